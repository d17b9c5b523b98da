#include "hal/qemu_mps2/watchdog.h"

#include "hal/qemu_mps2/registers.h"
#include "hal/qemu_mps2/semihosting.h"

namespace bv::qemu {
namespace {

constexpr uint32_t kTickMs = 10;
// Until the loop's first feed, boot (blob checks, table builds) gets this much longer.
constexpr uint32_t kBootFactor = 3;
volatile uint32_t g_ticks_since_feed = 0;
volatile bool g_fed = false;
uint32_t g_limit_ticks = 0;

}  // namespace

void SysTickWatchdog::Start(uint32_t cpu_hz, uint32_t timeout_ms) {
  g_limit_ticks = (timeout_ms + kTickMs - 1) / kTickMs;
  g_ticks_since_feed = 0;
  kSysTick->RVR = cpu_hz / 1000 * kTickMs - 1;  // 24-bit: fine up to 1.6 GHz at 10 ms
  kSysTick->CVR = 0;
  kSysTick->CSR = 0x7;  // enable, interrupt, processor clock
}

void SysTickWatchdog::Stop() { kSysTick->CSR = 0; }

void SysTickWatchdog::DoFeed() {
  g_ticks_since_feed = 0;
  g_fed = true;
}

}  // namespace bv::qemu

// Named *_IRQHandler so firmware/tools/size_report.py counts its stack like every interrupt.
extern "C" void WatchdogTick_IRQHandler() {
  using namespace bv::qemu;
  const uint32_t ticks = g_ticks_since_feed + 1;
  g_ticks_since_feed = ticks;
  if (ticks < (g_fed ? g_limit_ticks : kBootFactor * g_limit_ticks)) return;
  SemiWrite0("WATCHDOG: the main loop stopped feeding the watchdog\n");
  SemiWriteDec("WATCHDOG: ms since last feed", uint64_t{ticks} * kTickMs);
  SemiExit(kExitWatchdog);
}
