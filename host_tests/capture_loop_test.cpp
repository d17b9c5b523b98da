// Capture and clock sync through the firmware main loop on the host, over the simulated
// 921600 Bd link of host_tests/link_sim.h.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <memory>
#include <vector>

#include "core/common/bytes.h"
#include "core/common/crc32.h"
#include "core/protocol/link.h"
#include "core/protocol/protocol.h"
#include "core/protocol/scan_capture.h"
#include "firmware/main_loop.h"
#include "tools/ballvision/capture_collector.h"
#include "tools/ballvision/demo_scene.h"
#include "tools/ballvision/run_common.h"
// The firmware folder is only built for the target; the loop is compiled into this test.
#include "firmware/main_loop.cpp"  // NOLINT(build/include)
#include "host_tests/link_sim.h"

namespace bv::fw {
namespace {

using namespace sim;  // NOLINT(build/namespaces)

struct Received {
  std::vector<tools::CapturedPair> pairs;
  std::vector<std::string> messages;
  std::vector<uint64_t> ball_done_us;  // when each ball state's last byte left
  std::vector<protocol::CaptureEnd> ends;
  std::vector<std::array<uint8_t, 10>> errors;
  std::vector<protocol::ClockSyncReply> syncs;
  uint32_t decoder_errors = 0;
  uint32_t seq_gaps = 0;
  uint32_t capture_bytes = 0;
  uint64_t first_chunk_us = 0, last_chunk_us = 0;
};

Received DecodeWire(const PacedUart& uart, size_t limit = SIZE_MAX) {
  Received r;
  protocol::Decoder d;
  protocol::FrameView f;
  tools::CaptureCollector collector;
  std::string msg;
  bool have_seq = false;
  uint32_t last = 0;
  const size_t n = std::min(limit, uart.wire.size());
  for (size_t i = 0; i < n; ++i) {
    if (!d.Push(uart.wire[i], f)) continue;
    if (have_seq && f.seq != last + 1) ++r.seq_gaps;
    have_seq = true;
    last = f.seq;
    const auto ev = collector.Feed(f, msg);
    if (!msg.empty()) r.messages.push_back(msg);
    if (ev == tools::CaptureCollector::Event::kPairComplete) r.pairs.push_back(collector.pair());
    if (ev == tools::CaptureCollector::Event::kEnd) r.ends.push_back(collector.end());
    if (f.type == protocol::MsgType::kBallState) r.ball_done_us.push_back(uart.wire_done_us[i]);
    if (f.type == protocol::MsgType::kCaptureChunk) {
      r.capture_bytes += static_cast<uint32_t>(f.payload.size() - 10);
      if (r.first_chunk_us == 0) r.first_chunk_us = uart.wire_done_us[i];
      r.last_chunk_us = uart.wire_done_us[i];
    }
    if (f.type == protocol::MsgType::kError) {
      std::array<uint8_t, 10> e{};
      std::copy(f.payload.begin(), f.payload.end(), e.begin());
      r.errors.push_back(e);
    }
    if (f.type == protocol::MsgType::kClockSyncReply) {
      protocol::ClockSyncReply s;
      EXPECT_TRUE(protocol::ParseClockSyncReply(f.payload, s).ok());
      r.syncs.push_back(s);
    }
  }
  if (collector.Finish(msg)) r.messages.push_back(msg);
  r.decoder_errors = d.stats().errors();
  return r;
}

// The decimated image read pixel by pixel from the pattern (independent of CopyCaptureBytes).
std::vector<uint8_t> Expected(uint32_t pair, int camera, protocol::CaptureMode mode) {
  uint16_t w = 0, h = 0;
  EXPECT_TRUE(protocol::CaptureSize(mode, w, h));
  const size_t k = 640 / w;
  std::vector<uint8_t> out(size_t{w} * h * 2);
  for (size_t y = 0; y < h; ++y) {
    for (size_t x = 0; x < w; ++x) {
      const size_t row = k * y * 1280;
      out[(y * w + x) * 2] = PatternByte(pair, camera, row + 2 * k * x);
      const size_t sm = k * (x - x % 2) / 2;
      out[(y * w + x) * 2 + 1] = PatternByte(pair, camera, row + 4 * sm + (x % 2 ? 3 : 1));
    }
  }
  return out;
}

class CaptureLoopTest : public ::testing::Test {
 protected:
  void Start(uint32_t pairs, bool with_calibration = false) {
    camera_ = std::make_unique<SimCamera>(clock_, pairs);
    if (with_calibration) {
      ASSERT_TRUE(InstallCalibration(cal_storage_, cli::MakeDemoCalibration(), scratch_));
    }
    hal::Storage& storage = with_calibration ? static_cast<hal::Storage&>(cal_storage_) : storage_;
    loop_ = std::make_unique<MainLoop>(*camera_, uart_, clock_, storage, tables_, scratch_,
                                       MainLoopConfig(), nullptr, upload_);
    ASSERT_TRUE(loop_->Init().ok());
    ASSERT_EQ(loop_->pipeline_ready(), with_calibration);
  }
  void Command(protocol::MsgType type, std::span<const uint8_t> payload) {
    std::array<uint8_t, protocol::kMaxWireFrameBytes> wire{};
    const Result<size_t> n = protocol::EncodeFrame(type, cmd_seq_++, payload, wire);
    ASSERT_TRUE(n.ok());
    uart_.Feed(std::span<const uint8_t>(wire.data(), *n), clock_.now);
  }
  void Capture(uint16_t count, protocol::CaptureMode mode, uint8_t cameras = 3) {
    const uint8_t p[4] = {static_cast<uint8_t>(count), static_cast<uint8_t>(count >> 8),
                          static_cast<uint8_t>(mode), cameras};
    Command(protocol::MsgType::kCaptureStart, p);
  }
  // Uploads a blob as the main computer does (begin, 512-byte chunks, commit).
  void Upload(protocol::UploadTarget target, std::span<const uint8_t> blob) {
    uint8_t begin[9];
    ByteWriter b(begin);
    b.U8(static_cast<uint8_t>(target)), b.U32(static_cast<uint32_t>(blob.size()));
    b.U32(Crc32(blob));
    Command(protocol::MsgType::kUploadBegin, begin);
    for (size_t off = 0; off < blob.size(); off += 512) {
      const size_t n = std::min<size_t>(512, blob.size() - off);
      std::vector<uint8_t> chunk(5 + n);
      ByteWriter w(chunk);
      w.U8(static_cast<uint8_t>(target)), w.U32(static_cast<uint32_t>(off));
      std::memcpy(chunk.data() + 5, blob.data() + off, n);
      Command(protocol::MsgType::kUploadChunk, chunk);
    }
    const uint8_t commit = static_cast<uint8_t>(target);
    Command(protocol::MsgType::kUploadCommit, std::span<const uint8_t>(&commit, 1));
  }
  // Polls every 100 µs of simulated time until `until_us`, or until the camera has finished and
  // the loop has nothing left to capture.
  void RunUntil(uint64_t until_us) {
    while (clock_.now < until_us) {
      loop_->Poll();
      clock_.now += 100;
      uart_.Advance(clock_.now);
      if (camera_->Finished() && !loop_->capture_active()) break;
    }
  }
  void Drain() {
    for (int i = 0; i < 100000; ++i) {
      clock_.now += 100;
      uart_.Advance(clock_.now);
    }
  }
  // `frames` frame periods with one capture of `pairs` pairs requested at the start; the wire
  // decoded.
  Received RunCapture(uint32_t frames, uint16_t pairs, protocol::CaptureMode mode,
                      bool with_calibration = false, uint8_t cameras = 3) {
    Start(frames, with_calibration);
    Capture(pairs, mode, cameras);
    RunUntil(1000 + frames * kPeriodUs);
    Drain();
    return DecodeWire(uart_);
  }
  // A clean stream of `pairs` whole pairs and one "complete" end.
  static ::testing::AssertionResult Complete(const Received& r, size_t pairs) {
    if (r.decoder_errors != 0 || r.seq_gaps != 0) {
      return ::testing::AssertionFailure()
             << r.decoder_errors << " decoder errors, " << r.seq_gaps << " sequence gaps";
    }
    if (r.pairs.size() != pairs) {
      return ::testing::AssertionFailure() << r.pairs.size() << " pairs, not " << pairs << " "
                                           << (r.messages.empty() ? "" : r.messages[0]);
    }
    if (r.ends.size() != 1 || r.ends[0].reason != protocol::CaptureEndReason::kComplete) {
      return ::testing::AssertionFailure() << r.ends.size() << " ends, not one 'complete'";
    }
    return ::testing::AssertionSuccess();
  }

