// ballvision capture: frames from the coprocessor over the serial link, written as a captured
// sequence (../shared/DESIGN.md §4) that `ballvision run` replays. On a serial device, pty or
// tcp:HOST:PORT it sends the capture request and decodes the answer; a file or '-' holds a
// recorded stream and is only decoded.
#include <fcntl.h>
#include <netdb.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "core/common/image.h"
#include "core/protocol/commands.h"
#include "core/protocol/link.h"
#include "core/protocol/protocol.h"
#include "tools/ballvision/calib_io.h"
#include "tools/ballvision/capture_collector.h"
#include "tools/ballvision/cli_args.h"
#include "tools/ballvision/commands.h"
#include "tools/ballvision/link_io.h"
#include "tools/ballvision/safe_write.h"
#include "tools/ballvision/signals.h"

namespace bv::cli {
namespace {

constexpr uint32_t kRequestSeq = 1;  // sequence number of our capture request

const char* const kCaptureUsage =
    "usage: ballvision capture SOURCE --out SEQ_DIR [--pairs N]\n"
    "                          [--mode full|half|quarter|scanlines] [--calib FILE]\n"
    "                          [--cameras both|omni|persp] [--baud N] [--seconds S]\n"
    "  Asks the coprocessor for the next N frame pairs (1..100, default 1: a snapshot) and\n"
    "  writes SEQ_DIR/frames.csv (index = the device's frame counter), one .yuyv per\n"
    "  image, capture.csv (pair index, per-camera exposure times and frame counters) and\n"
    "  capture.json (mode, complete or not and why).\n"
    "  Half and quarter images are scaled back to 640x480 (nearest) so `run` replays them.\n"
    "  scanlines: only the pixels the front end reads on its scan tables; --calib FILE (the\n"
    "  calibration the device uses) places them, every other pixel is fill (grey);\n"
    "  scan_mask_omni.pgm / scan_mask_persp.pgm mark the real pixels.\n"
    "  SOURCE: a serial device or pty, tcp:HOST:PORT, or a file / '-' holding a recorded\n"
    "  stream (decoded only, no request sent). Exit 1 when the capture is incomplete (the\n"
    "  pairs written are still a valid sequence; capture.json says what is missing).\n";

const char* ModeName(protocol::CaptureMode m) {
  switch (m) {
    case protocol::CaptureMode::kFull:
      return "full";
    case protocol::CaptureMode::kHalf:
      return "half";
    case protocol::CaptureMode::kQuarter:
      return "quarter";
    case protocol::CaptureMode::kScanlines:
      return "scanlines";
  }
  return "?";
}

const char* EndName(protocol::CaptureEndReason r) {
  switch (r) {
    case protocol::CaptureEndReason::kComplete:
      return "complete";
    case protocol::CaptureEndReason::kStopped:
      return "stopped";
    case protocol::CaptureEndReason::kCameraFinished:
      return "camera finished";
  }
  return "?";
}

std::string JsonString(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

// Why the coprocessor refused a command (protocol ErrorCode), by code.
const char* const kRefusalWhy[] = {"",
                                   "unknown command",
                                   "bad length",
                                   "",
                                   "",
                                   "",
                                   "",
                                   "",
                                   "",
                                   "",
                                   "bad value",
                                   "",
                                   "busy: a capture is running",
                                   "this board cannot capture (scanlines: no scan table, the "
                                   "device has no calibration for a camera asked for)",
                                   ""};

const char* const kScanlinesNote =
    "only the scan-table samples are real (each sample's Y and its pixel pair's U, V, as the "
    "classifier read them; scan_mask_omni.pgm / scan_mask_persp.pgm mark them); every other pixel "
    "is fill (Y 128, U 128, V 128: grey, classified "
    "as nothing by the built-in table). The attention samples and region growing read fill "
    "there, so `ballvision run` on this sequence is NOT expected to give the device's ball "
    "output";

struct CaptureArgs {
  std::string source, out_dir, calib;
  int64_t pairs = 1;
  long baud = 921600;
  double seconds = 0;  // 0: as long as the request takes (DefaultSeconds)
  protocol::CaptureMode mode = protocol::CaptureMode::kFull;
  uint8_t cameras = protocol::kCaptureOmni | protocol::kCapturePersp;
};

// Returns -1 to go on, else the exit code.
int ParseCaptureArgs(int argc, char** argv, CaptureArgs& a) {
  ArgParser args("ballvision capture", kCaptureUsage);
  args.Positional("SOURCE", a.source)
      .Text("--out", a.out_dir)
      .Required("--out")
      .Int("--pairs", 1, protocol::kMaxCapturePairs, a.pairs)
      .Custom("--mode",
              [&a](const std::string& v, std::string& error) {
                if (v == "full") {
                  a.mode = protocol::CaptureMode::kFull;
                } else if (v == "half") {
                  a.mode = protocol::CaptureMode::kHalf;
                } else if (v == "quarter") {
                  a.mode = protocol::CaptureMode::kQuarter;
                } else if (v == "scanlines") {
                  a.mode = protocol::CaptureMode::kScanlines;
                } else {
                  error = "--mode: got '" + v + "', expected full, half, quarter or scanlines";
                  return false;
                }
                return true;
              })
      .Custom("--cameras",
              [&a](const std::string& v, std::string& error) {
                if (v == "both") {
                  a.cameras = protocol::kCaptureOmni | protocol::kCapturePersp;
                } else if (v == "omni") {
                  a.cameras = protocol::kCaptureOmni;
                } else if (v == "persp") {
                  a.cameras = protocol::kCapturePersp;
                } else {
                  error = "--cameras: got '" + v + "', expected both, omni or persp";
                  return false;
                }
                return true;
              })
      .Text("--calib", a.calib)
      .Int("--baud", 1, 4000000, a.baud)
      .Number("--seconds", 0.1, 1e6, a.seconds);
  return args.Parse(argc, argv);
}

// A new directory, or one without a sequence in it; false (printed) otherwise.
bool PrepareOutDir(const std::string& out_dir) {
  struct stat st {};
  if (lstat(out_dir.c_str(), &st) == 0) {
    if (!S_ISDIR(st.st_mode)) {
      std::fprintf(stderr, "ballvision capture: %s exists and is not a directory\n",
                   out_dir.c_str());
      return false;
    }
    const std::string csv = out_dir + "/frames.csv";
    if (access(csv.c_str(), F_OK) == 0) {
      std::fprintf(stderr,
                   "ballvision capture: %s already holds a sequence (frames.csv); "
                   "choose a new directory\n",
                   out_dir.c_str());
      return false;
    }
  } else if (mkdir(out_dir.c_str(), 0777) != 0) {
    std::fprintf(stderr, "ballvision capture: cannot create %s: %s\n", out_dir.c_str(),
                 std::strerror(errno));
    return false;
  }
  return true;
}

// False (printed) when the request cannot be sent.
bool SendRequest(int fd, const CaptureArgs& a) {
  uint8_t p[protocol::kCaptureStartBytes] = {static_cast<uint8_t>(a.pairs & 0xFF),
                                             static_cast<uint8_t>(a.pairs >> 8),
                                             static_cast<uint8_t>(a.mode), a.cameras};
  uint8_t wire[64];
  const Result<size_t> n =
      protocol::EncodeFrame(protocol::MsgType::kCaptureStart, kRequestSeq, p, wire);
  if (!n.ok() || write(fd, wire, *n) != static_cast<ssize_t>(*n)) {
    std::fprintf(stderr, "ballvision capture: cannot send the request to %s: %s\n",
                 a.source.c_str(), std::strerror(errno));
    return false;
  }
  return true;
}

double DefaultSeconds(const CaptureArgs& a) {
  // A full-size pair is ~14 s of link time at 921600 Bd; allow twice that. A scanline pair
  // (~3 bytes x 26 k samples) is about a quarter pair.
  const double pair_s = 2.0 * 1.23e6 / (a.baud / 10.0) /
                        (a.mode == protocol::CaptureMode::kFull   ? 1.0
                         : a.mode == protocol::CaptureMode::kHalf ? 4.0
                                                                  : 12.0);
  return 5.0 + static_cast<double>(a.pairs) * pair_s;
}

// An error packet answering a capture request: its request's seq and why.
bool ParseRefusal(const protocol::FrameView& frame, uint32_t& cmd_seq, std::string& why) {
  protocol::CommandReply reply;
  if (!protocol::ParseCommandReply(frame, reply).ok() ||
      reply.error == protocol::CommandError::kNone ||
      reply.cmd_type != protocol::MsgType::kCaptureStart) {
    return false;
  }
  const auto code = static_cast<uint8_t>(reply.error);
  cmd_seq = reply.cmd_seq;
  why = code < 15 ? kRefusalWhy[code] : "error";
  return true;
}

// Decodes the stream, writes each complete pair's images as it arrives and collects the rows of
// frames.csv and capture.csv.
struct CaptureReceiver {
  const std::string& out_dir;
  bool writable;                  // our request was sent: its refusal ends the capture
  const tools::ScanTables* scan;  // from --calib (null without): places scanline samples
  tools::CaptureCollector collector;
  protocol::Decoder decoder;
  protocol::FrameView frame;
  std::string frames_rows, capture_rows, refusal, message;
  std::string write_error;  // the image write that failed
  std::string scan_error;   // a scanline stream that does not fit the host's tables
  uint32_t written = 0, bad = 0;
  uint32_t samples[2] = {0, 0};  // scanline samples per image, once seen
  bool write_failed = false, done = false;

  void Feed(const uint8_t* bytes, size_t n) {
    for (size_t i = 0; i < n && !done && !write_failed; ++i) {
      if (decoder.Push(bytes[i], frame)) Handle();
    }
  }

  void Handle() {
    uint32_t cmd_seq = 0;
    std::string why;
    if (ParseRefusal(frame, cmd_seq, why)) {
      if (writable && cmd_seq == kRequestSeq) {  // ours: nothing will come
        refusal = why;
        std::fprintf(stderr, "ballvision capture: the coprocessor refused the request: %s\n",
                     why.c_str());
        done = true;
        return;
      }
      // In a recording: another request was refused; the capture may still be in it.
      std::fprintf(stderr, "ballvision capture: note: capture request seq %u refused: %s\n",
                   cmd_seq, why.c_str());
      return;
    }
    const auto ev = collector.Feed(frame, message);
    if (!message.empty()) std::fprintf(stderr, "ballvision capture: %s\n", message.c_str());
    if (ev == tools::CaptureCollector::Event::kBadPacket) ++bad;
    if (ev == tools::CaptureCollector::Event::kEnd) done = true;
    if (ev == tools::CaptureCollector::Event::kPairComplete) WritePair();
    if (!scan_error.empty()) done = true;
  }

  // The 640x480 image of camera c: upsampled, or the scanline samples in place (false, the
  // capture refused, when they do not fit the host's table).
  bool ToImage(const tools::CapturedPair& pair, int c, std::vector<uint8_t>& image) {
    if (pair.frame.mode != protocol::CaptureMode::kScanlines) {
      image = tools::UpsampleCapture(pair.image[c], pair.frame.mode);
      return true;
    }
    if (scan == nullptr) {
      scan_error =
          "a scanline capture needs --calib FILE (the calibration the device uses) to "
          "place its samples";
    } else if (tools::ScanStreamToImage(pair.image[c], scan->table(c), c ? "persp" : "omni", image,
                                        scan_error)) {
      if (samples[c] == 0) {
        samples[c] = static_cast<uint32_t>(scan->table(c).pixel_count());
        return WriteMask(c);
      }
      return true;
    }
    std::fprintf(stderr, "ballvision capture: %s\n", scan_error.c_str());
    done = true;
    return false;
  }

  // scan_mask_omni.pgm / scan_mask_persp.pgm: 255 at the real (sample) pixels, 0 at fill.
  bool WriteMask(int c) {
    std::string pgm = "P5\n640 480\n255\n";
    const size_t head = pgm.size();
    pgm.resize(head + static_cast<size_t>(kFrameWidth) * kFrameHeight, '\0');
    ForEachScanPixel(scan->table(c), [&](int u, int v) {
      pgm[head + static_cast<size_t>(v) * kFrameWidth + u] = static_cast<char>(255);
    });
    const std::string name = std::string("/scan_mask_") + (c ? "persp" : "omni") + ".pgm";
    if (WriteFileAtomic(out_dir + name, pgm, write_error)) return true;
    std::fprintf(stderr, "ballvision capture: %s\n", write_error.c_str());
    write_failed = true;
    return false;
  }

  void WritePair() {
    const tools::CapturedPair& pair = collector.pair();
    const protocol::CaptureFrame& f = pair.frame;
    // The device's frame counter as the index (the original sequence's index on a replay):
    // the captured sequence lines up with the frames it came from.
    const uint32_t index = pair.image[0].empty() ? f.persp_sequence : f.omni_sequence;
    std::string names[2];
    for (int c = 0; c < 2 && !write_failed; ++c) {
      if (pair.image[c].empty()) continue;
      std::vector<uint8_t> image;
      if (!ToImage(pair, c, image)) return;
      names[c] = std::string(c ? "persp_" : "omni_") + std::to_string(index) + ".yuyv";
      if (!WriteFileAtomic(out_dir + "/" + names[c], image, write_error)) {
        std::fprintf(stderr, "ballvision capture: %s\n", write_error.c_str());
        write_failed = true;
      }
    }
    if (write_failed) return;
    frames_rows += std::to_string(index) + "," + std::to_string(f.exposure_us) + "," + names[0] +
                   "," + names[1] + "\n";
    capture_rows += std::to_string(index) + "," + std::to_string(f.pair_index) + "," +
                    std::to_string(f.exposure_us) + "," +
                    (names[0].empty() ? "" : std::to_string(f.omni_exposure_us)) + "," +
                    (names[1].empty() ? "" : std::to_string(f.persp_exposure_us)) + "," +
                    (names[0].empty() ? "" : std::to_string(f.omni_sequence)) + "," +
                    (names[1].empty() ? "" : std::to_string(f.persp_sequence)) + "\n";
    ++written;
    std::printf("pair %u (frame %u): t %.6f s, %s%s\n", f.pair_index, index, f.exposure_us * 1e-6,
                names[0].empty() ? "" : "omni ", names[1].empty() ? "" : "persp");
    std::fflush(stdout);
  }
};

// Reads until the capture ends, the source ends, `seconds` pass or a signal arrives.
void Receive(int fd, double seconds, CaptureReceiver& rx) {
  const auto start = std::chrono::steady_clock::now();
  uint8_t buf[4096];
  while (!rx.done && !rx.write_failed) {
    const ssize_t n = ReadLinkChunk(fd, buf, sizeof buf, start, seconds, "ballvision capture");
    if (n < 0) break;
    if (n > 0) rx.Feed(buf, static_cast<size_t>(n));
  }
}

// What happened, in one line for capture.json and the summary.
struct CaptureOutcome {
  std::string note;  // empty: nothing went wrong
  uint32_t requested = 0;
  protocol::CaptureMode mode = protocol::CaptureMode::kFull;
  bool complete = false;
};

CaptureOutcome Outcome(const CaptureReceiver& rx, const CaptureArgs& a) {
  const tools::CaptureCollector& col = rx.collector;
  CaptureOutcome o;
  o.requested = col.seen_any() ? col.first().count : static_cast<uint32_t>(a.pairs);
  o.mode = col.seen_any() ? col.first().mode : a.mode;
  if (!rx.refusal.empty()) {
    o.note = "refused by the coprocessor: " + rx.refusal;
  } else if (!rx.scan_error.empty()) {
    o.note = "refused: " + rx.scan_error;
  } else if (!col.seen_any()) {
    o.note = "no capture packets received";
  } else if (!col.ended()) {
    o.note = "cut off: the stream ended before the capture's end packet";
  } else if (col.end().reason != protocol::CaptureEndReason::kComplete) {
    o.note = std::string("ended early: ") + EndName(col.end().reason);
  } else if (col.pairs_broken() > 0) {
    o.note = std::to_string(col.pairs_broken()) + " pair(s) lost in transmission";
  }
  if (rx.write_failed) o.note = "writing the images failed";
  o.complete = o.note.empty() && rx.written == o.requested;
  return o;
}

std::string CaptureJson(const CaptureOutcome& o, const CaptureReceiver& rx) {
  const tools::CaptureCollector& col = rx.collector;
  std::string json = "{\n  \"format\": \"ballvision capture\",\n  \"version\": 1,\n";
  json += "  \"mode\": " + JsonString(ModeName(o.mode)) + ",\n";
  const bool scan = o.mode == protocol::CaptureMode::kScanlines;
  json += std::string("  \"upsampled_to_640x480\": ") +
          (o.mode == protocol::CaptureMode::kFull || scan ? "false" : "true") + ",\n";
  if (scan) {
    json += "  \"scanline_samples\": {\"omni\": " + std::to_string(rx.samples[0]) +
            ", \"persp\": " + std::to_string(rx.samples[1]) + "},\n";
    json += "  \"fill_yuv\": [" + std::to_string(tools::kScanFillY) + ", " +
            std::to_string(tools::kScanFillChroma) + ", " + std::to_string(tools::kScanFillChroma) +
            "],\n";
    json += "  \"scanlines_note\": " + JsonString(kScanlinesNote) + ",\n";
  }
  json += "  \"pairs_requested\": " + std::to_string(o.requested) + ",\n";
  json += "  \"pairs_written\": " + std::to_string(rx.written) + ",\n";
  json += "  \"pairs_broken\": " + std::to_string(col.pairs_broken()) + ",\n";
  json += std::string("  \"complete\": ") + (o.complete ? "true" : "false") + ",\n";
  json +=
      "  \"end\": " + (col.ended() ? JsonString(EndName(col.end().reason)) : std::string("null")) +
      ",\n";
  json += "  \"note\": " + JsonString(o.note) + "\n}\n";
  return json;
}

// Every file is written even if one fails (the pairs written stay a valid sequence); the
// message is the last failure's, the images' when only they failed.
bool WriteSequenceFiles(const std::string& out_dir, const CaptureOutcome& o,
                        const CaptureReceiver& rx) {
  std::string err = rx.write_error;
  bool ok = !rx.write_failed;
  ok = WriteFileAtomic(out_dir + "/capture.csv",
                       "index,pair_index,t_us,omni_exposure_us,persp_exposure_us,"
                       "omni_sequence,persp_sequence\n" +
                           rx.capture_rows,
                       err) &&
       ok;
  ok = WriteFileAtomic(out_dir + "/capture.json", CaptureJson(o, rx), err) && ok;
  ok = WriteFileAtomic(out_dir + "/frames.csv",
                       "index,t_us,omni_file,persp_file\n" + rx.frames_rows, err) &&
       ok;
  if (!ok) std::fprintf(stderr, "ballvision capture: %s\n", err.c_str());
  return ok;
}

void PrintSummary(const CaptureOutcome& o, const CaptureReceiver& rx) {
  std::printf(
      "summary: pairs_written=%u of %u, broken=%u, bad_packets=%u, decoder_errors=%u, "
      "%s%s\n",
      rx.written, o.requested, rx.collector.pairs_broken(), rx.bad, rx.decoder.stats().errors(),
      o.complete ? "complete" : "INCOMPLETE: ", o.note.c_str());
}

}  // namespace

int CmdCapture(int argc, char** argv) {
  CaptureArgs a;
  if (const int rc = ParseCaptureArgs(argc, argv, a); rc >= 0) return rc;
  if (!PrepareOutDir(a.out_dir)) return 1;
  std::string err;
  bool writable = false;
  const int fd = OpenLink(a.source, a.baud, writable, err);
  if (fd < 0) {
    std::fprintf(stderr, "ballvision capture: %s\n", err.c_str());
    return 1;
  }
  if (a.mode == protocol::CaptureMode::kScanlines && a.calib.empty()) {
    std::fprintf(stderr,
                 "ballvision capture: --mode scanlines needs --calib FILE (the calibration the "
                 "device uses: its scan tables place the samples)\n");
    if (fd != STDIN_FILENO) close(fd);
    return 2;
  }
  std::unique_ptr<tools::ScanTables> scan;
  if (!a.calib.empty()) {
    RigCalibration cal;
    scan = std::make_unique<tools::ScanTables>();
    if (!LoadCalibrationFile(a.calib, cal, err) || !scan->Build(cal, err)) {
      std::fprintf(stderr, "ballvision capture: %s\n", err.c_str());
      if (fd != STDIN_FILENO) close(fd);
      return 1;
    }
  }
  InstallInterruptHandlers();
  if (writable) {
    if (!SendRequest(fd, a)) {
      close(fd);
      return 1;
    }
    if (a.seconds == 0) a.seconds = DefaultSeconds(a);
  }
  CaptureReceiver rx{a.out_dir, writable, scan.get()};
  Receive(fd, a.seconds, rx);
  if (fd != STDIN_FILENO) close(fd);
  if (InterruptSignal()) ReportInterrupt("ballvision capture");
  if (rx.collector.Finish(rx.message)) {
    std::fprintf(stderr, "ballvision capture: %s\n", rx.message.c_str());
  }
  const CaptureOutcome o = Outcome(rx, a);
  const bool ok = WriteSequenceFiles(a.out_dir, o, rx);
  PrintSummary(o, rx);
  if (InterruptSignal()) return InterruptExitCode();
  return ok && o.complete ? 0 : 1;
}

}  // namespace bv::cli
