// Vector table, reset and fatal-error reporting for the STM32H743 (no vendor startup code); the
// handlers themselves are shared (hal/cortex_m/startup.cpp).
#include <cstdint>

#include "hal/cortex_m/startup.h"
#include "hal/stm32h7/registers.h"
#include "hal/stm32h7/system.h"

extern "C" {
int main();
// Driver interrupts, wired to the drivers by the board bring-up (firmware/boards/stm32h7).
void DCMI_IRQHandler();
void DMA2_Stream1_IRQHandler();
void DMA1_Stream0_IRQHandler();
void DMA1_Stream1_IRQHandler();
void USART1_IRQHandler();
}

namespace {

// The last fault survives the reset it triggers (.noinit is neither copied nor zeroed), for a
// debugger; not yet reported in the status packet.
struct FaultRecord {
  uint32_t magic, cfsr, hfsr, bfar, pc;
};

constexpr bv::cm7::IrqVector kIrqs[] = {
    {bv::h7::kIrqDma1Stream0, DMA1_Stream0_IRQHandler},
    {bv::h7::kIrqDma1Stream1, DMA1_Stream1_IRQHandler},
    {bv::h7::kIrqUsart1, USART1_IRQHandler},
    {bv::h7::kIrqDma2Stream1, DMA2_Stream1_IRQHandler},
    {bv::h7::kIrqDcmi, DCMI_IRQHandler},
};

}  // namespace

__attribute__((section(".noinit"))) FaultRecord g_last_fault;

extern "C" __attribute__((section(".vectors"), used)) const bv::cm7::VectorTable<bv::h7::kIrqCount>
    g_vectors = bv::cm7::MakeVectorTable<bv::h7::kIrqCount>(&__stack_top, Default_Handler, kIrqs);

extern "C" void Reset_Handler() {
  using namespace bv::h7;
  bv::cm7::EnableFpuAndFaultTraps();
  kScb->VTOR = reinterpret_cast<uint32_t>(&g_vectors);

  ClockTreeInit();
  bv::cm7::InitDataAndBss();

  // DMA buffers are kept coherent by the drivers with clean/invalidate by address.
  bv::cm7::EnableCaches();

  bv::cm7::RunConstructors();
  main();
  SystemReset();
}

void bv::cm7::OnFatal(const FatalReport& r) {
  using namespace bv::h7;
  switch (r.kind) {
    case FatalReport::Kind::kFault:
      g_last_fault = FaultRecord{0xFA017u, r.cfsr, r.hfsr, r.bfar, r.pc};
      ItmWrite("FAULT: reset\n");
      break;
    case FatalReport::Kind::kAssert:
      ItmWrite("ASSERT ");
      ItmWrite(r.file != nullptr ? r.file : "?");
      ItmWrite(": ");
      ItmWrite(r.what != nullptr ? r.what : "?");
      ItmWrite("\n");
      break;
    case FatalReport::Kind::kUnexpectedIrq:
      ItmWrite("FAULT: unexpected interrupt\n");
      break;
    case FatalReport::Kind::kUnreachable:
      ItmWrite("FAULT: never-called hook reached\n");
      break;
  }
  SystemReset();
}
