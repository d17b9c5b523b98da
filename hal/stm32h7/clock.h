#pragma once
// Monotonic microseconds from TIM2 (32-bit, 1 MHz), extended to 64 bits on read.
#include <cstdint>

#include "hal/clock.h"

namespace bv::h7 {

class Tim2Clock final : public hal::Clock {
 public:
  void Init();
  /// NowUs() without the virtual call, for interrupt handlers (a bounded stack).
  uint64_t ReadUs() const;

 private:
  uint64_t DoNowUs() const override { return ReadUs(); }
  mutable uint32_t last_ = 0;
  mutable uint64_t high_ = 0;
};

}  // namespace bv::h7
