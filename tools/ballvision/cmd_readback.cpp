// ballvision readback: the colour table (as adapted on the device) or the calibration in use,
// read back over the link and saved (docs/protocol.md, "Read-back").
#include <poll.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>

#include "tools/ballvision/blob_reader.h"
#include "tools/ballvision/cli_args.h"
#include "tools/ballvision/commands.h"
#include "tools/ballvision/link_io.h"
#include "tools/ballvision/safe_write.h"
#include "tools/ballvision/signals.h"

namespace bv::cli {
namespace {

const char* const kReadbackUsage =
    "usage: ballvision readback SOURCE --out FILE [--what lut|calibration|classifier] [--baud N]\n"
    "                          [--seconds S]\n"
    "  Reads the blob the coprocessor uses (default: the colour table, with what online\n"
    "  adaptation made of it) over a serial device, pty or tcp:HOST:PORT and writes it\n"
    "  to FILE only when it is whole, from one snapshot, and passes its CRC and content\n"
    "  checks (a LUT file for --lut, or a calibration blob for `calib to-json`).\n"
    "  --seconds: give up after S seconds (default 60); nothing is written then.\n";

constexpr int64_t kAnswerTimeoutUs = 1000000;  // a lost request or answer: ask again
constexpr int64_t kBusyPauseUs = 20000;        // the device's TX ring had no room: wait a little

int64_t NowUs() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

struct ReadbackArgs {
  std::string source, out, what = "lut";
  long baud = 921600;
  double seconds = 60;
};

// Sends requests and feeds answers until the reader is done or failed, the link closes, the
// time is up or a signal arrives. Returns a message when it stopped early ("" otherwise).
std::string Exchange(int fd, BlobReader& reader, const ReadbackArgs& a) {
  protocol::Decoder decoder;
  protocol::FrameView frame;
  const int64_t start = NowUs();
  int64_t sent_at = 0, not_before = 0;
  int busy_seen = 0;
  uint8_t buf[4096];
  while (!reader.done() && !reader.failed()) {
    if (InterruptSignal()) return "interrupted";
    const int64_t now = NowUs();
    if (now - start > static_cast<int64_t>(a.seconds * 1e6)) return "no complete answer in time";
    if (reader.busy_answers() != busy_seen) {
      busy_seen = reader.busy_answers();
      not_before = now + kBusyPauseUs;
    }
    protocol::ReadBlobRequest req;
    uint32_t seq = 0;
    if (now >= not_before && reader.NextRequest(req, seq)) {
      uint8_t wire[64];
      const Result<size_t> n = protocol::EncodeReadBlob(req, seq, wire);
      if (!n.ok() || write(fd, wire, *n) != static_cast<ssize_t>(*n)) {
        return std::string("write failed: ") + std::strerror(errno);
      }
      sent_at = now;
    } else if (now - sent_at > kAnswerTimeoutUs) {
      reader.Resend();
    }
    pollfd p{fd, POLLIN, 0};
    const int ready = poll(&p, 1, 10);
    if (ready <= 0) continue;
    const ssize_t got = read(fd, buf, sizeof buf);
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0 && !isatty(fd)) return "the link closed";
    for (ssize_t i = 0; i < got; ++i) {
      if (decoder.Push(buf[i], frame)) reader.OnFrame(frame);
    }
  }
  return "";
}

}  // namespace

int CmdReadback(int argc, char** argv) {
  ReadbackArgs a;
  ArgParser args("ballvision readback", kReadbackUsage);
  args.Positional("SOURCE", a.source)
      .Text("--out", a.out)
      .Required("--out")
      .Text("--what", a.what)
      .Int("--baud", 1200, 4000000, a.baud)
      .Number("--seconds", 0.1, 1e6, a.seconds);
  if (const int rc = args.Parse(argc, argv); rc >= 0) return rc;
  if (a.what != "lut" && a.what != "calibration" && a.what != "classifier") {
    return args.UsageError("--what: got '" + a.what + "', expected lut, calibration or classifier");
  }
  std::string err;
  if (!CheckOutputPath(a.out, err)) {
    std::fprintf(stderr, "ballvision readback: %s\n", err.c_str());
    return 1;
  }
  bool writable = false;
  const int fd = OpenLink(a.source, a.baud, writable, err);
  if (fd < 0) {
    std::fprintf(stderr, "ballvision readback: %s\n", err.c_str());
    return 1;
  }
  if (!writable) {
    std::fprintf(stderr, "ballvision readback: %s is a recording; a read-back needs a live link\n",
                 a.source.c_str());
    close(fd);
    return 1;
  }
  InstallInterruptHandlers();
  BlobReader reader(a.what == "lut"          ? protocol::UploadTarget::kLut
                    : a.what == "classifier" ? protocol::UploadTarget::kClassifier
                                             : protocol::UploadTarget::kCalibration);
  const int64_t start = NowUs();
  const std::string stopped = Exchange(fd, reader, a);
  close(fd);
  if (!reader.done()) {
    std::fprintf(stderr, "ballvision readback: %s after %zu of %u bytes; %s not written\n",
                 reader.failed() ? reader.error().c_str() : stopped.c_str(), reader.blob().size(),
                 reader.total_len(), a.out.c_str());
    return InterruptSignal() ? InterruptExitCode() : 1;
  }
  if (!WriteFileAtomic(
          a.out, std::vector<unsigned char>(reader.blob().begin(), reader.blob().end()), err)) {
    std::fprintf(stderr, "ballvision readback: %s\n", err.c_str());
    return 1;
  }
  std::printf(
      "read %zu bytes of the %s in use (crc32 %08x) in %.1f s, %d busy answers, %d "
      "restarts: wrote %s\n",
      reader.blob().size(),
      a.what == "lut" ? "colour table"
                      : (a.what == "classifier" ? "ball classifier" : "calibration"),
      reader.blob_crc32(), (NowUs() - start) * 1e-6, reader.busy_answers(), reader.restarts(),
      a.out.c_str());
  return 0;
}

}  // namespace bv::cli
