// ballvision sync: the clock-sync exchange with the coprocessor (docs/protocol.md, "Clock
// sync") through tools/ballvision/clock_sync.h, or the estimator alone on recorded exchanges.
#include <poll.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>

#include "core/protocol/link.h"
#include "core/protocol/protocol.h"
#include "tools/ballvision/cli_args.h"
#include "tools/ballvision/clock_sync.h"
#include "tools/ballvision/commands.h"
#include "tools/ballvision/link_io.h"
#include "tools/ballvision/signals.h"

namespace bv::cli {
namespace {

const char* const kSyncUsage =
    "usage: ballvision sync SOURCE [--hz N] [--seconds S] [--baud N]\n"
    "       ballvision sync --exchanges FILE.csv [--baud N]\n"
    "  Live: sends clock sync requests (default 10 Hz) on a serial device, pty or\n"
    "  tcp:HOST:PORT and prints the offset (this computer's steady clock minus the\n"
    "  coprocessor's) and drift once a second.\n"
    "  --exchanges: feeds recorded exchanges (CSV id,t1,t2,t3,t4 in µs, header line)\n"
    "  to the estimator and prints one line per exchange: id, verdict, t2 in host\n"
    "  time (µs), drift (ppm); --baud sets the wire-time correction (0: none).\n";

const char* VerdictName(tools::ClockSync::Verdict v) {
  switch (v) {
    case tools::ClockSync::Verdict::kAccepted:
      return "accepted";
    case tools::ClockSync::Verdict::kDuplicate:
      return "duplicate";
    case tools::ClockSync::Verdict::kUnknownId:
      return "unknown id";
    case tools::ClockSync::Verdict::kMismatch:
      return "mismatch";
    case tools::ClockSync::Verdict::kInconsistent:
      return "inconsistent";
    case tools::ClockSync::Verdict::kHeld:
      return "held";
    case tools::ClockSync::Verdict::kRestarted:
      return "restarted";
  }
  return "?";
}

int64_t NowUs() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// Offline: the same exchanges through both estimators give the same numbers (a Python test
// compares them).
int ReplayExchanges(const std::string& path, const tools::ClockSync::Config& config) {
  std::ifstream in(path);
  if (!in) {
    std::fprintf(stderr, "ballvision sync: cannot open %s: %s\n", path.c_str(),
                 std::strerror(errno));
    return 1;
  }
  tools::ClockSync sync(config);
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    if (++line_no == 1) continue;  // header
    std::istringstream row(line);
    std::string cell[5];
    int n = 0;
    while (n < 5 && std::getline(row, cell[n], ',')) ++n;
    int64_t v[5] = {};
    std::string err;
    for (int i = 0; i < 5; ++i) {
      if (n != 5 ||
          !ArgInt(path + ":" + std::to_string(line_no), cell[i], 0, INT64_MAX, v[i], err)) {
        std::fprintf(
            stderr, "ballvision sync: %s\n",
            n != 5 ? (path + ":" + std::to_string(line_no) + ": expected 5 columns id,t1,t2,t3,t4")
                         .c_str()
                   : err.c_str());
        return 1;
      }
    }
    protocol::ClockSyncReply r;
    r.id = static_cast<uint32_t>(v[0]);
    r.t1_host_us = static_cast<uint64_t>(v[1]);
    r.t2_rx_us = static_cast<uint64_t>(v[2]);
    r.t3_tx_us = static_cast<uint64_t>(v[3]);
    sync.OnRequestSent(r.id, v[1]);
    const tools::ClockSync::Verdict verdict = sync.OnReply(r, v[4]);
    std::printf("%u,%s,%lld,%.6f\n", r.id, VerdictName(verdict),
                static_cast<long long>(sync.valid() ? sync.ToHostTime(r.t2_rx_us) : 0),
                sync.DriftPpm());
  }
  return 0;
}

void PrintEstimate(const tools::ClockSync& sync, uint32_t sent, const char* prefix) {
  if (!sync.valid()) {
    std::printf("%ssent %u, no reply yet\n", prefix, sent);
  } else {
    std::printf(
        "%ssent %u, offset %.6f s at t=0, drift %+.2f ppm, min delay %.0f us, "
        "accepted %u held %u restarts %u duplicates %u refused %u outliers %u\n",
        prefix, sent, sync.OffsetUs(0) * 1e-6, sync.DriftPpm(), sync.MinDelayUs(), sync.accepted(),
        sync.holding() ? 1u : 0u, sync.restarts(), sync.duplicates(),
        sync.unknown() + sync.rejected(), sync.outliers());
  }
  std::fflush(stdout);
}

}  // namespace

