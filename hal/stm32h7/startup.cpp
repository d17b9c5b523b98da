// Vector table, reset and fault handling for the STM32H743 (no vendor startup code).
#include <cstdint>
#include <cstring>
#include <new>

#include "hal/stm32h7/registers.h"
#include "hal/stm32h7/system.h"

extern "C" {
int main();
[[noreturn]] void Reset_Handler();
void Fault_Handler();
void Default_Handler();
// Driver interrupts (hal/stm32h7/camera.cpp, uart.cpp).
void DCMI_IRQHandler();
void DMA2_Stream1_IRQHandler();
void DMA1_Stream0_IRQHandler();
void DMA1_Stream1_IRQHandler();
void USART1_IRQHandler();
}

namespace {

using Vector = void (*)();

// The last fault survives the reset it triggers (.noinit is neither copied nor zeroed), for a
// debugger; not yet reported in the status packet.
struct FaultRecord {
  uint32_t magic, cfsr, hfsr, bfar, pc;
};

}  // namespace

__attribute__((section(".noinit"))) FaultRecord g_last_fault;

constexpr Vector MakeTable(int i) {
  switch (i) {
    case 0:
      return nullptr;  // replaced below by the stack pointer
    case 1:
      return Reset_Handler;
    case 2:
    case 3:
    case 4:
    case 5:
    case 6:
      return Fault_Handler;
    case 7:
    case 8:
    case 9:
    case 10:
    case 13:
      return nullptr;
    default:
      break;
  }
  switch (i - 16) {
    case bv::h7::kIrqDma1Stream0:
      return DMA1_Stream0_IRQHandler;
    case bv::h7::kIrqDma1Stream1:
      return DMA1_Stream1_IRQHandler;
    case bv::h7::kIrqUsart1:
      return USART1_IRQHandler;
    case bv::h7::kIrqDma2Stream1:
      return DMA2_Stream1_IRQHandler;
    case bv::h7::kIrqDcmi:
      return DCMI_IRQHandler;
    default:
      return Default_Handler;
  }
}

struct VectorTable {
  const void* stack;
  Vector handlers[16 + bv::h7::kIrqCount - 1];
};

constexpr VectorTable BuildTable() {
  VectorTable t{&__stack_top, {}};
  for (int i = 1; i < 16 + bv::h7::kIrqCount; ++i) t.handlers[i - 1] = MakeTable(i);
  return t;
}

extern "C" __attribute__((section(".vectors"), used)) const VectorTable g_vectors = BuildTable();

extern "C" void Reset_Handler() {
  using namespace bv::h7;
  bv::cm7::EnableFpuAndFaultTraps();
  kScb->VTOR = reinterpret_cast<uint32_t>(&g_vectors);

  ClockTreeInit();
  bv::cm7::InitDataAndBss();

  // Caches on: I-cache, then D-cache (invalidated by set/way first). DMA buffers are kept
  // coherent by the drivers with clean/invalidate by address.
  asm volatile("dsb\n isb" ::: "memory");
  kScb->ICIALLU = 0;
  asm volatile("dsb\n isb" ::: "memory");
  kScb->CCR = kScb->CCR | (1u << 17);
  kCacheId->CSSELR = 0;
  asm volatile("dsb" ::: "memory");
  const uint32_t ccsidr = kCacheId->CCSIDR;
  const uint32_t sets = ((ccsidr >> 13) & 0x7FFFu) + 1;
  const uint32_t ways = ((ccsidr >> 3) & 0x3FFu) + 1;
  for (uint32_t s = 0; s < sets; ++s) {
    for (uint32_t w = 0; w < ways; ++w) kScb->DCISW = (s << 5) | (w << 30);
  }
  asm volatile("dsb" ::: "memory");
  kScb->CCR = kScb->CCR | (1u << 16);
  asm volatile("dsb\n isb" ::: "memory");

  bv::cm7::RunConstructors();
  main();
  SystemReset();
}

extern "C" __attribute__((naked)) void Fault_Handler() {
  asm volatile("mrs r0, msp\n b FaultReport");
}

extern "C" [[noreturn]] __attribute__((used)) void FaultReport(const uint32_t* frame) {
  using namespace bv::h7;
  g_last_fault = FaultRecord{0xFA017u, kScb->CFSR, kScb->HFSR, kScb->BFAR, frame[6]};
  ItmWrite("FAULT: reset\n");
  SystemReset();
}

extern "C" void Default_Handler() {
  bv::h7::ItmWrite("FAULT: unexpected interrupt\n");
  bv::h7::SystemReset();
}

extern "C" [[noreturn]] void __assert_func(const char* file, int, const char*, const char* expr) {
  bv::h7::ItmWrite("ASSERT ");
  bv::h7::ItmWrite(file != nullptr ? file : "?");
  bv::h7::ItmWrite(": ");
  bv::h7::ItmWrite(expr != nullptr ? expr : "?");
  bv::h7::ItmWrite("\n");
  bv::h7::SystemReset();
}

// See hal/qemu_mps2/startup.cpp: nothing is ever allocated or destroyed.
void operator delete(void*) noexcept { bv::h7::SystemReset(); }
void operator delete(void*, size_t) noexcept { bv::h7::SystemReset(); }
void operator delete(void*, std::align_val_t) noexcept { bv::h7::SystemReset(); }
void operator delete(void*, size_t, std::align_val_t) noexcept { bv::h7::SystemReset(); }
extern "C" int atexit(void (*)()) { return 0; }
