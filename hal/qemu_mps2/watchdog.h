#pragma once
// Software watchdog on SysTick (the MPS2 model has no watchdog QEMU implements): the interrupt
// counts ticks since the last feed and ends the run with exit code 103 and a diagnostic when the
// main loop stops feeding it.
#include <cstdint>

#include "hal/watchdog.h"

namespace bv::qemu {

inline constexpr int kExitWatchdog = 103;

class SysTickWatchdog : public hal::Watchdog {
 public:
  /// Starts SysTick (processor clock `cpu_hz`) with a 10 ms tick; bites after `timeout_ms`
  /// (three times that until the first feed: boot validates blobs and builds tables).
  void Start(uint32_t cpu_hz, uint32_t timeout_ms);
  void Stop();

 private:
  void DoFeed() override;
};

}  // namespace bv::qemu
