// mps2-an500 board bring-up for the firmware. Command line (semihosting `arg=` items, joined by
// spaces, so paths must not contain spaces):
//   seq=DIR        captured sequence with raw .yuyv frames (required)
//   cal=FILE       calibration blob, stored into the calibration A/B slots (optional)
//   lut=FILE       colour LUT blob, stored into the LUT A/B slots (optional)
//   clf=FILE       ball classifier weights blob, stored into its A/B slots (optional)
//   frames=N       stop after N pairs (optional)
//   adapt=1        online colour adaptation on from boot (the cost benchmark)
//   period_us=N    frame period for the deadline accounting (default 33333)
//   rx_bytes=N     test aid: the replay ends only after N bytes arrived on UART0
//   capture_chunks=N  capture chunks queued per loop iteration at most (default 4); with
//                  QEMU's instantaneous UART, 4000 streams a whole full-size pair (2400 chunks) per
//                  iteration, so a capture takes consecutive pairs (replay test)
//   selftest=fault executes an undefined instruction (tests the fault handler)
//   inject=KIND@N[,KIND@N...]  fault injection keyed on the pair index N (from 0), for faults a
//                  frames.csv cannot express (swapped / jumping timestamps and a camera that
//                  stops are written into the test sequence instead):
//                    torn@N       pair N's omni slot is handed out half written (kPairTorn)
//                    drop@N       pairs N and N+1 complete before the loop polls (one dropped)
//                    uartstuck@N  UART0 transmits nothing after pair N is handed out
//                    hang@N       the loop hangs releasing pair N (the watchdog must bite)
// A software watchdog (hal/qemu_mps2/watchdog.h) fed by the main loop ends a stalled run with
// exit 103.
// At exit the board prints its own counters ("board: exit ..."), which survive a stuck UART.
#include <cstring>
#include <new>

#include "firmware/boards/board.h"
#include "hal/common/blob_store.h"
#include "hal/qemu_mps2/camera.h"
#include "hal/qemu_mps2/clock.h"
#include "hal/qemu_mps2/registers.h"
#include "hal/qemu_mps2/semihosting.h"
#include "hal/qemu_mps2/storage.h"
#include "hal/qemu_mps2/uart.h"
#include "hal/qemu_mps2/watchdog.h"

