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
#include <string>

#include "core/protocol/link.h"
#include "core/protocol/protocol.h"
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
    "usage: ballvision capture SOURCE --out SEQ_DIR [--pairs N] [--mode full|half|quarter]\n"
    "                          [--cameras both|omni|persp] [--baud N] [--seconds S]\n"
    "  Asks the coprocessor for the next N frame pairs (1..100, default 1: a snapshot) and\n"
    "  writes SEQ_DIR/frames.csv (index = the device's frame counter), one .yuyv per\n"
    "  image, capture.csv (pair index, per-camera exposure times and frame counters) and\n"
    "  capture.json (mode, complete or not and why).\n"
    "  Half and quarter images are scaled back to 640x480 (nearest) so `run` replays them.\n"
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

}  // namespace

int CmdCapture(int argc, char** argv) {
  std::string source, out_dir, err;
  int64_t pairs = 1;
  long baud = 921600;
  double seconds = 0;
  protocol::CaptureMode mode = protocol::CaptureMode::kFull;
  uint8_t cameras = protocol::kCaptureOmni | protocol::kCapturePersp;
  ArgParser args("ballvision capture", kCaptureUsage);
  args.Positional("SOURCE", source)
      .Text("--out", out_dir)
      .Required("--out")
      .Int("--pairs", 1, protocol::kMaxCapturePairs, pairs)
      .Custom("--mode",
              [&mode](const std::string& v, std::string& error) {
                if (v == "full") {
                  mode = protocol::CaptureMode::kFull;
                } else if (v == "half") {
                  mode = protocol::CaptureMode::kHalf;
                } else if (v == "quarter") {
                  mode = protocol::CaptureMode::kQuarter;
                } else {
                  error = "--mode: got '" + v + "', expected full, half or quarter";
                  return false;
                }
                return true;
              })
      .Custom("--cameras",
              [&cameras](const std::string& v, std::string& error) {
                if (v == "both") {
                  cameras = protocol::kCaptureOmni | protocol::kCapturePersp;
                } else if (v == "omni") {
                  cameras = protocol::kCaptureOmni;
                } else if (v == "persp") {
                  cameras = protocol::kCapturePersp;
                } else {
                  error = "--cameras: got '" + v + "', expected both, omni or persp";
                  return false;
                }
                return true;
              })
      .Int("--baud", 1, 4000000, baud)
      .Number("--seconds", 0.1, 1e6, seconds);
  if (const int rc = args.Parse(argc, argv); rc >= 0) return rc;
  struct stat st {};
  if (lstat(out_dir.c_str(), &st) == 0) {
    if (!S_ISDIR(st.st_mode)) {
      std::fprintf(stderr, "ballvision capture: %s exists and is not a directory\n",
                   out_dir.c_str());
      return 1;
    }
    const std::string csv = out_dir + "/frames.csv";
    if (access(csv.c_str(), F_OK) == 0) {
      std::fprintf(stderr,
                   "ballvision capture: %s already holds a sequence (frames.csv); "
                   "choose a new directory\n",
                   out_dir.c_str());
      return 1;
    }
  } else if (mkdir(out_dir.c_str(), 0777) != 0) {
    std::fprintf(stderr, "ballvision capture: cannot create %s: %s\n", out_dir.c_str(),
                 std::strerror(errno));
    return 1;
  }

  bool writable = false;
  const int fd = OpenLink(source, baud, writable, err);
  if (fd < 0) {
    std::fprintf(stderr, "ballvision capture: %s\n", err.c_str());
    return 1;
  }
  InstallInterruptHandlers();
  if (writable) {
    uint8_t p[protocol::kCaptureStartBytes] = {static_cast<uint8_t>(pairs & 0xFF),
                                               static_cast<uint8_t>(pairs >> 8),
                                               static_cast<uint8_t>(mode), cameras};
    uint8_t wire[64];
    const Result<size_t> n =
        protocol::EncodeFrame(protocol::MsgType::kCaptureStart, kRequestSeq, p, wire);
    if (!n.ok() || write(fd, wire, *n) != static_cast<ssize_t>(*n)) {
      std::fprintf(stderr, "ballvision capture: cannot send the request to %s: %s\n",
                   source.c_str(), std::strerror(errno));
      close(fd);
      return 1;
    }
    if (seconds == 0) {
      // A full-size pair is ~14 s of link time at 921600 Bd; allow twice that.
      const double pair_s = 2.0 * 1.23e6 / (baud / 10.0) /
                            (mode == protocol::CaptureMode::kFull   ? 1.0
                             : mode == protocol::CaptureMode::kHalf ? 4.0
                                                                    : 16.0);
      seconds = 5.0 + static_cast<double>(pairs) * pair_s;
    }
  }

  tools::CaptureCollector collector;
  protocol::Decoder decoder;
  protocol::FrameView frame;
  std::string frames_rows, capture_rows, message, refusal;
  uint32_t written = 0, bad = 0;
  bool write_failed = false;
  const auto start = std::chrono::steady_clock::now();
  uint8_t buf[4096];
  bool done = false;
  while (!done && !write_failed) {
    const ssize_t n = ReadLinkChunk(fd, buf, sizeof buf, start, seconds, "ballvision capture");
    if (n < 0) break;
    if (n == 0) continue;
    for (ssize_t i = 0; i < n && !done; ++i) {
      if (!decoder.Push(buf[i], frame)) continue;
      if (frame.type == protocol::MsgType::kError && frame.payload.size() == 10 &&
          frame.payload[0] == static_cast<uint8_t>(protocol::MsgType::kCaptureStart)) {
        static const char* kWhy[] = {"",
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
                                     "this board cannot capture",
                                     ""};
        const uint8_t code = frame.payload[5];
        const uint32_t cmd_seq = frame.payload[1] | (frame.payload[2] << 8) |
                                 (frame.payload[3] << 16) | (uint32_t{frame.payload[4]} << 24);
        const std::string why = code < 15 ? kWhy[code] : "error";
        if (writable && cmd_seq == kRequestSeq) {  // ours: nothing will come
          refusal = why;
          std::fprintf(stderr, "ballvision capture: the coprocessor refused the request: %s\n",
                       why.c_str());
          done = true;
          break;
        }
        // In a recording: another request was refused; the capture may still be in it.
        std::fprintf(stderr, "ballvision capture: note: capture request seq %u refused: %s\n",
                     cmd_seq, why.c_str());
        continue;
      }
      const auto ev = collector.Feed(frame, message);
      if (!message.empty()) std::fprintf(stderr, "ballvision capture: %s\n", message.c_str());
      if (ev == tools::CaptureCollector::Event::kBadPacket) ++bad;
      if (ev == tools::CaptureCollector::Event::kEnd) done = true;
      if (ev != tools::CaptureCollector::Event::kPairComplete) continue;
      const tools::CapturedPair& pair = collector.pair();
      const protocol::CaptureFrame& f = pair.frame;
      // The device's frame counter as the index (the original sequence's index on a replay):
      // the captured sequence lines up with the frames it came from.
      const uint32_t index = pair.image[0].empty() ? f.persp_sequence : f.omni_sequence;
      std::string names[2];
      for (int c = 0; c < 2 && !write_failed; ++c) {
        if (pair.image[c].empty()) continue;
        names[c] = std::string(c ? "persp_" : "omni_") + std::to_string(index) + ".yuyv";
        if (!WriteFileAtomic(out_dir + "/" + names[c],
                             tools::UpsampleCapture(pair.image[c], f.mode), err)) {
          std::fprintf(stderr, "ballvision capture: %s\n", err.c_str());
          write_failed = true;
        }
      }
      if (write_failed) break;
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
  }
  if (fd != STDIN_FILENO) close(fd);
  if (InterruptSignal()) ReportInterrupt("ballvision capture");
  if (collector.Finish(message)) std::fprintf(stderr, "ballvision capture: %s\n", message.c_str());

  // What happened, in one line for capture.json and the summary.
  std::string note;
  const bool ended = collector.ended();
  const protocol::CaptureEnd& end = collector.end();
  const uint32_t requested =
      collector.seen_any() ? collector.first().count : static_cast<uint32_t>(pairs);
  const protocol::CaptureMode got_mode = collector.seen_any() ? collector.first().mode : mode;
  if (!refusal.empty()) {
    note = "refused by the coprocessor: " + refusal;
  } else if (!collector.seen_any()) {
    note = "no capture packets received";
  } else if (!ended) {
    note = "cut off: the stream ended before the capture's end packet";
  } else if (end.reason != protocol::CaptureEndReason::kComplete) {
    note = std::string("ended early: ") + EndName(end.reason);
  } else if (collector.pairs_broken() > 0) {
    note = std::to_string(collector.pairs_broken()) + " pair(s) lost in transmission";
  }
  if (write_failed) note = "writing the images failed";
  const bool complete = note.empty() && written == requested;
  std::string json = "{\n  \"format\": \"ballvision capture\",\n  \"version\": 1,\n";
  json += "  \"mode\": " + JsonString(ModeName(got_mode)) + ",\n";
  json += std::string("  \"upsampled_to_640x480\": ") +
          (got_mode == protocol::CaptureMode::kFull ? "false" : "true") + ",\n";
  json += "  \"pairs_requested\": " + std::to_string(requested) + ",\n";
  json += "  \"pairs_written\": " + std::to_string(written) + ",\n";
  json += "  \"pairs_broken\": " + std::to_string(collector.pairs_broken()) + ",\n";
  json += std::string("  \"complete\": ") + (complete ? "true" : "false") + ",\n";
  json += "  \"end\": " + (ended ? JsonString(EndName(end.reason)) : std::string("null")) + ",\n";
  json += "  \"note\": " + JsonString(note) + "\n}\n";
  bool ok = !write_failed;
  ok = WriteFileAtomic(out_dir + "/capture.csv",
                       "index,pair_index,t_us,omni_exposure_us,persp_exposure_us,"
                       "omni_sequence,persp_sequence\n" +
                           capture_rows,
                       err) &&
       ok;
  ok = WriteFileAtomic(out_dir + "/capture.json", json, err) && ok;
  ok = WriteFileAtomic(out_dir + "/frames.csv", "index,t_us,omni_file,persp_file\n" + frames_rows,
                       err) &&
       ok;
  if (!ok) std::fprintf(stderr, "ballvision capture: %s\n", err.c_str());
  std::printf(
      "summary: pairs_written=%u of %u, broken=%u, bad_packets=%u, decoder_errors=%u, "
      "%s%s\n",
      written, requested, collector.pairs_broken(), bad, decoder.stats().errors(),
      complete ? "complete" : "INCOMPLETE: ", note.c_str());
  if (InterruptSignal()) return InterruptExitCode();
  return ok && complete ? 0 : 1;
}

}  // namespace bv::cli
