// Vector table, reset and fault handling for mps2-an500 (everything in C++, no crt0).
#include <cstdint>
#include <cstring>
#include <new>

#include "hal/qemu_mps2/registers.h"
#include "hal/qemu_mps2/semihosting.h"

extern "C" {
int main();
[[noreturn]] void Reset_Handler();
[[noreturn]] void Fault_Handler();
void Default_Handler();
void WatchdogTick_IRQHandler();  // hal/qemu_mps2/watchdog.cpp
void UART0RX_IRQHandler();       // hal/qemu_mps2/board.cpp
}

namespace {

using Vector = void (*)();

// Exit codes a test can tell apart: 100 fault, 101 failed assert, 102 unexpected interrupt.
constexpr int kExitFault = 100;
constexpr int kExitAssert = 101;
constexpr int kExitUnexpectedIrq = 102;

}  // namespace

extern "C" __attribute__((section(".vectors"), used)) const Vector g_vectors[16 + 32] = {
    reinterpret_cast<Vector>(&__stack_top),
    Reset_Handler,
    Fault_Handler,  // NMI
    Fault_Handler,  // HardFault
    Fault_Handler,  // MemManage
    Fault_Handler,  // BusFault
    Fault_Handler,  // UsageFault
    nullptr,
    nullptr,
    nullptr,
    nullptr,
    Default_Handler,  // SVC
    Default_Handler,  // DebugMon
    nullptr,
    Default_Handler,          // PendSV
    WatchdogTick_IRQHandler,  // SysTick
    // External interrupts: only UART0 RX (IRQ 0); the rest is polled.
    UART0RX_IRQHandler,
    Default_Handler,
    Default_Handler,
    Default_Handler,
    Default_Handler,
    Default_Handler,
    Default_Handler,
    Default_Handler,
    Default_Handler,
    Default_Handler,
    Default_Handler,
    Default_Handler,
    Default_Handler,
    Default_Handler,
    Default_Handler,
    Default_Handler,
    Default_Handler,
    Default_Handler,
    Default_Handler,
    Default_Handler,
    Default_Handler,
    Default_Handler,
    Default_Handler,
    Default_Handler,
    Default_Handler,
    Default_Handler,
    Default_Handler,
    Default_Handler,
    Default_Handler,
    Default_Handler,
    Default_Handler,
    Default_Handler,
};

extern "C" void Reset_Handler() {
  using namespace bv::qemu;
  bv::cm7::EnableFpuAndFaultTraps();

  bv::cm7::InitDataAndBss();
  bv::cm7::RunConstructors();

  SemiExit(main());
}

// Naked so that r0 is the exception frame before the compiler pushes anything.
extern "C" __attribute__((naked)) void Fault_Handler() {
  asm volatile("mrs r0, msp\n b FaultReport");
}

extern "C" [[noreturn]] __attribute__((used)) void FaultReport(const uint32_t* frame) {
  using namespace bv::qemu;
  uint32_t ipsr;
  asm volatile("mrs %0, ipsr" : "=r"(ipsr));
  SemiWrite0("FAULT: firmware crashed\n");
  SemiWriteHex("IPSR", ipsr);
  SemiWriteHex("CFSR", kScb->CFSR);
  SemiWriteHex("HFSR", kScb->HFSR);
  SemiWriteHex("BFAR", kScb->BFAR);
  SemiWriteHex("MMFAR", kScb->MMFAR);
  SemiWriteHex("PC", frame[6]);  // stacked PC of the faulting instruction
  SemiWriteHex("LR", frame[5]);
  SemiExit(kExitFault);
}

extern "C" void Default_Handler() {
  bv::qemu::SemiWrite0("FAULT: unexpected interrupt\n");
  bv::qemu::SemiExit(kExitUnexpectedIrq);
}

// Newlib's version drags in stdio and malloc (and then fails the heap guard).
extern "C" [[noreturn]] void __assert_func(const char* file, int line, const char* func,
                                           const char* expr) {
  using namespace bv::qemu;
  SemiWrite0("ASSERT ");
  SemiWrite0(file != nullptr ? file : "?");
  SemiWriteDec(" line", static_cast<uint64_t>(line));
  SemiWrite0(func != nullptr ? func : "?");
  SemiWrite0(": ");
  SemiWrite0(expr != nullptr ? expr : "?");
  SemiWrite0("\n");
  SemiExit(kExitAssert);
}

// Virtual destructors make the compiler emit deleting destructors that reference operator
// delete; nothing is ever allocated, so these are never reached. Defining them keeps libstdc++'s
// versions (and through them free()/the allocator) out of the image.
void operator delete(void*) noexcept { bv::qemu::SemiExit(kExitAssert); }
void operator delete(void*, size_t) noexcept { bv::qemu::SemiExit(kExitAssert); }
void operator delete(void*, std::align_val_t) noexcept { bv::qemu::SemiExit(kExitAssert); }
void operator delete(void*, size_t, std::align_val_t) noexcept { bv::qemu::SemiExit(kExitAssert); }

// Function-local statics with (virtual) destructors register them through atexit() because of
// -fno-use-cxa-atexit. The firmware never returns from main (it exits through semihosting or
// loops forever), so nothing is ever destroyed: keep newlib's atexit tables out of the image.
extern "C" int atexit(void (*)()) { return 0; }
