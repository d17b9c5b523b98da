#pragma once
// Software watchdog on SysTick: the interrupt counts ticks since the last feed and ends the run
// with exit code 103 (and a diagnostic) when the main loop stops feeding. The feed sits in the
// camera poll (every main-loop iteration asks for a pair), so only a loop that keeps iterating
// keeps it quiet; a real board would use its independent watchdog (IWDG) the same way.
#include <cstdint>

namespace bv::qemu {

inline constexpr int kExitWatchdog = 103;

/// Starts SysTick (processor clock `cpu_hz`) with a 10 ms tick; bites after `timeout_ms`.
void WatchdogStart(uint32_t cpu_hz, uint32_t timeout_ms);
void WatchdogStop();
/// Called by a healthy loop; cheap and safe before WatchdogStart().
void WatchdogFeed();

}  // namespace bv::qemu
