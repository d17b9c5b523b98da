// The board-independent firmware main loop on the host, with fixed-size fakes for the HAL.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <functional>
#include <memory>
#include <vector>

#include <Eigen/Geometry>

#include "core/common/blob.h"
#include "core/common/bytes.h"
#include "core/common/crc32.h"
#include "core/protocol/protocol.h"
#include "firmware/main_loop.h"
#include "hal/common/blob_store.h"
#include "host_tests/link_sim.h"
#include "tools/ballvision/demo_scene.h"
#include "tools/ballvision/run_common.h"
// The firmware folder is only built for the target; the loop is compiled into this test.
#include "firmware/main_loop.cpp"  // NOLINT(build/include)

namespace bv::fw {
namespace {

alignas(32) uint8_t g_frame[kFrameBytes];  // one grey frame shared by every fake pair
// Pairs drawn one by one (FakeCamera::render), each camera its own image.
alignas(32) uint8_t g_omni_frame[kFrameBytes], g_persp_frame[kFrameBytes];

struct ScriptedPair {
  uint64_t t_us;
  uint32_t flags;
  uint32_t dropped;
};

class FakeCamera : public hal::Camera {
 public:
  static constexpr size_t kCapacity = 128;
  void Add(const ScriptedPair& p) { script_[count_++] = p; }
  void AddRegular(int n, uint64_t period_us) {
    for (int i = 0; i < n; ++i) Add({static_cast<uint64_t>(i) * period_us, 0, 0});
  }
  int held() const { return held_; }
  uint32_t bad_input = 0;  // what the camera layer says it refused
  int idle_polls = 1;      // kUnavailable answers before each pair (the loop must poll, not block)
  // When set, draws pair k (counted from the first Add) into the two frames instead of g_frame.
  std::function<void(size_t k, uint8_t* omni, uint8_t* persp)> render;

 private:
  Status DoStart() override { return Status(); }
  Status DoAcquirePair(hal::FramePair& out) override {
    if (next_ >= count_) return Status(StatusCode::kUnavailable, "end");
    if (idle_left_-- > 0) return Status(StatusCode::kUnavailable, "not yet");
    idle_left_ = idle_polls;
    const ScriptedPair& p = script_[next_];
    const uint8_t* omni = g_frame;
    const uint8_t* persp = g_frame;
    if (render) {
      render(next_, g_omni_frame, g_persp_frame);
      omni = g_omni_frame;
      persp = g_persp_frame;
    }
    ++next_;
    out = hal::FramePair{};
    if (!(p.flags & hal::kPairOmniMissing)) out.omni = {omni, kFrameBytes, p.t_us, 0, true};
    if (!(p.flags & hal::kPairPerspMissing)) out.persp = {persp, kFrameBytes, p.t_us, 0, true};
    out.exposure_us = p.t_us;
    out.flags = p.flags;
    out.dropped = p.dropped;
    ++held_;
    return Status();
  }
  void DoRelease(const hal::FramePair&) override { --held_; }
  bool DoFinished() const override { return next_ >= count_; }
  uint32_t DoBadInputCount() const override { return bad_input; }

  std::array<ScriptedPair, kCapacity> script_{};
  size_t count_ = 0, next_ = 0;
  int idle_left_ = 0;
  int held_ = 0;
};

template <size_t kCapacity>
class FakeUart : public hal::Uart {
 public:
  std::span<const uint8_t> bytes() const { return {buf_.data(), size_}; }
  bool full = false;  // simulates a transmit buffer without room
  uint32_t refused = 0;
  // A TX ring of `ring` bytes that the line empties by Drain() (default: unlimited).
  size_t ring = SIZE_MAX;
  size_t queued = 0;
  void Drain(size_t n) { queued -= std::min(n, queued); }
  /// Queues bytes "received from the main computer".
  void Feed(std::span<const uint8_t> b) {
    ASSERT_LE(rx_len_ + b.size(), rx_.size());
    std::memcpy(rx_.data() + rx_len_, b.data(), b.size());
    rx_len_ += b.size();
  }
  bool rx_empty() const { return rx_pos_ == rx_len_; }
  /// What was transmitted so far; the record starts empty again (a long exchange in rounds).
  std::vector<uint8_t> TakeBytes() {
    std::vector<uint8_t> out(buf_.begin(), buf_.begin() + static_cast<std::ptrdiff_t>(size_));
    size_ = 0;
    return out;
  }
  hal::UartRxStats rx_stats;  // what the board driver would report

 private:
  Status DoWrite(std::span<const uint8_t> b) override {
    if (full || b.size() > kCapacity - size_ || b.size() > DoWriteSpace()) {
      ++refused;
      return Status(StatusCode::kUnavailable, "full");
    }
    std::memcpy(buf_.data() + size_, b.data(), b.size());
    size_ += b.size();
    queued += b.size();
    return Status();
  }
  size_t DoWriteSpace() const override {
    if (full) return 0;
    return std::min(kCapacity - size_, ring == SIZE_MAX ? SIZE_MAX : ring - queued);
  }
  hal::UartRxStats DoRxStats() const override { return rx_stats; }
  Result<size_t> DoRead(std::span<uint8_t> out) override {
    const size_t n = std::min(out.size(), rx_len_ - rx_pos_);
    std::memcpy(out.data(), rx_.data() + rx_pos_, n);
    rx_pos_ += n;
    return n;
  }
  std::array<uint8_t, kCapacity> buf_{};
  size_t size_ = 0;
  std::array<uint8_t, 160 * 1024> rx_{};
  size_t rx_len_ = 0, rx_pos_ = 0;
};

// Every reading advances time by step_us: the loop reads the clock a fixed number of times per
// pair, so processing time is proportional to step_us.
class FakeClock : public hal::Clock {
 public:
  uint64_t step_us = 1;

 private:
  uint64_t DoNowUs() const override { return now_us_ += step_us; }
  mutable uint64_t now_us_ = 0;
};

struct Decoded {
  int balls = 0;
  int statuses = 0;
  uint32_t decoder_errors = 0;
  uint64_t ball_t_us[FakeCamera::kCapacity] = {};
  protocol::StatusReport first_status, last_status;
  int status_count_between_first_and_last_ball = 0;
};

Decoded Decode(std::span<const uint8_t> bytes) {
  Decoded d;
  protocol::Decoder dec;
  protocol::FrameView f;
  uint32_t expected_seq = 0;
  for (uint8_t b : bytes) {
    if (!dec.Push(b, f)) continue;
    EXPECT_EQ(f.seq, expected_seq++) << "packet sequence numbers must be contiguous";
    if (f.type == protocol::MsgType::kBallState) {
      BallState s;
      EXPECT_TRUE(protocol::ParseBallState(f.payload, s).ok());
      if (d.balls < static_cast<int>(FakeCamera::kCapacity)) d.ball_t_us[d.balls] = s.t_us;
      ++d.balls;
    } else if (f.type == protocol::MsgType::kStatus) {
      protocol::StatusReport st;
      EXPECT_TRUE(protocol::ParseStatus(f.payload, st).ok());
      if (d.statuses == 0) d.first_status = st;
      d.last_status = st;
      if (d.balls > 0) ++d.status_count_between_first_and_last_ball;
      ++d.statuses;
    }
  }
  d.decoder_errors = dec.stats().errors();
  return d;
}

class MainLoopTest : public ::testing::Test {
 protected:
  void Run(const MainLoopConfig& config = MainLoopConfig()) {
    loop_ = std::make_unique<MainLoop>(camera_, uart_, clock_, storage_, tables_, scratch_, config);
    init_ = loop_->Init();
    loop_->RunUntilFinished();
  }
  // A valid demo calibration and the built-in table in storage: the pipeline runs (features on).
  void InstallDemoBlobs(uint32_t* calibration_id = nullptr, uint32_t* lut_id = nullptr,
                        bool with_lut = true, const OmniSelfMask* self_mask = nullptr) {
    static ColorLut lut;
    cli::FillBuiltInLut(lut);
    RigCalibration cal = cli::MakeDemoCalibration();
    if (self_mask != nullptr) cal.omni.self_mask = *self_mask;
    cal.lut_id = lut.Id();
    if (calibration_id != nullptr) *calibration_id = cal.calibration_id;
    if (lut_id != nullptr) *lut_id = cal.lut_id;
    static uint8_t blob[kColorLutBlobBytes];
    const Result<size_t> cal_bytes = SerializeCalibration(cal, blob);
    ASSERT_TRUE(cal_bytes.ok()) << cal_bytes.status().message();
    hal::BlobStore cal_store(storage_, 0, 1, BlobKind::kCalibration, kCalibrationBlobVersion);
    ASSERT_TRUE(cal_store.Save(std::span<const uint8_t>(blob, *cal_bytes), scratch_).ok());
    if (!with_lut) return;
    const Result<size_t> lut_bytes = SerializeLut(lut, blob);
    ASSERT_TRUE(lut_bytes.ok());
    hal::BlobStore lut_store(storage_, 2, 3, BlobKind::kColorLut, kColorLutBlobVersion);
    ASSERT_TRUE(lut_store.Save(std::span<const uint8_t>(blob, *lut_bytes), scratch_).ok());
  }
  FakeCamera camera_;
  FakeUart<64 * 1024> uart_;
  FakeClock clock_;
  sim::MemStorage storage_;
  std::array<uint8_t, kBlobScratchBytes> scratch_{};
  PipelineTables tables_, reboot_tables_;  // the reboot tests run a second loop beside loop_
  std::unique_ptr<MainLoop> loop_;
  Status init_;
};

class CountingWatchdog : public hal::Watchdog {
 public:
  int feeds = 0;