  SimClock clock_;
  PacedUart uart_;
  NoStorage storage_;
  MemStorage cal_storage_;
  std::vector<uint8_t> upload_ = std::vector<uint8_t>(kUploadBufferBytes);
  std::vector<uint8_t> scratch_ = std::vector<uint8_t>(kBlobScratchBytes);
  PipelineTables tables_;
  std::unique_ptr<SimCamera> camera_;
  std::unique_ptr<MainLoop> loop_;
  uint32_t cmd_seq_ = 1;
};

TEST_F(CaptureLoopTest, QuarterCaptureArrivesIntactWhileBallStatesKeepTheirRate) {
  const Received r = RunCapture(90, 2, protocol::CaptureMode::kQuarter);  // 3 s
  ASSERT_TRUE(Complete(r, 2));
  EXPECT_EQ(r.ends[0].pairs_sent, 2);
  for (const tools::CapturedPair& p : r.pairs) {
    const uint32_t src = p.frame.omni_sequence;
    EXPECT_EQ(p.frame.exposure_us, 1000 + uint64_t{src} * kPeriodUs);
    EXPECT_EQ(p.image[0], Expected(src, 0, protocol::CaptureMode::kQuarter)) << "pair " << src;
    EXPECT_EQ(p.image[1], Expected(src, 1, protocol::CaptureMode::kQuarter)) << "pair " << src;
  }
  EXPECT_GT(r.pairs[1].frame.omni_sequence, r.pairs[0].frame.omni_sequence);
  // Every pair got its ball state; none waited longer than a frame period plus two chunks.
  EXPECT_EQ(r.ball_done_us.size(), 90u);
  EXPECT_EQ(loop_->status().packets_dropped, 0u);
  EXPECT_EQ(camera_->frames_lost, 0u);
  EXPECT_LE(camera_->max_held, 2);
  uint64_t worst_gap = 0;
  for (size_t i = 1; i < r.ball_done_us.size(); ++i) {
    worst_gap = std::max(worst_gap, r.ball_done_us[i] - r.ball_done_us[i - 1]);
  }
  EXPECT_LT(worst_gap, kPeriodUs + 12000) << "ball-state spacing on the wire";
  // The capture used most of the link: at least 70 % of 92160 B/s while it ran.
  const double rate = r.capture_bytes / ((r.last_chunk_us - r.first_chunk_us) * 1e-6);
  EXPECT_GT(rate, 0.7 * 92160) << rate;
}

TEST_F(CaptureLoopTest, RefusesASecondCaptureAndStopsOnCommand) {
  Start(150);
  Capture(5, protocol::CaptureMode::kHalf, protocol::kCaptureOmni);  // ~1.8 s a pair
  RunUntil(1000 + 5 * kPeriodUs);
  Capture(1, protocol::CaptureMode::kFull);    // while the first runs
  Capture(500, protocol::CaptureMode::kFull);  // absurd
  RunUntil(1000 + 90 * kPeriodUs);
  Command(protocol::MsgType::kCaptureStop, {});
  RunUntil(1000 + 150 * kPeriodUs);
  Drain();
  const Received r = DecodeWire(uart_);
  ASSERT_EQ(r.errors.size(), 2u);
  EXPECT_EQ(r.errors[0][0], static_cast<uint8_t>(protocol::MsgType::kCaptureStart));
  EXPECT_EQ(r.errors[0][5], static_cast<uint8_t>(protocol::CommandError::kBusy));
  EXPECT_EQ(r.errors[1][5], static_cast<uint8_t>(protocol::CommandError::kBadValue));
  ASSERT_EQ(r.ends.size(), 1u);
  EXPECT_EQ(r.ends[0].reason, protocol::CaptureEndReason::kStopped);
  EXPECT_EQ(r.ends[0].requested, 5);
  EXPECT_EQ(r.ends[0].pairs_sent, r.pairs.size());
  EXPECT_GE(r.pairs.size(), 1u);
  EXPECT_LT(r.pairs.size(), 5u);
  for (const tools::CapturedPair& p : r.pairs) {
    EXPECT_TRUE(p.image[1].empty()) << "omni only was asked for";
    EXPECT_EQ(p.image[0], Expected(p.frame.omni_sequence, 0, protocol::CaptureMode::kHalf));
  }
  EXPECT_EQ(r.ball_done_us.size(), 150u);
  EXPECT_LE(camera_->max_held, 2);
}

TEST_F(CaptureLoopTest, CameraThatEndsCutsTheCaptureShortAndSaysSo) {
  Start(10);  // 0.33 s: one full pair takes ~14 s of link time
  Capture(3, protocol::CaptureMode::kFull, protocol::kCapturePersp);
  // The loop keeps streaming the held pair after the camera's end (RunUntilFinished does the
  // same on the board, where the UART drains by itself).
  loop_->Poll();  // reads the request
  ASSERT_TRUE(loop_->capture_active());
  for (int i = 0; i < 400000 && loop_->capture_active(); ++i) {
    clock_.now += 100;
    uart_.Advance(clock_.now);
    loop_->Poll();
  }
  EXPECT_TRUE(camera_->Finished());
  Drain();
  const Received r = DecodeWire(uart_);
  ASSERT_EQ(r.pairs.size(), 1u);
  EXPECT_EQ(r.pairs[0].image[1],
            Expected(r.pairs[0].frame.persp_sequence, 1, protocol::CaptureMode::kFull));
  ASSERT_EQ(r.ends.size(), 1u);
  EXPECT_EQ(r.ends[0].reason, protocol::CaptureEndReason::kCameraFinished);
  EXPECT_EQ(r.ends[0].pairs_sent, 1);
}

TEST_F(CaptureLoopTest, StreamCutHalfWayKeepsTheCompletePairs) {
  const Received whole = RunCapture(120, 3, protocol::CaptureMode::kQuarter);
  ASSERT_EQ(whole.pairs.size(), 3u);
  // Cut inside the second pair's images.
  size_t cut = 0;
  {
    protocol::Decoder d;
    protocol::FrameView f;
    int chunks = 0;
    for (size_t i = 0; i < uart_.wire.size() && cut == 0; ++i) {
      if (d.Push(uart_.wire[i], f) && f.type == protocol::MsgType::kCaptureChunk &&
          ++chunks == 150 + 75) {
        cut = i + 1;  // pair 0 has 150 chunks, pair 1 is half sent
      }
    }
  }
  ASSERT_GT(cut, 0u);
  const Received r = DecodeWire(uart_, cut);
  ASSERT_EQ(r.pairs.size(), 1u);
  EXPECT_EQ(r.pairs[0].image[0], whole.pairs[0].image[0]);
  EXPECT_TRUE(r.ends.empty());
  ASSERT_FALSE(r.messages.empty());
  EXPECT_EQ(r.messages.back(),
            "pair 1 of capture 1 incomplete: the stream ended after 38400 of 76800 bytes");
}

// Mode 3: the samples of the scan tables the host builds from the same calibration, at their
// pixels, equal to the source frame there (read from the pattern, not from the loop's tables).
TEST_F(CaptureLoopTest, ScanlineCapturePutsEverySampleOfTheTablesAtItsPixel) {
  const Received r =
      RunCapture(120, 3, protocol::CaptureMode::kScanlines, /*with_calibration=*/true);
  ASSERT_TRUE(Complete(r, 3));
  auto host = std::make_unique<tools::ScanTables>();
  std::string error;
  ASSERT_TRUE(host->Build(cli::MakeDemoCalibration(), error)) << error;
  const uint32_t n[2] = {host->table(0).pixel_count(), host->table(1).pixel_count()};
  ASSERT_GT(n[0], 10000u);
  ASSERT_GT(n[1], 5000u);
  for (const tools::CapturedPair& p : r.pairs) {
    EXPECT_EQ(p.frame.mode, protocol::CaptureMode::kScanlines);
    EXPECT_EQ(p.frame.width, 640);
    EXPECT_EQ(p.frame.height, 480);
    EXPECT_EQ(p.frame.image_bytes, 16u + 3u * (n[0] + n[1]));
    const uint32_t src = p.frame.omni_sequence;
    for (int cam = 0; cam < 2; ++cam) {
      std::vector<uint8_t> img;
      ASSERT_TRUE(tools::ScanStreamToImage(p.image[cam], host->table(cam), "cam", img, error))
          << error;
      std::vector<uint8_t> is_sample(640 * 480, 0);
      size_t bad = 0;
      ForEachScanPixel(host->table(cam), [&](int u, int v) {
        is_sample[static_cast<size_t>(v) * 640 + u] = 1;
        const size_t row = static_cast<size_t>(v) * 1280, pair = row + (u & ~1) * 2;
        const uint8_t* got = img.data() + pair;
        if (got[(u & 1) * 2] != PatternByte(src, cam, row + 2 * u) ||
            got[1] != PatternByte(src, cam, pair + 1) ||
            got[3] != PatternByte(src, cam, pair + 3)) {
          ++bad;
        }
      });
      EXPECT_EQ(bad, 0u) << "camera " << cam << " pair " << src;
      size_t not_fill = 0;
      for (size_t i = 0; i < is_sample.size(); ++i) {
        if (!is_sample[i] && img[2 * i] != tools::kScanFillY) ++not_fill;
      }
      EXPECT_EQ(not_fill, 0u) << "every pixel off the table is fill";
    }
  }
  // The fill is nothing to the built-in table: no ball, field, line or obstacle seeds.
  EXPECT_EQ(
      loop_->lut().Classify(tools::kScanFillY, tools::kScanFillChroma, tools::kScanFillChroma),
      ColorClass::kUnknown);
  EXPECT_EQ(r.ball_done_us.size(), 120u) << "every pair kept its ball state";
  EXPECT_EQ(loop_->status().packets_dropped, 0u);
  EXPECT_LE(camera_->max_held, 2);
  const double rate = r.capture_bytes / ((r.last_chunk_us - r.first_chunk_us) * 1e-6);
  EXPECT_GT(rate, 0.7 * 92160) << rate;
}

// An upload rebuilds the pipeline: a new colour table keeps the scan tables (the capture goes
// on, its samples still right), a calibration that moves them ends the capture.
TEST_F(CaptureLoopTest, ScanlineCaptureOutlivesATableUploadButNotAMovedCalibration) {
  Start(240, /*with_calibration=*/true);
  Capture(3, protocol::CaptureMode::kScanlines);
  RunUntil(1000 + 20 * kPeriodUs);  // inside the first pair
  ASSERT_TRUE(loop_->capture_active());
  static ColorLut lut;
  cli::FillBuiltInLut(lut);
  static uint8_t blob[kColorLutBlobBytes];
  const Result<size_t> lut_bytes = SerializeLut(lut, blob);
  ASSERT_TRUE(lut_bytes.ok());
  Upload(protocol::UploadTarget::kLut, std::span<const uint8_t>(blob, *lut_bytes));
  RunUntil(1000 + 120 * kPeriodUs);
  EXPECT_EQ(loop_->status().lut_state, static_cast<uint8_t>(protocol::BlobState::kOk))
      << "the upload was applied";
  Capture(3, protocol::CaptureMode::kScanlines);  // the second capture
  RunUntil(1000 + 140 * kPeriodUs);
  RigCalibration moved = cli::MakeDemoCalibration();
  moved.omni.center_u += 3.0f;
  moved.calibration_id += 1;
  uint8_t cal_blob[kCalibrationBlobMaxBytes];
  const Result<size_t> cal_bytes = SerializeCalibration(moved, cal_blob);
  ASSERT_TRUE(cal_bytes.ok());
  Upload(protocol::UploadTarget::kCalibration, std::span<const uint8_t>(cal_blob, *cal_bytes));
  RunUntil(1000 + 240 * kPeriodUs);
  Drain();
  const Received r = DecodeWire(uart_);
  ASSERT_EQ(r.ends.size(), 2u);
  EXPECT_EQ(r.ends[0].reason, protocol::CaptureEndReason::kComplete);
  EXPECT_EQ(r.ends[0].pairs_sent, 3);
  EXPECT_EQ(r.ends[1].reason, protocol::CaptureEndReason::kStopped);
  EXPECT_LT(r.ends[1].pairs_sent, 3);
  EXPECT_EQ(loop_->status().calibration_id, moved.calibration_id) << "the upload was applied";
  auto host = std::make_unique<tools::ScanTables>();
  std::string error;
  ASSERT_TRUE(host->Build(cli::MakeDemoCalibration(), error)) << error;
  ASSERT_GE(r.pairs.size(), 3u);
  for (size_t i = 0; i < r.pairs.size(); ++i) {  // every pair sent is whole and right
    const tools::CapturedPair& p = r.pairs[i];
    for (int cam = 0; cam < 2; ++cam) {
      std::vector<uint8_t> img;
      ASSERT_TRUE(tools::ScanStreamToImage(p.image[cam], host->table(cam), "cam", img, error))
          << error;
      size_t bad = 0;
      ForEachScanPixel(host->table(cam), [&](int u, int v) {
        const size_t at = static_cast<size_t>(v) * 1280 + 2 * u;
        if (img[at] != PatternByte(p.frame.omni_sequence, cam, at)) ++bad;
      });
      EXPECT_EQ(bad, 0u) << "pair " << i << " camera " << cam;
    }
  }
}

TEST_F(CaptureLoopTest, ScanlineStreamOfAnotherTableIsRefusedNamingBothCounts) {
  const Received r = RunCapture(60, 1, protocol::CaptureMode::kScanlines,
                                /*with_calibration=*/true, protocol::kCaptureOmni);
  ASSERT_EQ(r.pairs.size(), 1u);
  EXPECT_TRUE(r.pairs[0].image[1].empty());
  auto same = std::make_unique<tools::ScanTables>();
  std::string error;
  ASSERT_TRUE(same->Build(cli::MakeDemoCalibration(), error)) << error;
  std::vector<uint8_t> img;
  ASSERT_TRUE(tools::ScanStreamToImage(r.pairs[0].image[0], same->table(0), "omni", img, error));
  const uint32_t n = same->table(0).pixel_count();
  // A stream with one sample less than the host's table: refused, naming both counts.
  std::vector<uint8_t> shorter(r.pairs[0].image[0].begin(), r.pairs[0].image[0].end() - 3);
  ByteWriter(std::span<uint8_t>(shorter.data(), 4)).U32(n - 1);
  EXPECT_FALSE(tools::ScanStreamToImage(shorter, same->table(0), "omni", img, error));
  EXPECT_NE(error.find("sent " + std::to_string(n - 1) + " scanline samples"), std::string::npos)
      << error;
  EXPECT_NE(error.find("has " + std::to_string(n)), std::string::npos) << error;
  // A host table from another calibration (omni centre 3 px off): refused, by count or CRC.
  RigCalibration other = cli::MakeDemoCalibration();
  other.omni.center_u += 3.0f;
  auto host = std::make_unique<tools::ScanTables>();
  ASSERT_TRUE(host->Build(other, error)) << error;
  EXPECT_FALSE(tools::ScanStreamToImage(r.pairs[0].image[0], host->table(0), "omni", img, error));
  EXPECT_NE(error.find("omni"), std::string::npos) << error;
  // ... and a stream whose count is right but whose positions are not is refused by its CRC.
  std::vector<uint8_t> forged = r.pairs[0].image[0];
  forged[4] ^= 1;  // positions_crc32
  EXPECT_FALSE(tools::ScanStreamToImage(forged, same->table(0), "omni", img, error));
  EXPECT_NE(error.find("positions CRC"), std::string::npos) << error;
}

TEST_F(CaptureLoopTest, UnknownModeIsBadValueAndScanlinesWithoutCalibrationUnsupported) {
  Start(30);  // no calibration: no scan tables
  Capture(1, static_cast<protocol::CaptureMode>(4));
  Capture(1, protocol::CaptureMode::kScanlines);
  RunUntil(1000 + 30 * kPeriodUs);
  Drain();
  const Received r = DecodeWire(uart_);
  ASSERT_EQ(r.errors.size(), 2u);
  EXPECT_EQ(r.errors[0][0], static_cast<uint8_t>(protocol::MsgType::kCaptureStart));
  EXPECT_EQ(r.errors[0][5], static_cast<uint8_t>(protocol::CommandError::kBadValue));
  EXPECT_EQ(r.errors[1][5], static_cast<uint8_t>(protocol::CommandError::kUnsupported));
  EXPECT_TRUE(r.pairs.empty());
  EXPECT_FALSE(loop_->capture_active());
}

// A stream read in pieces of any size is the same stream (the chunks split samples).
TEST(ScanSampleStream, PiecesOfAnySizeGiveTheSameBytes) {
  ScanlineTable<kPerspScanPixels> t;
  ASSERT_TRUE(t.BuildPersp(ReferencePerspScanConfig(), 640, 480).ok());
  std::vector<uint8_t> frame(kFrameBytes);
  for (size_t i = 0; i < frame.size(); ++i) frame[i] = PatternByte(3, 1, i);
  const YuyvImage img{frame.data(), 640, 480, 1280};
  const uint32_t crc = protocol::ScanPositionsCrc(t);
  protocol::ScanSampleStream a, b;
  a.Start(t, crc);
  b.Start(t, crc);
  ASSERT_EQ(a.total_bytes(), 8u + 3u * t.pixel_count());
  std::vector<uint8_t> whole(a.total_bytes()), pieces(a.total_bytes());
  ASSERT_TRUE(a.Read(img, whole));
  for (size_t at = 0, k = 1; at < pieces.size(); at += k, k = k % 13 + 1) {
    const size_t m = std::min(k, pieces.size() - at);
    ASSERT_TRUE(b.Read(img, std::span<uint8_t>(pieces.data() + at, m)));
  }
  EXPECT_EQ(whole, pieces);
  EXPECT_FALSE(a.Read(img, std::span<uint8_t>(whole.data(), 1))) << "past the end";
  uint32_t samples = 0, got_crc = 0;
  ASSERT_TRUE(protocol::ParseScanStreamHeader(whole, samples, got_crc));
  EXPECT_EQ(samples, t.pixel_count());
  EXPECT_EQ(got_crc, crc);
  // The first sample: its pixel's Y, its pair's U and V.
  ScanlineTableBase::Cursor c;
  int u0 = -1, v0 = -1;
  ASSERT_EQ(t.ReadSamples(c, 1, [&](int u, int v) { u0 = u, v0 = v; }), 1u);
  const Yuv p = img.at(u0, v0);
  EXPECT_EQ(whole[8], p.y);
  EXPECT_EQ(whole[9], p.u);
  EXPECT_EQ(whole[10], p.v);
}

TEST_F(CaptureLoopTest, ClockSyncReplyCarriesTheArrivalStampAndEchoesTheRequest) {
  Start(30);
  uint8_t p[12];
  ByteWriter w(p);
  w.U32(5), w.U64(1700000000000042ull);
  clock_.now = 50000;
  Command(protocol::MsgType::kClockSync, p);  // stamped at 50000 by the "interrupt"
  clock_.now = 50800;                         // the loop gets to it 0.8 ms later
  uart_.Advance(clock_.now);                  // the boot status has left: the ring is empty
  loop_->Poll();
  uart_.Advance(clock_.now + 100000);
  const Received r = DecodeWire(uart_);
  ASSERT_EQ(r.syncs.size(), 1u);
  EXPECT_EQ(r.syncs[0].id, 5u);
  EXPECT_EQ(r.syncs[0].t1_host_us, 1700000000000042ull);
  EXPECT_EQ(r.syncs[0].t2_rx_us, 50000u);
  EXPECT_EQ(r.syncs[0].t3_tx_us, 50800u);
  EXPECT_EQ(loop_->sync_replies_sent(), 1u);
  EXPECT_TRUE(r.errors.empty());
}

// During a capture the reply waits for the ring to empty: t3 is when its first byte starts.
TEST_F(CaptureLoopTest, ClockSyncReplyDuringACaptureIsStampedWhenItLeaves) {
  Start(60);
  Capture(1, protocol::CaptureMode::kHalf);
  RunUntil(1000 + 10 * kPeriodUs);
  ASSERT_TRUE(loop_->capture_active());
  uint8_t p[12];
  ByteWriter w(p);
  w.U32(6), w.U64(77);
  Command(protocol::MsgType::kClockSync, p);
  const size_t before = uart_.wire.size();
  RunUntil(1000 + 20 * kPeriodUs);
  Drain();
  const Received r = DecodeWire(uart_);
  ASSERT_EQ(r.syncs.size(), 1u);
  const protocol::ClockSyncReply& s = r.syncs[0];
  EXPECT_GT(s.t3_tx_us, s.t2_rx_us + 1000) << "a chunk was on the line: the reply waited";
  EXPECT_LT(s.t3_tx_us, s.t2_rx_us + 15000) << "at most two chunks and a ball state";
  // Find the reply's first byte on the wire: the byte after the delimiter that precedes it.
  protocol::Decoder d;
  protocol::FrameView f;
  size_t start = 0;
  for (size_t i = 0; i < uart_.wire.size(); ++i) {
    if (!d.Push(uart_.wire[i], f)) continue;
    if (f.type == protocol::MsgType::kClockSyncReply) break;
    start = i + 1;
  }
  ASSERT_GT(start, before);
  const double byte_us = 1.0 / kBytesPerUs;
  EXPECT_NEAR(static_cast<double>(uart_.wire_done_us[start]) - byte_us,
              static_cast<double>(s.t3_tx_us), 100 + byte_us)
      << "first byte left within one poll step of t3";
  EXPECT_EQ(r.seq_gaps, 0u);
}

}  // namespace
}  // namespace bv::fw
