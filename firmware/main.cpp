// Firmware entry point, the same for every board: the board brings up its peripherals, the
// main loop runs until the camera finishes (QEMU replay) or forever (live board).
#include "firmware/boards/board.h"
#include "firmware/main_loop.h"

int main() {
  using namespace bv::fw;
  BoardServices board;
  const bv::Status init = BoardInit(board);
  if (!init.ok()) {
    BoardLog("firmware: board init failed: ");
    BoardLog(init.message());
    BoardLog("\n");
    BoardExit(2);
  }
  static MainLoop loop(*board.camera, *board.uart, *board.clock, *board.storage,
                       BoardPipelineTables(), BoardBlobScratch(kBlobScratchBytes), board.config,
                       board.watchdog, BoardUploadBuffer());
  const bv::Status start = loop.Init();
  if (!start.ok()) {
    // Keep going: the status packets report the camera fault (kFaultCameraStart).
    BoardLog("firmware: camera start failed: ");
    BoardLog(start.message());
    BoardLog("\n");
  }
  loop.RunUntilFinished();
  BoardLog(loop.pipeline_ready() ? "firmware: done\n" : "firmware: done (no calibration)\n");
  BoardExit(start.ok() ? 0 : 3);
}