 private:
  void DoFeed() override { ++feeds; }
};

// The watchdog hears from the loop itself, once per iteration, not from a driver: a loop that
// stops iterating (a hung pipeline, a stuck command) stops feeding it.
TEST_F(MainLoopTest, TheWatchdogIsFedOncePerIteration) {
  camera_.AddRegular(6, 33333);
  CountingWatchdog watchdog;
  loop_ = std::make_unique<MainLoop>(camera_, uart_, clock_, storage_, tables_, scratch_,
                                     MainLoopConfig(), &watchdog);
  ASSERT_TRUE(loop_->Init().ok());
  EXPECT_EQ(watchdog.feeds, 0);
  int polls = 0;
  while (!camera_.Finished()) {
    loop_->Poll();
    ++polls;
    ASSERT_EQ(watchdog.feeds, polls);
  }
  EXPECT_GT(polls, 6);  // idle polls between pairs feed it too
}

TEST_F(MainLoopTest, InputTheCameraRefusedIsAFaultInTheStatus) {
  camera_.AddRegular(10, 33333);
  Run();
  EXPECT_EQ(Decode(uart_.bytes()).last_status.fault_flags & kFaultCameraBadInput, 0u);
  camera_ = FakeCamera();
  uart_ = FakeUart<64 * 1024>();
  camera_.AddRegular(10, 33333);
  camera_.bad_input = 1;
  Run();
  EXPECT_NE(Decode(uart_.bytes()).last_status.fault_flags & kFaultCameraBadInput, 0u);
}

TEST_F(MainLoopTest, WithoutCalibrationEveryPairStillGivesOnePacketAndStatusSaysMissing) {
  camera_.AddRegular(10, 33333);
  Run();
  ASSERT_TRUE(init_.ok()) << init_.message();
  EXPECT_EQ(camera_.held(), 0) << "every acquired pair released";
  const Decoded d = Decode(uart_.bytes());
  EXPECT_EQ(d.decoder_errors, 0u);
  EXPECT_EQ(d.balls, 10);
  for (int i = 0; i < 10; ++i) EXPECT_EQ(d.ball_t_us[i], static_cast<uint64_t>(i) * 33333);
  ASSERT_EQ(d.statuses, 2) << "boot + final (10 frames span < 1 s)";
  EXPECT_EQ(d.first_status.frames_processed, 0u);
  EXPECT_EQ(d.last_status.frames_processed, 10u);
  EXPECT_EQ(d.last_status.calibration_state, static_cast<uint8_t>(protocol::BlobState::kMissing));
  EXPECT_EQ(d.last_status.lut_state, static_cast<uint8_t>(protocol::BlobState::kBuiltInMissing));
  EXPECT_TRUE(d.last_status.fault_flags & kFaultPipelineNotReady) << "no calibration";
  EXPECT_EQ(d.last_status.frame_rate_mhz, 30000u);
  EXPECT_EQ(d.last_status.deadline_overruns, 0u);
  EXPECT_FALSE(loop_->pipeline_ready());
}

TEST_F(MainLoopTest, CorruptBlobsAreReportedAndTheLoopKeepsRunning) {
  // Slot A: right magic, wrong CRC. Slot B of the LUT: a truncated header.
  uint8_t payload[8] = {1, 2, 3, 4, 5, 6, 7, 8};
  uint8_t blob[64];
  const Result<size_t> n = WriteBlob(BlobKind::kCalibration, 1, payload, blob);
  ASSERT_TRUE(n.ok());
  blob[*n - 1] ^= 0xFF;
  storage_.Put(0, std::span<const uint8_t>(blob, *n));
  const Result<size_t> m = WriteBlob(BlobKind::kColorLut, 1, payload, blob);
  ASSERT_TRUE(m.ok());
  storage_.Put(3, std::span<const uint8_t>(blob, 10));  // header cut short, rest erased (0xFF)
  camera_.AddRegular(3, 33333);
  Run();
  const Decoded d = Decode(uart_.bytes());
  EXPECT_EQ(d.balls, 3);
  EXPECT_EQ(d.last_status.calibration_state, static_cast<uint8_t>(protocol::BlobState::kCorrupt));
  EXPECT_EQ(d.last_status.lut_state, static_cast<uint8_t>(protocol::BlobState::kBuiltInCorrupt));
}

TEST_F(MainLoopTest, ValidLutBlobIsLoadedAndItsIdReported) {
  static ColorLut lut;
  lut.Fill(ColorClass::kField);
  lut.Set(ColorLut::Index(200, 60, 200), ColorClass::kBall);
  static uint8_t blob[kColorLutBlobBytes];
  const Result<size_t> n = SerializeLut(lut, blob);
  ASSERT_TRUE(n.ok());
  hal::BlobStore store(storage_, 2, 3, BlobKind::kColorLut, kColorLutBlobVersion);
  ASSERT_TRUE(store.Save(std::span<const uint8_t>(blob, *n), scratch_).ok());
  camera_.AddRegular(2, 33333);
  Run();
  const Decoded d = Decode(uart_.bytes());
  EXPECT_EQ(d.last_status.lut_state, static_cast<uint8_t>(protocol::BlobState::kOk));
  EXPECT_EQ(d.last_status.lut_id, lut.Id());
  EXPECT_EQ(d.last_status.calibration_state, static_cast<uint8_t>(protocol::BlobState::kMissing));
  EXPECT_FALSE(loop_->pipeline_ready()) << "a LUT without calibration is not enough";
}

TEST_F(MainLoopTest, WithoutAStoredLutTheBuiltInColourModelRunsThePipeline) {
  uint32_t calibration_id = 0, lut_id = 0;
  InstallDemoBlobs(&calibration_id, &lut_id, /*with_lut=*/false);
  camera_.AddRegular(3, 33333);
  Run();
  ASSERT_TRUE(loop_->pipeline_ready());
  const Decoded d = Decode(uart_.bytes());
  EXPECT_EQ(d.last_status.lut_state, static_cast<uint8_t>(protocol::BlobState::kBuiltInMissing));
  static ColorLut builtin;
  ASSERT_TRUE(BuildLut(BallColorModel{}, builtin).ok());
  EXPECT_EQ(d.last_status.lut_id, builtin.Id());
  EXPECT_EQ(d.last_status.fault_flags & kFaultPipelineNotReady, 0u);
}

TEST_F(MainLoopTest, WithCalibrationAndLutThePipelineRunsOnEveryPair) {
  uint32_t calibration_id = 0, lut_id = 0;
  InstallDemoBlobs(&calibration_id, &lut_id);

  camera_.AddRegular(5, 33333);
  camera_.Add({5 * 33333, hal::kPairPerspMissing, 0});  // the pipeline copes with one camera
  Run();
  ASSERT_TRUE(loop_->pipeline_ready());
  const Decoded d = Decode(uart_.bytes());
  EXPECT_EQ(d.balls, 6);
  const protocol::StatusReport& s = d.last_status;
  EXPECT_EQ(s.calibration_state, static_cast<uint8_t>(protocol::BlobState::kOk));
  EXPECT_EQ(s.calibration_id, calibration_id);
  EXPECT_EQ(s.lut_id, lut_id);
  EXPECT_EQ(s.pipeline_errors, 0u);
  EXPECT_EQ(s.fault_flags & kFaultPipelineNotReady, 0u);
}

// A calibration without a self-mask runs on the reference rig's geometry, and the status says so;
// one with a mask clears the flag.
TEST_F(MainLoopTest, TheStatusSaysWhetherTheOmniCalibrationHasASelfMask) {
  InstallDemoBlobs();
  camera_.AddRegular(3, 33333);
  Run();
  ASSERT_TRUE(loop_->pipeline_ready());
  EXPECT_NE(Decode(uart_.bytes()).last_status.fault_flags & kFaultNoSelfMask, 0u);
}

TEST_F(MainLoopTest, ALearnedSelfMaskClearsTheNoSelfMaskFlag) {
  OmniSelfMask mask;
  mask.known = true;
  mask.inner_radius_px = 54.0f;
  mask.outer_radius_px = 219.0f;
  mask.sector_count = 3;
  const float angles[] = {14.5f, 134.8f, 256.5f};
  for (int i = 0; i < 3; ++i) mask.sectors[i] = {angles[i], 2.5f};
  for (uint8_t& b : mask.body_px) b = 50;
  InstallDemoBlobs(nullptr, nullptr, true, &mask);
  camera_.AddRegular(3, 33333);
  Run();
  ASSERT_TRUE(loop_->pipeline_ready());
  const Decoded d = Decode(uart_.bytes());
  EXPECT_EQ(d.last_status.fault_flags & kFaultNoSelfMask, 0u);
  EXPECT_EQ(d.balls, 3);
}

TEST_F(MainLoopTest, StatusAtLeastOncePerSecondOfExposureTimeWithFrameRate) {
  camera_.AddRegular(100, 33333);  // 3.3 s
  Run();
  const Decoded d = Decode(uart_.bytes());
  EXPECT_EQ(d.balls, 100);
  // boot + at 1 s, 2 s, 3 s of exposure time + final
  EXPECT_EQ(d.statuses, 5);
  EXPECT_NEAR(d.last_status.frame_rate_mhz, 30000u, 30u);
}

TEST_F(MainLoopTest, PairFlagsAndDroppedFramesAreCounted) {
  camera_.Add({0, 0, 0});
  camera_.Add({33333, hal::kPairOmniMissing, 2});
  camera_.Add({66666, hal::kPairPerspMissing, 0});
  camera_.Add({99999, hal::kPairOutOfSync | hal::kPairTorn, 1});
  camera_.Add({50000, hal::kPairOutOfOrder, 0});
  Run();
  const Decoded d = Decode(uart_.bytes());
  EXPECT_EQ(d.balls, 5);
  const protocol::StatusReport& s = d.last_status;
  EXPECT_EQ(s.frames_processed, 5u);
  EXPECT_EQ(s.frames_dropped, 3u);
  EXPECT_EQ(s.pairs_omni_missing, 1u);
  EXPECT_EQ(s.pairs_persp_missing, 1u);
  EXPECT_EQ(s.pairs_out_of_sync, 1u);
  EXPECT_EQ(s.pairs_torn, 1u);
  EXPECT_EQ(s.pairs_out_of_order, 1u);
}

TEST_F(MainLoopTest, SlowProcessingCountsOverruns) {
  camera_.AddRegular(4, 33333);
  clock_.step_us = 20000;  // the loop reads the clock several times per pair: > 33333 us each
  MainLoopConfig config;
  Run(config);
  const Decoded d = Decode(uart_.bytes());
  EXPECT_EQ(d.last_status.deadline_overruns, 4u);
  EXPECT_GT(d.last_status.max_proc_us, config.frame_period_us);
}

TEST_F(MainLoopTest, FullUartDropsWholePacketsAndCountsThem) {
  camera_.AddRegular(6, 33333);
  loop_ = std::make_unique<MainLoop>(camera_, uart_, clock_, storage_, tables_, scratch_);
  ASSERT_TRUE(loop_->Init().ok());
  for (int i = 0; i < 3; ++i) {
    while (!loop_->Poll()) {
    }
  }
  uart_.full = true;
  for (int i = 0; i < 2; ++i) {
    while (!loop_->Poll()) {
    }
  }
  uart_.full = false;
  loop_->RunUntilFinished();
  EXPECT_EQ(loop_->status().packets_dropped, 2u);
  protocol::Decoder dec;
  protocol::FrameView f;
  int balls = 0;
  uint32_t last_seq = 0, gaps = 0;
  for (uint8_t b : uart_.bytes()) {
    if (!dec.Push(b, f)) continue;
    if (f.seq != 0 && f.seq != last_seq + 1) ++gaps;
    last_seq = f.seq;
    balls += f.type == protocol::MsgType::kBallState;
  }
  EXPECT_EQ(dec.stats().errors(), 0u) << "no partial packet ever reached the stream";
  EXPECT_EQ(balls, 4);
  EXPECT_EQ(gaps, 1u) << "the receiver sees the drop as one sequence gap";
}

// Per pair in transmission order: the packet types and their exposure times.
struct StreamEntry {
  protocol::MsgType type;
  uint64_t t_us;
  uint32_t seq;
};

std::vector<StreamEntry> Stream(std::span<const uint8_t> bytes, uint32_t& decoder_errors,
                                protocol::StatusReport& last_status, int& bad_payloads) {
  std::vector<StreamEntry> out;
  protocol::Decoder dec;
  protocol::FrameView f;
  bad_payloads = 0;
  for (uint8_t b : bytes) {
    if (!dec.Push(b, f)) continue;
    uint64_t t = 0;
    bool ok = true;
    if (f.type == protocol::MsgType::kBallState) {
      BallState s;
      ok = protocol::ParseBallState(f.payload, s).ok();
      t = s.t_us;
    } else if (f.type == protocol::MsgType::kPose) {
      protocol::PoseReport p;
      ok = protocol::ParsePose(f.payload, p).ok();
      t = p.t_us;
    } else if (f.type == protocol::MsgType::kLinePoints) {
      protocol::LinePointsReport l;
      ok = protocol::ParseLinePoints(f.payload, l).ok();
      t = l.t_us;
    } else if (f.type == protocol::MsgType::kObstacles) {
      protocol::ObstaclesReport o;
      ok = protocol::ParseObstacles(f.payload, o).ok();
      t = o.t_us;
    } else if (f.type == protocol::MsgType::kGoals) {
      protocol::GoalsReport g;
      ok = protocol::ParseGoals(f.payload, g).ok();
      t = g.t_us;
    } else if (f.type == protocol::MsgType::kStatus) {
      ok = protocol::ParseStatus(f.payload, last_status).ok();
    }
    bad_payloads += ok ? 0 : 1;
    out.push_back({f.type, t, f.seq});
  }
  decoder_errors = dec.stats().errors();
  return out;
}

TEST_F(MainLoopTest, PoseObstaclesGoalsAndLinePointsFollowEachBallState) {
  InstallDemoBlobs();
  camera_.AddRegular(6, 33333);
  camera_.Add({6 * 33333, hal::kPairOmniMissing, 0});  // no new features: ball and pose only
  Run();
  ASSERT_TRUE(loop_->pipeline_ready());
  uint32_t errors = 0;
  int bad = 0;
  protocol::StatusReport last;
  const auto stream = Stream(uart_.bytes(), errors, last, bad);
  EXPECT_EQ(errors, 0u);
  EXPECT_EQ(bad, 0);
  // boot status, then per pair: ball, pose, obstacles, goals, lines (same exposure), then final
  // status.
  ASSERT_EQ(stream.size(), 1u + 6 * 5 + 2 + 1);
  const protocol::MsgType order[5] = {protocol::MsgType::kBallState, protocol::MsgType::kPose,
                                      protocol::MsgType::kObstacles, protocol::MsgType::kGoals,
                                      protocol::MsgType::kLinePoints};
  for (int pair = 0; pair < 6; ++pair) {
    for (int k = 0; k < 5; ++k) {
      const StreamEntry& e = stream[1 + 5 * pair + k];
      EXPECT_EQ(e.type, order[k]) << "pair " << pair << " packet " << k;
      EXPECT_EQ(e.t_us, static_cast<uint64_t>(pair) * 33333) << "pair " << pair;
    }
  }
  EXPECT_EQ(stream[31].type, protocol::MsgType::kBallState);
  EXPECT_EQ(stream[32].type, protocol::MsgType::kPose);
  EXPECT_EQ(stream[32].t_us, 6u * 33333);
  EXPECT_EQ(stream[33].type, protocol::MsgType::kStatus);
  for (size_t i = 0; i < stream.size(); ++i) EXPECT_EQ(stream[i].seq, i);
  EXPECT_EQ(loop_->feature_packets_sent(), 25u);  // 6 x (pose, obstacles, goals, lines) + 1 pose
  EXPECT_EQ(last.feature_packets_dropped, 0u);
  EXPECT_EQ(last.packets_dropped, 0u);
}

// A link slower than the stream (150 bytes per frame period into a 1 KB ring): the field
// packets back up and are dropped, the ball state never is, and it leads each pair's packets.
TEST_F(MainLoopTest, UnderBackpressureBallStatesGoOutFirstAndFeaturesAreDropped) {
  InstallDemoBlobs();
  const int kPairs = 60;
  camera_.AddRegular(kPairs, 33333);
  uart_.ring = 1024;
  loop_ = std::make_unique<MainLoop>(camera_, uart_, clock_, storage_, tables_, scratch_);
  ASSERT_TRUE(loop_->Init().ok());
  ASSERT_TRUE(loop_->pipeline_ready());
  while (!camera_.Finished()) {
    if (loop_->Poll()) uart_.Drain(150);
  }
  uint32_t errors = 0;
  int bad = 0;
  protocol::StatusReport last;
  const auto stream = Stream(uart_.bytes(), errors, last, bad);
  EXPECT_EQ(errors, 0u);
  EXPECT_EQ(bad, 0);
  int balls = 0, field = 0;
  uint64_t last_ball_t = UINT64_MAX;
  for (const StreamEntry& e : stream) {
    if (e.type == protocol::MsgType::kBallState) {
      ++balls;
      last_ball_t = e.t_us;
    } else if (e.type != protocol::MsgType::kStatus) {
      ++field;
      EXPECT_EQ(e.t_us, last_ball_t) << "a field packet before its pair's ball state";
    }
  }
  EXPECT_EQ(balls, kPairs) << "every ball state went out";
  EXPECT_EQ(loop_->status().packets_dropped, 0u);
  EXPECT_GT(loop_->status().feature_packets_dropped, 0u);
  EXPECT_GT(field, 0);
  EXPECT_EQ(static_cast<uint32_t>(field) + loop_->status().feature_packets_dropped, 4u * kPairs);
  EXPECT_EQ(static_cast<uint32_t>(field), loop_->feature_packets_sent());
}

// --- commands from the main computer ---

class MainLoopCommandsTest : public MainLoopTest {
 protected:
  void Start() {
    loop_ = std::make_unique<MainLoop>(camera_, uart_, clock_, storage_, tables_, scratch_,
                                       MainLoopConfig(), nullptr, upload_);
    ASSERT_TRUE(loop_->Init().ok());
  }
  void Command(protocol::MsgType type, std::span<const uint8_t> payload) {
    uint8_t wire[protocol::kMaxWireFrameBytes];
    const Result<size_t> n = protocol::EncodeFrame(type, cmd_seq_++, payload, wire);
    ASSERT_TRUE(n.ok());
    uart_.Feed(std::span<const uint8_t>(wire, *n));
  }
  void SetParam(uint16_t id, float value) {
    uint8_t p[6];
    ByteWriter w(p);
    w.U16(id);
    w.F32(value);
    Command(protocol::MsgType::kSetParam, w.written());
  }
  // The teach command: the ball at (a, b), a floor point or a pixel of one camera.
  void Teach(protocol::TeachWhere where, float a, float b) {
    uint8_t p[protocol::kTeachBallBytes];
    ByteWriter w(p);
    w.U8(static_cast<uint8_t>(where));
    w.F32(a);
    w.F32(b);
    Command(protocol::MsgType::kTeachBall, w.written());
  }
  void UploadBegin(protocol::UploadTarget target, size_t size, uint32_t crc) {
    uint8_t p[9];
    ByteWriter begin(p);
    begin.U8(static_cast<uint8_t>(target));
    begin.U32(static_cast<uint32_t>(size));
    begin.U32(crc);
    Command(protocol::MsgType::kUploadBegin, begin.written());
  }
  void Upload(protocol::UploadTarget target, std::span<const uint8_t> blob, uint32_t crc) {
    UploadBegin(target, blob.size(), crc);
    UploadChunks(target, blob);
    UploadCommit(target);
  }
  void UploadChunks(protocol::UploadTarget target, std::span<const uint8_t> blob) {
    uint8_t p[5 + protocol::kMaxChunkBytes];
    for (size_t off = 0; off < blob.size(); off += protocol::kMaxChunkBytes) {
      const size_t n = std::min(protocol::kMaxChunkBytes, blob.size() - off);
      ByteWriter chunk(p);
      chunk.U8(static_cast<uint8_t>(target));
      chunk.U32(static_cast<uint32_t>(off));
      chunk.Bytes(blob.subspan(off, n));
      Command(protocol::MsgType::kUploadChunk, chunk.written());
    }
  }
  void UploadCommit(protocol::UploadTarget target) {
    const uint8_t t = static_cast<uint8_t>(target);
    Command(protocol::MsgType::kUploadCommit, std::span<const uint8_t>(&t, 1));
  }
  void Drain() {
    while (!uart_.rx_empty()) loop_->Poll();
  }
  // Counts replies in the transmitted stream; `last_error` gets the last error code.
  void Replies(int& acks, int& errors, int& statuses, uint8_t& last_error) {
    acks = errors = statuses = 0;
    protocol::Decoder dec;
    protocol::FrameView f;
    for (uint8_t b : uart_.bytes()) {
      if (!dec.Push(b, f)) continue;
      if (f.type == protocol::MsgType::kAck) ++acks;
      if (f.type == protocol::MsgType::kStatus) ++statuses;
      if (f.type == protocol::MsgType::kError) {
        ++errors;
        last_error = f.payload.size() >= 6 ? f.payload[5] : 0xFF;
      }
    }
  }
  // The built-in table serialised: what the upload tests send.
  std::span<uint8_t> BuiltInLutBlob() {
    cli::FillBuiltInLut(lut_);
    const Result<size_t> n = SerializeLut(lut_, lut_blob_);
    EXPECT_TRUE(n.ok());
    return {lut_blob_, n.ok() ? *n : 0};
  }
  uint8_t upload_[kUploadBufferBytes] = {};
  uint32_t cmd_seq_ = 0;
  ColorLut lut_;
  uint8_t lut_blob_[kColorLutBlobBytes] = {};
};

TEST_F(MainLoopCommandsTest, LutUploadIsVerifiedSavedAndActivated) {
  Start();
  const std::span<const uint8_t> b = BuiltInLutBlob();
  ASSERT_FALSE(b.empty());
  Upload(protocol::UploadTarget::kLut, b, Crc32(b));
  Drain();
  int acks, errors, statuses;
  uint8_t code = 0;
  Replies(acks, errors, statuses, code);
  EXPECT_EQ(errors, 0);
  EXPECT_EQ(acks, static_cast<int>(2 + (b.size() + protocol::kMaxChunkBytes - 1) /
                                           protocol::kMaxChunkBytes));
  EXPECT_EQ(loop_->status().lut_state, static_cast<uint8_t>(protocol::BlobState::kOk));
  EXPECT_EQ(loop_->status().lut_id, lut_.Id());
  // Persisted: a fresh loop over the same storage loads it at boot.
  MainLoop reboot(camera_, uart_, clock_, storage_, reboot_tables_, scratch_);
  ASSERT_TRUE(reboot.Init().ok());
  EXPECT_EQ(reboot.status().lut_id, lut_.Id());
}

// A disc of one colour in the shared fake frame (both cameras), YUYV; restored by the caller.
void PaintDisc(int cu, int cv, int r, uint8_t y, uint8_t u, uint8_t v) {
  for (int row = cv - r; row <= cv + r; ++row) {
    for (int col = cu - r; col <= cu + r; ++col) {
      if ((row - cv) * (row - cv) + (col - cu) * (col - cu) > r * r) continue;
      uint8_t* px = g_frame + (static_cast<size_t>(row) * kFrameWidth + col) * 2;
      px[0] = y;
      px[1] = (col & 1) ? v : u;  // Y0 U Y1 V: the odd pixel's second byte is V
    }
  }
}

TEST_F(MainLoopCommandsTest, TeachAtAPixelLearnsTheBallStoresAndActivatesTheTable) {
  // A yellow ball the built-in red-to-orange model does not take, lit unevenly (two halves).
  std::memset(g_frame, 128, sizeof g_frame);
  PaintDisc(320, 240, 20, 170, 60, 150);
  PaintDisc(330, 240, 10, 110, 86, 142);  // the shaded part: same hue, darker
  Start();
  ASSERT_NE(loop_->lut().Classify(170, 60, 150), ColorClass::kBall) << "test needs a new colour";
  const uint32_t builtin_id = loop_->status().lut_id;
  Teach(protocol::TeachWhere::kPerspPixel, 318.0f, 236.0f);
  loop_->Poll();  // the command: accepted, no reply yet (no pair)
  int acks, errors, statuses;
  uint8_t code = 0;
  Replies(acks, errors, statuses, code);
  EXPECT_EQ(acks + errors, 0) << "answered only once a pair was taught from";
  camera_.AddRegular(1, 33333);
  loop_->RunUntilFinished();
  Replies(acks, errors, statuses, code);
  EXPECT_EQ(errors, 0) << int{code};
  EXPECT_EQ(acks, 1);
  EXPECT_EQ(loop_->status().lut_state, static_cast<uint8_t>(protocol::BlobState::kOk));
  EXPECT_NE(loop_->status().lut_id, builtin_id);
  EXPECT_EQ(loop_->lut().Classify(170, 60, 150), ColorClass::kBall);
  EXPECT_EQ(loop_->lut().Classify(110, 86, 142), ColorClass::kBall) << "the shade too";
  EXPECT_NE(loop_->lut().Classify(128, 128, 128), ColorClass::kBall);
  // Stored as an upload is: a fresh loop loads it.
  MainLoop reboot(camera_, uart_, clock_, storage_, reboot_tables_, scratch_);
  ASSERT_TRUE(reboot.Init().ok());
  EXPECT_EQ(reboot.status().lut_id, loop_->status().lut_id);
  std::memset(g_frame, 128, sizeof g_frame);
}

TEST_F(MainLoopCommandsTest, TeachRefusalsKeepTheOldTable) {
  std::memset(g_frame, 128, sizeof g_frame);
  PaintDisc(320, 240, 20, 170, 60, 150);
  Start();
  const uint32_t before = loop_->status().lut_id;
  int acks, errors, statuses;
  uint8_t code = 0;
  // Grey where the ball was said to be: no ball.
  Teach(protocol::TeachWhere::kOmniPixel, 40, 40);
  camera_.AddRegular(1, 33333);
  loop_->RunUntilFinished();
  Replies(acks, errors, statuses, code);
  EXPECT_EQ(errors, 1);
  EXPECT_EQ(code, static_cast<uint8_t>(protocol::CommandError::kNoBall));
  // A floor point without a calibration.
  Teach(protocol::TeachWhere::kFloorPoint, 1.0f, 2.0f);
  camera_.Add({33333, 0, 0});
  loop_->RunUntilFinished();
  Replies(acks, errors, statuses, code);
  EXPECT_EQ(errors, 2);
  EXPECT_EQ(code, static_cast<uint8_t>(protocol::CommandError::kUnsupported));
  // Out of range, NaN: refused at once.
  Teach(protocol::TeachWhere::kPerspPixel, -1.0f, 3.0f);
  Teach(protocol::TeachWhere::kFloorPoint, std::nanf(""), 3.0f);
  Drain();
  Replies(acks, errors, statuses, code);
  EXPECT_EQ(errors, 4);
  EXPECT_EQ(code, static_cast<uint8_t>(protocol::CommandError::kBadValue));
  const auto upload_begin = [&] {
    uint8_t b[9];
    ByteWriter begin(b);
    begin.U8(static_cast<uint8_t>(protocol::UploadTarget::kLut));
    begin.U32(1000);
    begin.U32(0);
    Command(protocol::MsgType::kUploadBegin, begin.written());
  };
  // An upload begin while a teach waits for its pair: busy (the teach works in the buffer).
  Teach(protocol::TeachWhere::kPerspPixel, 320, 240);
  upload_begin();
  Drain();
  Replies(acks, errors, statuses, code);
  EXPECT_EQ(errors, 5);
  EXPECT_EQ(code, static_cast<uint8_t>(protocol::CommandError::kBusy));
  camera_.Add({66666, 0, 0});
  loop_->RunUntilFinished();  // the teach answers (ack: the disc is there)
  Replies(acks, errors, statuses, code);
  EXPECT_EQ(acks, 1);
  const uint32_t taught = loop_->status().lut_id;
  EXPECT_NE(taught, before);
  // During an upload: busy; the upload goes on.
  upload_begin();
  Teach(protocol::TeachWhere::kPerspPixel, 320, 240);
  Drain();
  Replies(acks, errors, statuses, code);
  EXPECT_EQ(errors, 6);
  EXPECT_EQ(code, static_cast<uint8_t>(protocol::CommandError::kBusy));
  EXPECT_EQ(loop_->status().lut_id, taught);
  std::memset(g_frame, 128, sizeof g_frame);
}

TEST_F(MainLoopCommandsTest, AdaptationNeedsAKnownModelAndOnlyASaveMakesItPermanent) {
  const auto param = [&](uint16_t id, float value) { SetParam(id, value); };
  Start();  // no stored table: the built-in model, known
  int acks, errors, statuses;
  uint8_t code = 0;
  param(kParamColorAdaptation, 1.0f);
  param(kParamColorAdaptation, 0.5f);  // neither 0 nor 1
  Drain();
  Replies(acks, errors, statuses, code);
  EXPECT_EQ(acks, 1);
  EXPECT_EQ(errors, 1);
  EXPECT_EQ(loop_->status().lut_state, static_cast<uint8_t>(protocol::BlobState::kBuiltInMissing))
      << "adapting stores nothing";
  param(kParamSaveColorTable, 1.0f);  // the table in use, stored as an upload
  Drain();
  Replies(acks, errors, statuses, code);
  EXPECT_EQ(acks, 2);
  EXPECT_EQ(loop_->status().lut_state, static_cast<uint8_t>(protocol::BlobState::kOk));
  MainLoop reboot(camera_, uart_, clock_, storage_, reboot_tables_, scratch_);
  ASSERT_TRUE(reboot.Init().ok());
  EXPECT_EQ(reboot.status().lut_id, loop_->status().lut_id);
  // After an uploaded table (its model unknown) adaptation cannot start.
  const std::span<uint8_t> b = BuiltInLutBlob();
  Upload(protocol::UploadTarget::kLut, b, Crc32(b));
  param(kParamColorAdaptation, 1.0f);
  Drain();
  Replies(acks, errors, statuses, code);
  EXPECT_EQ(errors, 2);
  EXPECT_EQ(code, static_cast<uint8_t>(protocol::CommandError::kBadValue));
}

// Both saves serialise into the upload buffer: while an upload is open they are refused as
// busy, and the upload's bytes stay as they came.
TEST_F(MainLoopCommandsTest, ASaveWhileAnUploadIsOpenIsBusyAndTheUploadGoesOn) {
  Start();  // the built-in table in use; the upload differs from it (a save would show)
  cli::FillBuiltInLut(lut_);
  lut_.Set(0, ColorClass::kField);
  const Result<size_t> n = SerializeLut(lut_, lut_blob_);
  ASSERT_TRUE(n.ok());
  const std::span<const uint8_t> b(lut_blob_, *n);
  for (const uint16_t id : {kParamSaveColorTable, kParamSaveCorrection}) {
    UploadBegin(protocol::UploadTarget::kLut, b.size(), Crc32(b));
    UploadChunks(protocol::UploadTarget::kLut, b);
    SetParam(id, 1.0f);
    UploadCommit(protocol::UploadTarget::kLut);
  }
  Drain();
  int acks, errors, statuses;
  uint8_t code = 0;
  Replies(acks, errors, statuses, code);
  EXPECT_EQ(errors, 2);
  EXPECT_EQ(code, static_cast<uint8_t>(protocol::CommandError::kBusy));
  EXPECT_EQ(loop_->status().lut_state, static_cast<uint8_t>(protocol::BlobState::kOk));
  EXPECT_EQ(loop_->status().lut_id, lut_.Id());
}

TEST_F(MainLoopCommandsTest, TeachingAColourTheFieldHasIsRefused) {
  // Grey, with a yellow-green "ball" said to be at the point whose colour also covers a big
  // patch of the image that the field rule calls carpet (U and V below grey): the learnt
  // colour would take the field.
  std::memset(g_frame, 128, sizeof g_frame);
  PaintDisc(160, 240, 20, 120, 118, 90);
  PaintDisc(480, 240, 140, 120, 118, 90);
  Start();
  const uint32_t before = loop_->status().lut_id;
  Teach(protocol::TeachWhere::kPerspPixel, 160.0f, 240.0f);
  camera_.AddRegular(1, 33333);
  loop_->RunUntilFinished();
  int acks, errors, statuses;
  uint8_t code = 0;
  Replies(acks, errors, statuses, code);
  EXPECT_EQ(errors, 1);
  EXPECT_EQ(code, static_cast<uint8_t>(protocol::CommandError::kTeachRefused));
  EXPECT_EQ(loop_->status().lut_id, before);
  std::memset(g_frame, 128, sizeof g_frame);
}

TEST_F(MainLoopCommandsTest, CorruptUploadIsRefusedAndNothingChanges) {
  Start();
  const std::span<uint8_t> b = BuiltInLutBlob();
  ASSERT_FALSE(b.empty());
  Upload(protocol::UploadTarget::kLut, b, Crc32(b) ^ 1u);  // transfer CRC wrong
  b[100] = 200;  // a class value that does not exist, with a matching transfer CRC
  Upload(protocol::UploadTarget::kLut, b, Crc32(b));
  Drain();
  int acks, errors, statuses;
  uint8_t code = 0;
  Replies(acks, errors, statuses, code);
  EXPECT_EQ(errors, 2);
  EXPECT_EQ(code, static_cast<uint8_t>(protocol::CommandError::kVerifyFailed));
  EXPECT_EQ(loop_->status().lut_state, static_cast<uint8_t>(protocol::BlobState::kBuiltInMissing));
  loop_->SendStatus();  // the counters are refreshed with every status packet
  EXPECT_EQ(loop_->status().command_errors, 2u);
  MainLoop reboot(camera_, uart_, clock_, storage_, reboot_tables_, scratch_);
  ASSERT_TRUE(reboot.Init().ok());
  EXPECT_EQ(reboot.status().lut_state, static_cast<uint8_t>(protocol::BlobState::kBuiltInMissing));
}

TEST_F(MainLoopCommandsTest, ParametersAndStatusRequests) {
  Start();
  uint8_t p[6];
  ByteWriter w(p);
  w.U16(kParamFramePeriodUs);
  w.F32(1000.0f);
  Command(protocol::MsgType::kSetParam, w.written());
  ByteWriter bad(p);
  bad.U16(77);
  bad.F32(1.0f);
  Command(protocol::MsgType::kSetParam, bad.written());
  Command(protocol::MsgType::kRequestStatus, {});
  const uint8_t garbage[] = {0x11, 0x22, 0x33, 0x00};  // not a valid frame: counted, ignored
  uart_.Feed(garbage);
  Drain();
  int acks, errors, statuses;
  uint8_t code = 0;
  Replies(acks, errors, statuses, code);
  EXPECT_EQ(acks, 1);
  EXPECT_EQ(errors, 1);
  EXPECT_EQ(code, static_cast<uint8_t>(protocol::CommandError::kUnknownParam));
  EXPECT_EQ(statuses, 2) << "boot + requested";
  // The new period applies: 2 us of processing now overruns a 1 ms frame only if > 1000 us.
  clock_.step_us = 600;
  camera_.AddRegular(3, 33333);
  loop_->RunUntilFinished();
  EXPECT_EQ(loop_->status().deadline_overruns, 3u);
  EXPECT_EQ(loop_->status().rx_errors, 1u);
}

// Issue 17: the board driver's receive losses reach the status packet, and one iteration drains
// everything the receive ring holds (a whole 1 KB upload), not one 64-byte read.
TEST_F(MainLoopCommandsTest, ReceiveLossesAreReportedAndOnePollDrainsAnUpload) {
  Start();
  uart_.rx_stats = hal::UartRxStats{3, 5, 7};
  std::vector<uint8_t> blob(1024);
  for (size_t i = 0; i < blob.size(); ++i) blob[i] = static_cast<uint8_t>(i * 7);
  uint8_t p[5 + protocol::kMaxChunkBytes];
  ByteWriter begin(p);
  begin.U8(static_cast<uint8_t>(protocol::UploadTarget::kLut));
  begin.U32(static_cast<uint32_t>(blob.size()));
  begin.U32(Crc32(blob));
  Command(protocol::MsgType::kUploadBegin, begin.written());
  for (size_t off = 0; off < blob.size(); off += protocol::kMaxChunkBytes) {
    ByteWriter chunk(p);
    chunk.U8(static_cast<uint8_t>(protocol::UploadTarget::kLut));
    chunk.U32(static_cast<uint32_t>(off));
    chunk.Bytes(std::span<const uint8_t>(blob).subspan(off, protocol::kMaxChunkBytes));
    Command(protocol::MsgType::kUploadChunk, chunk.written());
  }
  Command(protocol::MsgType::kRequestStatus, {});
  loop_->Poll();
  EXPECT_TRUE(uart_.rx_empty());
  int acks, errors, statuses;
  uint8_t code = 0;
  Replies(acks, errors, statuses, code);
  EXPECT_EQ(acks, 3);  // begin + two chunks
  EXPECT_EQ(errors, 0);
  ASSERT_EQ(statuses, 2);
  protocol::Decoder dec;
  protocol::FrameView f;
  protocol::StatusReport last;
  for (uint8_t b : uart_.bytes()) {
    if (dec.Push(b, f) && f.type == protocol::MsgType::kStatus) {
      ASSERT_TRUE(protocol::ParseStatus(f.payload, last).ok());
    }
  }
  EXPECT_EQ(last.rx_overruns, 3u);
  EXPECT_EQ(last.rx_ring_full, 5u);
  EXPECT_EQ(last.rx_line_errors, 7u);
}

TEST_F(MainLoopCommandsTest, FieldHalfOdometryAndPoseCommands) {
  Start();
  const int8_t half = -1;
  Command(protocol::MsgType::kSetFieldHalf,
          std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(&half), 1));
  uint8_t odo[12];
  ByteWriter w(odo);
  w.F32(0.05f), w.F32(0.1f), w.F32(-0.01f);
  Command(protocol::MsgType::kOdometry, odo);
  uint8_t pose[13];
  ByteWriter pw(pose);
  pw.U8(1), pw.F32(-3.0f), pw.F32(2.0f), pw.F32(0.25f);
  Command(protocol::MsgType::kSetPose, pose);
  Drain();
  EXPECT_TRUE(loop_->pipeline().robot_pose().known);
  EXPECT_EQ(loop_->pipeline().robot_pose().x_m, -3.0f);
  EXPECT_EQ(loop_->pipeline().robot_pose().y_m, 2.0f);
  EXPECT_EQ(loop_->pipeline().robot_pose().heading_rad, 0.25f);
  // Refused: a half of 2, NaN odometry, a pose 30 m away. The pose stays as it was.
  const int8_t bad_half = 2;
  Command(protocol::MsgType::kSetFieldHalf,
          std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(&bad_half), 1));
  ByteWriter w2(odo);
  w2.F32(NAN), w2.F32(0), w2.F32(0);
  Command(protocol::MsgType::kOdometry, odo);
  ByteWriter pw2(pose);
  pw2.U8(1), pw2.F32(30.0f), pw2.F32(0), pw2.F32(0);
  Command(protocol::MsgType::kSetPose, pose);
  Drain();
  EXPECT_EQ(loop_->pipeline().robot_pose().x_m, -3.0f);
  int acks, errors, statuses;
  uint8_t code = 0;
  Replies(acks, errors, statuses, code);
  EXPECT_EQ(acks, 3);
  EXPECT_EQ(errors, 3);
  EXPECT_EQ(code, static_cast<uint8_t>(protocol::CommandError::kBadValue));
  loop_->SendStatus();
  EXPECT_EQ(loop_->status().command_errors, 3u);
}

