#pragma once
#include <cstdint>

namespace bv::hal {

/// Monotonic microseconds since an arbitrary epoch (boot). Never goes backwards.
class Clock {
 public:
  virtual ~Clock() = default;
  uint64_t NowUs() const { return DoNowUs(); }

 private:
  virtual uint64_t DoNowUs() const = 0;
};

}  // namespace bv::hal
