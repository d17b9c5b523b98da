#include "hal/stm32h7/clock.h"

#include "hal/stm32h7/registers.h"
#include "hal/stm32h7/system.h"

namespace bv::h7 {

void Tim2Clock::Init() {
  kRcc->APB1LENR = kRcc->APB1LENR | (1u << 0);
  (void)kRcc->APB1LENR;
  kTim2->CR1 = 0;
  kTim2->PSC = kTimerHz / 1000000 - 1;
  kTim2->ARR = 0xFFFFFFFFu;
  kTim2->EGR = 1;  // load the prescaler
  kTim2->CR1 = 1;
}

uint64_t Tim2Clock::ReadUs() const {
  // Also called from the capture interrupt (exposure timestamps): keep the extension atomic.
  const uint32_t primask = IrqSave();
  const uint32_t now = kTim2->CNT;
  if (now < last_) high_ += 1ull << 32;
  last_ = now;
  const uint64_t t = high_ | now;
  IrqRestore(primask);
  return t;
}

}  // namespace bv::h7