TEST_F(MainLoopCommandsTest, RobotPoseParametersReachThePipeline) {
  Start();
  auto set = [&](uint16_t id, float v) {
    SetParam(id, v);
    Drain();
  };
  EXPECT_FALSE(loop_->pipeline().robot_pose().known);
  set(kParamRobotFieldX, 8.2f);
  set(kParamRobotFieldY, -1.5f);
  set(kParamRobotHeadingRad, 0.5f);
  set(kParamRobotFieldX, 1e6f);  // out of range: refused, pose unchanged
  const RobotPose& pose = loop_->pipeline().robot_pose();
  EXPECT_TRUE(pose.known);
  EXPECT_EQ(pose.x_m, 8.2f);
  EXPECT_EQ(pose.y_m, -1.5f);
  EXPECT_EQ(pose.heading_rad, 0.5f);
  int acks, errors, statuses;
  uint8_t code = 0;
  Replies(acks, errors, statuses, code);
  EXPECT_EQ(acks, 3);
  EXPECT_EQ(errors, 1);
  EXPECT_EQ(code, static_cast<uint8_t>(protocol::CommandError::kBadValue));
  set(kParamRobotPoseKnown, 0.f);
  EXPECT_FALSE(loop_->pipeline().robot_pose().known);
}

// Read-back (0x2C): the blob in use comes back in chunks of one snapshot, checked by its CRC.
class MainLoopReadbackTest : public MainLoopCommandsTest {
 protected:
  void Read(protocol::UploadTarget target, uint32_t offset, uint16_t length = 512) {
    uint8_t p[protocol::kReadBlobBytes];
    ByteWriter w(p);
    w.U8(static_cast<uint8_t>(target));
    w.U32(offset);
    w.U16(length);
    Command(protocol::MsgType::kReadBlob, w.written());
  }
  struct Answers {
    std::vector<protocol::BlobData> data;
    std::vector<std::vector<uint8_t>> bytes;           // each data packet's bytes (the spans die)
    std::vector<std::pair<uint8_t, uint32_t>> errors;  // code, detail
  };
  Answers Collect() {
    Drain();
    Answers a;
    const std::vector<uint8_t> sent = uart_.TakeBytes();
    protocol::Decoder dec;
    protocol::FrameView f;
    for (uint8_t b : sent) {
      if (!dec.Push(b, f)) continue;
      if (f.type == protocol::MsgType::kBlobData) {
        protocol::BlobData d;
        EXPECT_TRUE(protocol::ParseBlobData(f.payload, d).ok());
        a.bytes.emplace_back(d.data.begin(), d.data.end());
        a.data.push_back(d);
      } else if (f.type == protocol::MsgType::kError) {
        ByteReader r(f.payload);
        r.U8(), r.U32();
        const uint8_t code = r.U8();
        a.errors.push_back({code, r.U32()});
      }
    }
    return a;
  }
  // The whole blob of `target` in rounds of 32 reads; false if any answer was not data.
  bool ReadAll(protocol::UploadTarget target, std::vector<uint8_t>& blob, uint32_t& crc) {
    blob.clear();
    uint32_t total = 1;
    for (uint32_t off = 0; off < total;) {
      for (int k = 0; k < 32 && off + k * 512u < total; ++k) Read(target, off + k * 512u);
      const Answers a = Collect();
      if (!a.errors.empty() || a.data.empty()) return false;
      for (size_t i = 0; i < a.data.size(); ++i) {
        EXPECT_EQ(a.data[i].offset, off) << "answers in order, contiguous";
        if (off == 0) crc = a.data[i].blob_crc32;
        EXPECT_EQ(a.data[i].blob_crc32, crc) << "one snapshot";
        total = a.data[i].total_len;
        blob.insert(blob.end(), a.bytes[i].begin(), a.bytes[i].end());
        off += static_cast<uint32_t>(a.bytes[i].size());
      }
    }
    return true;
  }
};

