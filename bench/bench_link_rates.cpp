// Capture over the link at 921600 Bd: the firmware main loop (firmware/main_loop.cpp, as built
// for the boards) on the simulated link of host_tests/link_sim.h (30 Hz pairs, 2 KB TX ring
// emptied at 92160 B/s). Prints, per capture mode, the image bytes per second while the
// capture streams, the ball-state packets per second over the same window and the worst time
// from a pair's exposure to its ball state's last byte on the wire, with and without a
// capture. The scanline case boots with the demo calibration (its pipeline then runs: the
// model's pipeline still takes no simulated time).
//   build/host/bench/bench_link_rates
#include <algorithm>
#include <cstdio>
#include <memory>
#include <vector>

#include "core/protocol/link.h"
#include "firmware/main_loop.cpp"  // NOLINT(build/include)
#include "firmware/main_loop.h"
#include "host_tests/link_sim.h"
#include "tools/ballvision/demo_scene.h"

namespace {

using namespace bv;           // NOLINT(build/namespaces)
using namespace bv::fw::sim;  // NOLINT(build/namespaces)
namespace protocol = bv::protocol;

struct Figures {
  double capture_bytes_per_s = 0;
  double capture_s = 0;
  uint64_t capture_bytes = 0;
  uint32_t pairs_captured = 0;
  double ball_per_s = 0;
  double worst_ball_latency_ms = 0;
  uint32_t balls = 0, pairs = 0;
};

Figures Run(bool capture, protocol::CaptureMode mode, uint16_t count, uint32_t pairs) {
  SimClock clock;
  PacedUart uart;
  NoStorage none;
  MemStorage with_calibration;  // scanlines need the scan tables: a calibration
  std::vector<uint8_t> scratch(fw::kBlobScratchBytes);
  const bool scan = capture && mode == protocol::CaptureMode::kScanlines;
  if (scan && !InstallCalibration(with_calibration, cli::MakeDemoCalibration(), scratch)) {
    std::fprintf(stderr, "calibration not stored\n");
  }
  hal::Storage& storage = scan ? static_cast<hal::Storage&>(with_calibration) : none;
  SimCamera camera(clock, pairs);
  auto tables = std::make_unique<PipelineTables>();
  auto loop = std::make_unique<fw::MainLoop>(camera, uart, clock, storage, *tables, scratch);
  if (!loop->Init().ok()) std::fprintf(stderr, "init failed\n");
  if (capture) {
    const uint8_t p[4] = {static_cast<uint8_t>(count), static_cast<uint8_t>(count >> 8),
                          static_cast<uint8_t>(mode), 3};
    uint8_t wire[64];
    const Result<size_t> n = protocol::EncodeFrame(protocol::MsgType::kCaptureStart, 1, p, wire);
    uart.Feed(std::span<const uint8_t>(wire, *n), clock.now);
  }
  const uint64_t end_us = 1000 + uint64_t{pairs} * kPeriodUs;
  while (clock.now < end_us + 2000000) {
    loop->Poll();
    clock.now += 50;
    uart.Advance(clock.now);
  }
  // Decode what left, with the time each packet's last byte left.
  Figures f;
  protocol::Decoder d;
  protocol::FrameView v;
  uint64_t first_chunk = 0, last_chunk = 0, capture_bytes = 0;
  std::vector<std::pair<uint64_t, uint64_t>> balls;  // (exposure, on the wire)
  for (size_t i = 0; i < uart.wire.size(); ++i) {
    if (!d.Push(uart.wire[i], v)) continue;
    if (v.type == protocol::MsgType::kCaptureChunk) {
      if (first_chunk == 0) first_chunk = uart.wire_done_us[i];
      last_chunk = uart.wire_done_us[i];
      capture_bytes += v.payload.size() - protocol::kCaptureChunkHeaderBytes;
    } else if (v.type == protocol::MsgType::kCaptureEnd) {
      protocol::CaptureEnd e;
      if (protocol::ParseCaptureEnd(v.payload, e).ok()) f.pairs_captured = e.pairs_sent;
    } else if (v.type == protocol::MsgType::kBallState) {
      BallState s;
      if (protocol::ParseBallState(v.payload, s).ok())
        balls.emplace_back(s.t_us, uart.wire_done_us[i]);
    }
  }
  const uint64_t w0 = capture ? first_chunk : 1000;
  const uint64_t w1 = capture ? last_chunk : end_us;
  f.capture_s = (w1 - w0) * 1e-6;
  f.capture_bytes = capture_bytes;
  f.capture_bytes_per_s = capture && w1 > w0 ? capture_bytes / f.capture_s : 0;
  uint32_t in_window = 0;
  for (const auto& [t, out] : balls) {
    if (t < w0 || t >= w1) continue;
    ++in_window;
    f.worst_ball_latency_ms = std::max(f.worst_ball_latency_ms, (out - t) * 1e-3);
  }
  f.ball_per_s = w1 > w0 ? in_window / ((w1 - w0) * 1e-6) : 0;
  f.balls = static_cast<uint32_t>(balls.size());
  f.pairs = camera.served;
  return f;
}

}  // namespace

int main() {
  std::printf(
      "921600 Bd (92160 B/s), 30 Hz pairs, 2 KB TX ring, chunks of %zu image bytes "
      "(%zu on the wire)\n",
      protocol::kCaptureChunkBytes,
      protocol::WireFrameBytes(protocol::kCaptureChunkHeaderBytes + protocol::kCaptureChunkBytes));
  std::printf("%-40s %12s %10s %14s %12s %16s %s\n", "run", "capture B/s", "link %",
              "capture time s", "ball pkt/s", "worst ball ms", "pairs (balls/served)");
  const Figures base = Run(false, protocol::CaptureMode::kFull, 0, 300);
  std::printf("%-40s %12s %10s %14s %12.2f %16.2f %u/%u\n", "no capture (10 s)", "-", "-", "-",
              base.ball_per_s, base.worst_ball_latency_ms, base.balls, base.pairs);
  struct Case {
    const char* name;
    protocol::CaptureMode mode;
    uint16_t count;
    uint32_t pairs;
  } cases[] = {
      {"quarter 160x120, 10 pairs, both", protocol::CaptureMode::kQuarter, 10, 600},
      {"half 320x240, 3 pairs, both", protocol::CaptureMode::kHalf, 3, 600},
      {"full 640x480, 1 pair, both", protocol::CaptureMode::kFull, 1, 600},
      {"scanlines (demo calib), 10 pairs, both", protocol::CaptureMode::kScanlines, 10, 600}};
  for (const Case& c : cases) {
    const Figures f = Run(true, c.mode, c.count, c.pairs);
    std::printf("%-40s %12.0f %10.1f %14.2f %12.2f %16.2f %u/%u, %u captured, %.0f B/pair\n",
                c.name, f.capture_bytes_per_s, 100.0 * f.capture_bytes_per_s / 92160.0, f.capture_s,
                f.ball_per_s, f.worst_ball_latency_ms, f.balls, f.pairs, f.pairs_captured,
                f.pairs_captured ? static_cast<double>(f.capture_bytes) / f.pairs_captured : 0.0);
  }
  return 0;
}