namespace bv::fw {
namespace {

using namespace bv::qemu;

// DMA frame slots and the RAM blob slots live in PSRAM (outside the static RAM budget).
__attribute__((section(".frames"), aligned(32))) FrameSlots g_frame_slots;
__attribute__((section(".psram"), aligned(32)))
uint8_t g_storage_mem[RamStorage::kSlots * RamStorage::kSlotBytes];

__attribute__((section(".psram"), aligned(32))) uint8_t g_upload[kUploadBufferBytes];
// Raw bytes: a NOLOAD section is not zeroed, and the tables are built in place after BoardInit.
__attribute__((section(".psram"))) alignas(bv::PipelineTables) uint8_t
    g_tables_mem[sizeof(bv::PipelineTables)];

// Far longer than a healthy iteration (a frame pair takes ~1 ms) and than activating an uploaded
// LUT (verify, A/B save, pipeline re-init: boot does the same work in ~0.2 s of virtual time).
constexpr uint32_t kWatchdogTimeoutMs = 1000;

char g_cmdline[512];
CmsdkUart* g_uart = nullptr;            // for the receive interrupt and the flush at exit
SemihostingCamera* g_camera = nullptr;  // for the exit summary
SysTickWatchdog g_watchdog;

// Finds "key=" in the command line and copies its value; false if absent or too long.
bool GetArg(const char* key, char* out, size_t out_size) {
  const size_t klen = std::strlen(key);
  const char* p = g_cmdline;
  while (*p != '\0') {
    while (*p == ' ') ++p;
    const char* tok = p;
    while (*p != '\0' && *p != ' ') ++p;
    const size_t tlen = static_cast<size_t>(p - tok);
    if (tlen > klen && std::strncmp(tok, key, klen) == 0 && tok[klen] == '=') {
      const size_t vlen = tlen - klen - 1;
      if (vlen + 1 > out_size) return false;
      std::memcpy(out, tok + klen + 1, vlen);
      out[vlen] = '\0';
      return true;
    }
  }
  return false;
}

bool ParseU32(const char* s, uint32_t& out) {
  uint64_t v = 0;
  if (*s == '\0') return false;
  for (; *s != '\0'; ++s) {
    if (*s < '0' || *s > '9') return false;
    v = v * 10 + static_cast<uint64_t>(*s - '0');
    if (v > UINT32_MAX) return false;
  }
  out = static_cast<uint32_t>(v);
  return true;
}

bool GetU32Arg(const char* key, uint32_t& out) {
  char buf[16];
  if (!GetArg(key, buf, sizeof(buf))) return false;
  if (ParseU32(buf, out)) return true;
  SemiWrite0("board: ignoring non-numeric argument ");
  SemiWrite0(key);
  SemiWrite0("\n");
  return false;
}

struct InjectPlan {
  CameraFaults camera;
  uint32_t uart_stuck_at = CameraFaults::kNever;
};

// Parses inject=KIND@N[,KIND@N...]; unknown or malformed items are reported and ignored.
InjectPlan ParseInject() {
  InjectPlan plan;
  char list[128];
  if (!GetArg("inject", list, sizeof(list))) return plan;
  char* item = list;
  while (*item != '\0') {
    char* end = item;
    while (*end != '\0' && *end != ',') ++end;
    const bool last = *end == '\0';
    *end = '\0';
    char* at = std::strchr(item, '@');
    uint32_t n = 0;
    uint32_t* target = nullptr;
    if (at != nullptr) {
      *at = '\0';
      if (std::strcmp(item, "torn") == 0) target = &plan.camera.torn_at;
      if (std::strcmp(item, "drop") == 0) target = &plan.camera.drop_at;
      if (std::strcmp(item, "uartstuck") == 0) target = &plan.uart_stuck_at;
      if (std::strcmp(item, "hang") == 0) target = &plan.camera.hang_at;
    }
    if (target != nullptr && ParseU32(at + 1, n) && n != CameraFaults::kNever) {
      *target = n;
      SemiWrite0("board: inject ");
      SemiWriteDec(item, n);
    } else {
      SemiWrite0("board: ignoring inject item ");
      SemiWrite0(item);
      SemiWrite0(" (expected torn@N, drop@N, uartstuck@N or hang@N)\n");
    }
    if (last) break;
    item = end + 1;
  }
  return plan;
}

void LogBlobProblem(const char* path, const char* what, const char* detail) {
  SemiWrite0("board: ");
  SemiWrite0(path);
  SemiWrite0(": ");
  SemiWrite0(what);
  SemiWrite0(detail);
  SemiWrite0("\n");
}

// Stores a blob file the way the firmware would after an upload: through the A/B BlobStore. A
// file that is not a valid blob is copied raw into slot A instead, standing in for a damaged
// flash slot, so the main loop's "corrupt" path can be exercised.
void LoadBlobArg(RamStorage& storage, const char* key, const int (&slots)[2], BlobKind kind,
                 uint16_t max_version) {
  char path[SemihostingCamera::kMaxPath + 1];
  if (!GetArg(key, path, sizeof(path))) return;
  // Before the camera starts, two DMA slots serve as file and read-back buffers.
  const std::span<uint8_t> file(g_frame_slots[1][0], kFrameBytes);
  const std::span<uint8_t> verify(g_frame_slots[1][1], kFrameBytes);
  const Result<size_t> n = SemiReadFile(path, file);
  if (!n.ok()) {
    LogBlobProblem(path, "", n.status().message());
    return;
  }
  hal::BlobStore store(storage, slots[0], slots[1], kind, max_version);
  const Status st = store.Save(file.first(*n), verify);
  if (st.ok()) return;
  LogBlobProblem(path, "not stored through the blob store, copied raw into slot A: ", st.message());
  const size_t raw = *n < storage.slot_size() ? *n : storage.slot_size();
  if (!storage.Erase(slots[0]).ok() || !storage.Write(slots[0], 0, file.first(raw)).ok()) {
    LogBlobProblem(path, "", "raw copy failed");
  }
}

}  // namespace

Status BoardInit(BoardServices& out) {
  static CmsdkUart uart(kUart0, kNvic);
  static DualTimerClock clock(kDualTimer1);
  static RamStorage storage(g_storage_mem);
  clock.Init();
  g_uart = &uart;
  uart.Init(&clock);
  storage.Init();

  if (!SemiGetCmdline(g_cmdline, sizeof(g_cmdline))) {
    return Status(StatusCode::kInvalidArgument, "board: semihosting command line too long");
  }
  char mode[16];
  if (GetArg("selftest", mode, sizeof(mode)) && std::strcmp(mode, "fault") == 0) {
    // QEMU's MPS2 model answers reads of unimplemented addresses with zero instead of a bus
    // fault, so the self-test uses a permanently undefined instruction (UsageFault UNDEFINSTR).
    SemiWrite0("board: selftest=fault, executing an undefined instruction\n");
    asm volatile("udf #0");
  }

  uint32_t value = 0;
  if (GetU32Arg("period_us", value) && value > 0) out.config.frame_period_us = value;
  if (GetU32Arg("capture_chunks", value) && value > 0) out.config.capture_chunks_per_poll = value;
  if (GetU32Arg("adapt", value)) out.config.color_adaptation = value != 0;
  uint32_t max_pairs = 0;
  GetU32Arg("frames", max_pairs);

  LoadBlobArg(storage, "cal", out.config.calibration_slots, BlobKind::kCalibration,
              kCalibrationBlobVersion);
  LoadBlobArg(storage, "lut", out.config.lut_slots, BlobKind::kColorLut, kColorLutBlobVersion);
  LoadBlobArg(storage, "clf", out.config.classifier_slots, BlobKind::kBallClassifier,
              kBallClassifierBlobVersion);

  char seq[SemihostingCamera::kMaxPath + 1];
  if (!GetArg("seq", seq, sizeof(seq))) {
    return Status(StatusCode::kInvalidArgument,
                  "board: no seq=DIR on the semihosting command line");
  }
  static SemihostingCamera camera(g_frame_slots, seq, hal::PairerConfig(), max_pairs);

  uint32_t rx_bytes = 0;
  if (GetU32Arg("rx_bytes", rx_bytes)) camera.HoldOpenUntil(uart.rx_bytes(), rx_bytes);
  const InjectPlan plan = ParseInject();
  camera.InjectFaults(plan.camera);
  if (plan.uart_stuck_at != CameraFaults::kNever) {
    // Stuck once pair N has been handed out: pairs_served > N.
    uart.StallTxAfter(camera.pairs_served_counter(), plan.uart_stuck_at);
  }
  camera.SetClock(&clock);
  g_camera = &camera;
  g_watchdog.Start(kTimerClockHz, kWatchdogTimeoutMs);

  out.camera = &camera;
  out.uart = &uart;
  out.clock = &clock;
  out.storage = &storage;
  out.watchdog = &g_watchdog;
  return Status();
}

std::span<uint8_t> BoardBlobScratch(size_t min_bytes) {
  // The main loop validates blobs before the camera starts: lend it a DMA slot.
  static_assert(kFrameBytes >= kBlobScratchBytes);
  (void)min_bytes;
  return std::span<uint8_t>(g_frame_slots[0][0], kFrameBytes);
}

PipelineTables& BoardPipelineTables() { return *new (g_tables_mem) PipelineTables; }

std::span<uint8_t> BoardUploadBuffer() { return g_upload; }

void BoardLog(const char* text) { SemiWrite0(text); }

void BoardExit(int code) {
  g_watchdog.Stop();
  // The UART (ring + hardware) is fully drained before QEMU exits and closes the serial file
  // (unless its transmitter is stalled by fault injection: then the summary below is all).
  if (g_uart != nullptr) g_uart->Flush();
  // One "board: exit name=value" line per counter (the QEMU tests read them).
  auto line = [](const char* name, uint64_t value) {
    SemiWrite0("board: exit ");
    SemiWriteDec(name, value);
  };
  if (g_camera != nullptr) {
    line("pairs_served", *g_camera->pairs_served_counter());
    line("frames_dropped", g_camera->frames_dropped());
    line("pairs_torn", g_camera->pairs_torn());
    line("max_hold_us", g_camera->max_hold_us());
  }
  if (g_uart != nullptr) {
    line("uart_writes_refused", g_uart->writes_refused());
    line("uart_bytes_sent", g_uart->bytes_sent());
    line("uart_bytes_queued", g_uart->bytes_queued());
  }
  SemiExit(code);
}

}  // namespace bv::fw

extern "C" void UART0RX_IRQHandler() { bv::fw::g_uart->OnRxIrq(); }
