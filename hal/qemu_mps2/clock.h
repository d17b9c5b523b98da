#pragma once
// Monotonic microseconds from the CMSDK dual timer 1 (25 MHz, 32-bit, free-running down
// counter), extended to 64 bits. Deterministic with `-icount shift=0` (1 tick = 40 instructions).
#include <cstdint>

#include "hal/clock.h"
#include "hal/qemu_mps2/registers.h"

namespace bv::qemu {

class DualTimerClock final : public hal::Clock {
 public:
  explicit DualTimerClock(CmsdkDualTimerRegs* regs) : regs_(regs) {}
  void Init();
  /// 64-bit tick count; must be called at least once per 2^32 ticks (171 s) to see every wrap.
  uint64_t Ticks() const;
  /// NowUs() without the virtual call, for interrupt handlers (a bounded stack).
  uint64_t ReadUs() const { return Ticks() / (kTimerClockHz / 1000000); }

 private:
  uint64_t DoNowUs() const override { return ReadUs(); }

  CmsdkDualTimerRegs* regs_;
  mutable uint32_t last_count_ = 0;  // elapsed ticks (up-count) at the last read
  mutable uint64_t high_ = 0;
};

}  // namespace bv::qemu
