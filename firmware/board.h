#pragma once
// What each board (hal/qemu_mps2, hal/stm32h7) provides to the board-independent firmware:
// exactly one implementation is linked into an image.
#include <cstddef>
#include <span>

#include "core/common/status.h"
#include "firmware/main_loop.h"
#include "hal/camera.h"
#include "hal/clock.h"
#include "hal/storage.h"
#include "hal/uart.h"

namespace bv::fw {

struct BoardServices {
  hal::Camera* camera = nullptr;
  hal::Uart* uart = nullptr;
  hal::Clock* clock = nullptr;
  hal::Storage* storage = nullptr;
  const uint32_t* camera_bad_input = nullptr;  // optional counter of rejected camera input
  MainLoopConfig config;
};

/// Brings up clocks, UART, storage and camera and hands out the board's singletons. Errors are
/// fatal for the image (e.g. no camera source); the caller logs them and exits.
Status BoardInit(BoardServices& out);
/// Scratch RAM for validating one blob at boot, at least `min_bytes` (outside the static RAM
/// budget where the board has external RAM).
std::span<uint8_t> BoardBlobScratch(size_t min_bytes);
/// RAM for blob uploads from the main computer (kUploadBufferBytes, external RAM where the
/// board has it); empty if the board cannot take uploads.
std::span<uint8_t> BoardUploadBuffer();
/// Diagnostic text on the board's debug channel (never the packet UART).
void BoardLog(const char* text);
/// Flushes the UART and stops: QEMU exits with `code`; a live board resets.
[[noreturn]] void BoardExit(int code);

}  // namespace bv::fw
