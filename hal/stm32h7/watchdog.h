#pragma once
// The independent watchdog (IWDG1, LSI clock): resets the board ~0.5 s after the last feed.
#include "hal/watchdog.h"

namespace bv::h7 {

class IndependentWatchdog : public hal::Watchdog {
 public:
  /// Starts it; once started only a reset stops it.
  void Start();

 private:
  void DoFeed() override;
};

}  // namespace bv::h7
