#pragma once
// What each board's bring-up (firmware/boards/<board>/board.cpp, on that board's drivers in
// hal/<board>) provides to the board-independent firmware: exactly one is linked into an image.
#include <cstddef>
#include <span>

#include "core/common/status.h"
#include "firmware/main_loop.h"
#include "hal/camera.h"
#include "hal/clock.h"
#include "hal/storage.h"
#include "hal/uart.h"
#include "hal/watchdog.h"

namespace bv::fw {

struct BoardServices {
  hal::Camera* camera = nullptr;
  hal::Uart* uart = nullptr;
  hal::Clock* clock = nullptr;
  hal::Storage* storage = nullptr;
  hal::Watchdog* watchdog = nullptr;  // started by BoardInit, fed by the main loop
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
/// The pipeline's scan tables, built in external RAM where the board has it. Call after
/// BoardInit (which brings that RAM up), once.
PipelineTables& BoardPipelineTables();
/// Diagnostic text on the board's debug channel (never the packet UART).
void BoardLog(const char* text);
/// Flushes the UART and stops: QEMU exits with `code`; a live board resets.
[[noreturn]] void BoardExit(int code);

}  // namespace bv::fw
