// Vector table, reset and fatal-error reporting for mps2-an500 (everything in C++, no crt0);
// the handlers themselves are shared (hal/cortex_m/startup.cpp).
#include <cstdint>

#include "hal/cortex_m/startup.h"
#include "hal/qemu_mps2/registers.h"
#include "hal/qemu_mps2/semihosting.h"

extern "C" {
int main();
void WatchdogTick_IRQHandler();  // hal/qemu_mps2/watchdog.cpp
void UART0RX_IRQHandler();       // the board bring-up (firmware/boards/qemu_mps2)
}

namespace {

// Exit codes a test can tell apart: 100 fault, 101 failed assert (or a never-called hook),
// 102 unexpected interrupt.
constexpr int kExitFault = 100;
constexpr int kExitAssert = 101;
constexpr int kExitUnexpectedIrq = 102;

// External interrupts: only UART0 RX; the rest is polled.
constexpr bv::cm7::IrqVector kIrqs[] = {{bv::qemu::kIrqUart0Rx, UART0RX_IRQHandler}};

}  // namespace

extern "C" __attribute__((section(".vectors"), used)) const bv::cm7::VectorTable<32> g_vectors =
    bv::cm7::MakeVectorTable<32>(&__stack_top, WatchdogTick_IRQHandler, kIrqs);

extern "C" void Reset_Handler() {
  bv::cm7::EnableFpuAndFaultTraps();
  bv::cm7::InitDataAndBss();
  bv::cm7::RunConstructors();
  bv::qemu::SemiExit(main());
}

void bv::cm7::OnFatal(const FatalReport& r) {
  using namespace bv::qemu;
  switch (r.kind) {
    case FatalReport::Kind::kFault:
      SemiWrite0("FAULT: firmware crashed\n");
      SemiWriteHex("IPSR", r.ipsr);
      SemiWriteHex("CFSR", r.cfsr);
      SemiWriteHex("HFSR", r.hfsr);
      SemiWriteHex("BFAR", r.bfar);
      SemiWriteHex("MMFAR", r.mmfar);
      SemiWriteHex("PC", r.pc);
      SemiWriteHex("LR", r.lr);
      SemiExit(kExitFault);
    case FatalReport::Kind::kAssert:
      SemiWrite0("ASSERT ");
      SemiWrite0(r.file != nullptr ? r.file : "?");
      SemiWriteDec(" line", static_cast<uint64_t>(r.line));
      SemiWrite0(r.func != nullptr ? r.func : "?");
      SemiWrite0(": ");
      SemiWrite0(r.what != nullptr ? r.what : "?");
      SemiWrite0("\n");
      SemiExit(kExitAssert);
    case FatalReport::Kind::kUnexpectedIrq:
      SemiWrite0("FAULT: unexpected interrupt\n");
      SemiWriteHex("IPSR", r.ipsr);
      SemiExit(kExitUnexpectedIrq);
    case FatalReport::Kind::kUnreachable:
      break;
  }
  SemiWrite0("FAULT: never-called hook reached: ");
  SemiWrite0(r.what != nullptr ? r.what : "?");
  SemiWrite0("\n");
  SemiExit(kExitAssert);
}