TEST_F(MainLoopReadbackTest, TheTableAndTheCalibrationInUseComeBackByteForByte) {
  InstallDemoBlobs();
  Start();
  std::vector<uint8_t> blob;
  uint32_t crc = 0;
  ASSERT_TRUE(ReadAll(protocol::UploadTarget::kLut, blob, crc));
  std::vector<uint8_t> want(kColorLutBlobBytes);
  const Result<size_t> n = SerializeLut(loop_->lut(), want);
  ASSERT_TRUE(n.ok());
  want.resize(*n);
  EXPECT_EQ(blob, want);
  EXPECT_EQ(crc, Crc32(want));
  ColorLut back;
  EXPECT_TRUE(ParseLut(blob, back).ok());
  EXPECT_EQ(back.Id(), loop_->status().lut_id);

  ASSERT_TRUE(ReadAll(protocol::UploadTarget::kCalibration, blob, crc));
  RigCalibration cal;
  ASSERT_TRUE(ParseCalibration(blob, cal).ok());
  EXPECT_EQ(cal.calibration_id, loop_->status().calibration_id);
  EXPECT_EQ(crc, Crc32(blob));
}

// A persp camera turned by 1 deg after calibration: the pipeline corrects it in RAM, and only
// kParamSaveCorrection stores the corrected calibration. It comes back over the link, survives
// a reboot, and the watch, restarted from it, then sees no turn.
TEST_F(MainLoopReadbackTest, ACorrectedTurnIsStoredOnlyOnCommandAndComesBack) {
  uint32_t measured_id = 0;
  InstallDemoBlobs(&measured_id);
  const RigCalibration cal = cli::MakeDemoCalibration();
  RigCalibration turned = cal;
  constexpr float kRad = 3.14159265f / 180.0f;
  turned.persp.R_robot_cam =
      Eigen::AngleAxisf(1.0f * kRad, cal.persp.R_robot_cam.col(0)).toRotationMatrix() *
      cal.persp.R_robot_cam;
  const cli::DemoRenderer renderer(turned);
  std::vector<uint8_t> omni, persp;
  // A ball rolling in a zig-zag 1.5-4.5 m ahead (the samples must spread to fit pitch and yaw).
  camera_.render = [&](size_t k, uint8_t* o, uint8_t* p) {
    const float t = static_cast<float>(k) / 30.f;
    const Eigen::Vector3f ball(-1.2f + 2.4f * std::fabs(std::fmod(t * 0.6f, 2.f) - 1.f),
                               1.5f + 0.6f * t, 0.11f);
    renderer.Render(ball, static_cast<uint32_t>(k + 1), omni, persp);
    std::memcpy(o, omni.data(), kFrameBytes);
    std::memcpy(p, persp.data(), kFrameBytes);
  };
  const auto save = [&] { SetParam(kParamSaveCorrection, 1.0f); };
  const auto pairs = [&](int from, int n) {
    for (int k = from; k < from + n; ++k) camera_.Add({33333u * static_cast<uint64_t>(k), 0, 0});
  };
  Start();
  save();  // nothing corrected yet
  Answers a = Collect();
  ASSERT_EQ(a.errors.size(), 1u);
  EXPECT_EQ(a.errors[0].first, static_cast<uint8_t>(protocol::CommandError::kBadValue));
  pairs(0, 60);
  loop_->RunUntilFinished();
  const PerspTurnWatch& watch = loop_->pipeline().persp_turn();
  ASSERT_EQ(watch.state(), CameraState::kCorrected);
  EXPECT_NEAR(watch.change_deg(), 1.0f, 0.2f);
  EXPECT_EQ(loop_->status().calibration_id, measured_id) << "correcting stores nothing";
  {
    MainLoop reboot(camera_, uart_, clock_, storage_, reboot_tables_, scratch_);
    ASSERT_TRUE(reboot.Init().ok());
    EXPECT_EQ(reboot.status().calibration_id, measured_id);
  }
  uart_.TakeBytes();
  save();
  a = Collect();
  EXPECT_TRUE(a.errors.empty());
  const uint32_t stored_id = loop_->status().calibration_id;
  EXPECT_NE(stored_id, measured_id);
  EXPECT_EQ(watch.state(), CameraState::kAsCalibrated) << "the stored model is the new baseline";
  std::vector<uint8_t> blob;
  uint32_t crc = 0;
  ASSERT_TRUE(ReadAll(protocol::UploadTarget::kCalibration, blob, crc));
  RigCalibration back;
  ASSERT_TRUE(ParseCalibration(blob, back).ok());
  EXPECT_EQ(back.calibration_id, stored_id);
  const auto angle_deg = [&](const Eigen::Matrix3f& r1, const Eigen::Matrix3f& r2) {
    return Eigen::AngleAxisf(r1.transpose() * r2).angle() / kRad;
  };
  EXPECT_LT(angle_deg(back.persp.R_robot_cam, turned.persp.R_robot_cam), 0.2f);
  EXPECT_NEAR(angle_deg(back.persp.R_robot_cam, cal.persp.R_robot_cam), 1.0f, 0.2f);
  EXPECT_EQ(back.omni.center_u, cal.omni.center_u) << "the rest as calibrated";
  {
    MainLoop reboot(camera_, uart_, clock_, storage_, reboot_tables_, scratch_);
    ASSERT_TRUE(reboot.Init().ok());
    EXPECT_EQ(reboot.status().calibration_id, stored_id);
  }
  // Frames of the same turned camera: as calibrated now.
  pairs(60, 60);
  bool flagged = false;
  while (!camera_.Finished()) {
    loop_->Poll();
    flagged |= watch.state() != CameraState::kAsCalibrated;
  }
  EXPECT_FALSE(flagged);
  EXPECT_GT(watch.samples(), 12);
  EXPECT_LT(watch.change_deg(), 0.25f);
}

