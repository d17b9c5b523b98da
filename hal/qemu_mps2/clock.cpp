#include "hal/qemu_mps2/clock.h"

namespace bv::qemu {

void DualTimerClock::Init() {
  regs_->CONTROL = 0;
  regs_->LOAD = 0xFFFFFFFFu;
  regs_->CONTROL = (1u << 7) | (1u << 1);  // enable, 32-bit, free-running, no IRQ
  last_count_ = 0;
  high_ = 0;
}

uint64_t DualTimerClock::Ticks() const {
  cm7::IrqLock lock;  // also read by the UART receive interrupt (arrival stamps)
  const uint32_t count = 0xFFFFFFFFu - regs_->VALUE;  // counts down from LOAD
  if (count < last_count_) high_ += 1ull << 32;
  last_count_ = count;
  return high_ | count;
}

}  // namespace bv::qemu
