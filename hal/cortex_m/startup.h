#pragma once
// What every Cortex-M7 image shares: the vector table's layout and the handlers for faults,
// failed asserts, unexpected interrupts and the never-called allocator hooks (startup.cpp).
// A board supplies Reset_Handler, its table (MakeVectorTable) and OnFatal: how to report and stop.
#include <cstddef>
#include <cstdint>

extern "C" {
[[noreturn]] void Reset_Handler();  // the board's startup
void Fault_Handler();
void Default_Handler();
}

namespace bv::cm7 {

using Vector = void (*)();

struct IrqVector {
  int irq;  // external interrupt number (vector 16 + irq)
  Vector handler;
};

template <int kIrqCount>
struct VectorTable {
  const void* stack;
  Vector handlers[15 + kIrqCount];  // exceptions 1..15, then IRQ 0 .. kIrqCount - 1
};

/// The boot table: reset, the five fault vectors to Fault_Handler, SysTick to `systick`, each
/// listed IRQ to its handler, every other vector to Default_Handler (reserved ones null).
template <int kIrqCount, size_t N>
constexpr VectorTable<kIrqCount> MakeVectorTable(const void* stack, Vector systick,
                                                 const IrqVector (&irqs)[N]) {
  VectorTable<kIrqCount> t{stack, {}};
  for (int v = 1; v < 16 + kIrqCount; ++v) {
    Vector h = Default_Handler;
    if (v == 1) h = Reset_Handler;
    if (v >= 2 && v <= 6) h = Fault_Handler;  // NMI, HardFault, MemManage, BusFault, UsageFault
    if ((v >= 7 && v <= 10) || v == 13) h = nullptr;
    if (v == 15) h = systick;
    t.handlers[v - 1] = h;
  }
  for (const IrqVector& e : irqs) t.handlers[15 + e.irq] = e.handler;
  return t;
}

struct FatalReport {
  enum class Kind : uint8_t { kFault, kAssert, kUnexpectedIrq, kUnreachable };
  Kind kind = Kind::kFault;
  // kFault: the exception and the fault status registers; pc/lr are the stacked ones.
  uint32_t ipsr = 0, cfsr = 0, hfsr = 0, bfar = 0, mmfar = 0, pc = 0, lr = 0;
  // kAssert (null when the compiler gave none); kUnreachable: `what` names the hook.
  const char* file = nullptr;
  int line = 0;
  const char* func = nullptr;
  const char* what = nullptr;
};

/// Provided by each board: report on its debug channel, then stop (QEMU: exit; a board: reset).
[[noreturn]] void OnFatal(const FatalReport& report);

}  // namespace bv::cm7
