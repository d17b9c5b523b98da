// STM32H743 board bring-up for the firmware: clocks (in Reset_Handler), pins, SDRAM, TIM2,
// USART1 + DMA, flash blob slots, DCMI camera, watchdog.
#include <new>

#include "firmware/boards/board.h"
#include "hal/stm32h7/camera.h"
#include "hal/stm32h7/clock.h"
#include "hal/stm32h7/flash_storage.h"
#include "hal/stm32h7/registers.h"
#include "hal/stm32h7/system.h"
#include "hal/stm32h7/uart.h"
#include "hal/stm32h7/watchdog.h"

namespace {

using namespace bv::h7;

// DMA capture slots in external SDRAM (outside the static RAM budget).
__attribute__((section(".frames"), aligned(32))) CaptureSlots g_capture_slots;

__attribute__((section(".sdram"), aligned(32))) uint8_t g_upload[bv::fw::kUploadBufferBytes];
// Raw bytes: a NOLOAD section is not zeroed, and the tables are built in place after BoardInit.
__attribute__((section(".sdram"))) alignas(bv::PipelineTables) uint8_t
    g_tables_mem[sizeof(bv::PipelineTables)];

Tim2Clock g_clock;
DmaUart g_uart;
FlashStorage g_storage;
DcmiCamera g_camera(g_capture_slots, g_clock, bv::hal::PairerConfig());
IndependentWatchdog g_watchdog;

}  // namespace

extern "C" void DMA1_Stream0_IRQHandler() { g_uart.OnTxDmaIrq(); }
extern "C" void DMA1_Stream1_IRQHandler() { g_uart.OnRxDmaIrq(); }
extern "C" void USART1_IRQHandler() { g_uart.OnUsartIrq(); }
extern "C" void DMA2_Stream1_IRQHandler() { g_camera.OnDmaIrq(); }
extern "C" void DCMI_IRQHandler() { g_camera.OnDcmiIrq(); }

namespace bv::fw {

Status BoardInit(BoardServices& out) {
  PinsInit();
  SdramInit();
  g_clock.Init();
  g_uart.Init(&g_clock);
  g_watchdog.Start();
  out.camera = &g_camera;
  out.uart = &g_uart;
  out.clock = &g_clock;
  out.storage = &g_storage;
  out.watchdog = &g_watchdog;
  return Status();
}

std::span<uint8_t> BoardBlobScratch(size_t min_bytes) {
  // Blobs are validated before the camera starts: lend the first capture slot.
  static_assert(kSlotBytes >= kBlobScratchBytes);
  (void)min_bytes;
  return std::span<uint8_t>(g_capture_slots[0], kSlotBytes);
}

PipelineTables& BoardPipelineTables() { return *new (g_tables_mem) PipelineTables; }

std::span<uint8_t> BoardUploadBuffer() { return g_upload; }

void BoardLog(const char* text) { ItmWrite(text); }

void BoardExit(int code) {
  (void)code;
  g_uart.Flush();
  SystemReset();  // a live board never ends; a fatal init error restarts it
}

}  // namespace bv::fw