TEST_F(MainLoopReadbackTest, RefusalsNameTheProblemAndALaterReadFromZeroWorks) {
  Start();  // no calibration stored: the built-in table is in use
  using protocol::CommandError;
  using protocol::UploadTarget;
  auto code = [](CommandError e) { return static_cast<uint8_t>(e); };
  Read(UploadTarget::kLut, 512);          // no snapshot yet
  Read(UploadTarget::kLut, 0, 0);         // length 0
  Read(UploadTarget::kLut, 0, 513);       // beyond a chunk
  Read(static_cast<UploadTarget>(4), 0);  // unknown target
  Read(UploadTarget::kCalibration, 0);    // nothing in use
  Answers a = Collect();
  EXPECT_TRUE(a.data.empty());
  const std::vector<std::pair<uint8_t, uint32_t>> want = {{code(CommandError::kNoSnapshot), 0},
                                                          {code(CommandError::kBadValue), 512},
                                                          {code(CommandError::kBadValue), 512},
                                                          {code(CommandError::kBadTarget), 0},
                                                          {code(CommandError::kBadTarget), 0}};
  EXPECT_EQ(a.errors, want);

  // Interrupted half way: the reader stops, the device holds nothing for it.
  Read(UploadTarget::kLut, 0);
  Read(UploadTarget::kLut, 512);
  a = Collect();
  ASSERT_EQ(a.data.size(), 2u);
  const uint32_t total = a.data[0].total_len;
  Read(UploadTarget::kLut, total);  // at the end
  a = Collect();
  ASSERT_EQ(a.errors.size(), 1u);
  EXPECT_EQ(a.errors[0], std::make_pair(code(CommandError::kBadOffset), total));
  // An upload begin reuses the buffer: the snapshot is gone, and no read while it is open.
  const std::span<const uint8_t> b = BuiltInLutBlob();
  UploadBegin(UploadTarget::kLut, b.size(), Crc32(b));
  Read(UploadTarget::kLut, 1024);
  a = Collect();
  ASSERT_EQ(a.errors.size(), 1u);
  EXPECT_EQ(a.errors[0].first, code(CommandError::kBusy));
  Upload(UploadTarget::kLut, b, Crc32(b));  // begins again and completes
  Read(UploadTarget::kLut, 1024);
  a = Collect();
  ASSERT_EQ(a.errors.size(), 1u);
  EXPECT_EQ(a.errors[0].first, code(CommandError::kNoSnapshot));
  // From 0 again: the whole table, the uploaded one.
  std::vector<uint8_t> blob;
  uint32_t crc = 0;
  ASSERT_TRUE(ReadAll(UploadTarget::kLut, blob, crc));
  EXPECT_TRUE(std::equal(blob.begin(), blob.end(), b.begin(), b.end()));
}

TEST_F(MainLoopReadbackTest, WithNoRoomOnTheLinkAReadIsBusyAndBallStatesKeepTheirRoom) {
  InstallDemoBlobs();
  Start();
  uart_.TakeBytes();
  uart_.ring = 2 * kTxReserveBytes;  // a line that does not drain
  uart_.queued = kTxReserveBytes;
  Read(protocol::UploadTarget::kLut, 0);
  const Answers a = Collect();
  EXPECT_TRUE(a.data.empty());
  ASSERT_EQ(a.errors.size(), 1u);
  EXPECT_EQ(a.errors[0].first, static_cast<uint8_t>(protocol::CommandError::kBusy));
  camera_.AddRegular(1, 33333);
  loop_->RunUntilFinished();
  int balls = 0;
  protocol::Decoder dec;
  protocol::FrameView f;
  for (uint8_t b : uart_.bytes())
    balls += dec.Push(b, f) && f.type == protocol::MsgType::kBallState;
  EXPECT_EQ(balls, 1) << "the pair's ball state still went out";
}

}  // namespace
}  // namespace bv::fw
