#pragma once
// Monotonic microseconds from TIM2 (32-bit, 1 MHz), extended to 64 bits on read.
#include <cstdint>

#include "hal/clock.h"

namespace bv::h7 {

class Tim2Clock : public hal::Clock {
 public:
  void Init();

 private:
  uint64_t DoNowUs() const override;
  mutable uint32_t last_ = 0;
  mutable uint64_t high_ = 0;
};

}  // namespace bv::h7