int CmdSync(int argc, char** argv) {
  std::string source, exchanges, err;
  double hz = 10, seconds = 0;
  long baud = 921600;
  ArgParser args("ballvision sync", kSyncUsage);
  args.Positional("SOURCE", source, false)
      .Text("--exchanges", exchanges)
      .Number("--hz", 0.1, 100, hz)
      .Number("--seconds", 0.1, 1e7, seconds)
      .Int("--baud", 0, 4000000, baud);
  if (const int rc = args.Parse(argc, argv); rc >= 0) return rc;
  if (source.empty() == exchanges.empty()) {
    return args.UsageError("give either SOURCE or --exchanges FILE.csv");
  }
  tools::ClockSync::Config config;
  config.byte_us = baud > 0 ? 10.0 / static_cast<double>(baud) * 1e6 : 0.0;
  if (!exchanges.empty()) return ReplayExchanges(exchanges, config);

  bool writable = false;
  const int fd = OpenLink(source, baud, writable, err);
  if (fd < 0) {
    std::fprintf(stderr, "ballvision sync: %s\n", err.c_str());
    return 1;
  }
  if (!writable) {
    std::fprintf(stderr, "ballvision sync: %s is a recording; the exchange needs a live link\n",
                 source.c_str());
    close(fd);
    return 1;
  }
  InstallInterruptHandlers();
  tools::ClockSync sync(config);
  protocol::Decoder decoder;
  protocol::FrameView frame;
  const int64_t start = NowUs();
  int64_t next_request = start, last_print = start;
  uint32_t id = 0;
  uint8_t buf[4096];
  bool closed = false;
  auto report = [&](const char* prefix) { PrintEstimate(sync, id, prefix); };
  while (!InterruptSignal() && !closed &&
         (seconds <= 0 || NowUs() - start < static_cast<int64_t>(seconds * 1e6))) {
    if (NowUs() >= next_request) {
      protocol::ClockSyncRequest req;
      req.id = ++id;
      req.t1_host_us = static_cast<uint64_t>(NowUs());
      uint8_t wire[64];
      const Result<size_t> n = protocol::EncodeClockSyncRequest(req, id, wire);
      sync.OnRequestSent(req.id, static_cast<int64_t>(req.t1_host_us));
      if (!n.ok() || write(fd, wire, *n) != static_cast<ssize_t>(*n)) {
        if (n.ok() && (errno == EPIPE || errno == ECONNRESET)) {
          closed = true;
          break;
        }
        std::fprintf(stderr, "ballvision sync: write failed: %s\n", std::strerror(errno));
        break;
      }
      next_request += static_cast<int64_t>(1e6 / hz);
    }
    pollfd p{fd, POLLIN, 0};
    const int64_t wait_ms = (next_request - NowUs()) / 1000;
    const int ready = poll(&p, 1, wait_ms > 0 ? static_cast<int>(wait_ms) : 0);
    if (ready < 0 && errno == EINTR) continue;
    if (ready <= 0) continue;
    const ssize_t n = read(fd, buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0 && !isatty(fd)) {
      closed = true;
      break;
    }
    const int64_t t4 = NowUs();
    for (ssize_t i = 0; i < n; ++i) {
      if (!decoder.Push(buf[i], frame) || frame.type != protocol::MsgType::kClockSyncReply) {
        continue;
      }
      protocol::ClockSyncReply reply;
      if (protocol::ParseClockSyncReply(frame.payload, reply).ok()) (void)sync.OnReply(reply, t4);
    }
    if (NowUs() - last_print >= 1000000) {
      last_print = NowUs();
      report("");
    }
  }
  close(fd);
  if (closed) std::fprintf(stderr, "ballvision sync: the link closed\n");
  report("final: ");
  if (InterruptSignal()) return InterruptExitCode();
  return sync.valid() ? 0 : 1;
}

}  // namespace bv::cli
