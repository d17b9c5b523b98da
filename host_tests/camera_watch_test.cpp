// Frozen, blind and missing cameras (core/health, issue 40 B6): the watch on its own with drawn
// frames, then the whole pipeline on the rendered sequences with one camera frozen or blacked
// out: flagged within a second, the ball kept by the other camera, and no flag on unchanged ones.
#include "core/health/camera_watch.h"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/pipeline.h"
#include "core/scanline/scanline.h"
#include "hal/host/sequence.h"
#include "host_tests/test_util.h"
#include "tools/ballvision/calib_io.h"
#include "tools/ballvision/run_common.h"
#include "tools/ballvision/run_pipeline.h"

namespace bv {
namespace {

constexpr int kW = 640, kH = 480;

class CameraWatchTest : public ::testing::Test {
 protected:
  void SetUp() override {
    table_ = std::make_unique<ScanlineTable<kPerspScanPixels>>();
    ASSERT_TRUE(table_->BuildPersp(ReferencePerspScanConfig(), kW, kH).ok());
    ASSERT_TRUE(watch_.Build(*table_, CameraWatchConfig{}).ok());
    frame_.resize(static_cast<size_t>(kW) * kH * 2);
  }
  // A scene-like frame: a brightness ramp plus sensor noise, new noise every call.
  const YuyvImage& Live() {
    std::normal_distribution<float> noise(0.f, 2.f);
    for (int v = 0; v < kH; ++v) {
      for (int u = 0; u < kW; ++u) {
        const size_t o = (static_cast<size_t>(v) * kW + u) * 2;
        const float y = 40.f + 160.f * static_cast<float>(u + v) / (kW + kH) + noise(rng_);
        frame_[o] = static_cast<uint8_t>(std::clamp(y, 0.f, 255.f));
        frame_[o + 1] = static_cast<uint8_t>(std::clamp(128.f + noise(rng_), 0.f, 255.f));
      }
    }
    img_ = MakeYuyvImage(frame_.data(), kW, kH);
    return img_;
  }
  const YuyvImage& Uniform(uint8_t y, float sigma) {
    std::normal_distribution<float> noise(0.f, sigma);
    for (size_t o = 0; o < frame_.size(); o += 2) {
      frame_[o] = static_cast<uint8_t>(std::clamp(y + noise(rng_), 0.f, 255.f));
      frame_[o + 1] = 128;
    }
    img_ = MakeYuyvImage(frame_.data(), kW, kH);
    return img_;
  }
  std::unique_ptr<ScanlineTable<kPerspScanPixels>> table_;
  CameraWatch watch_;
  std::vector<uint8_t> frame_;
  YuyvImage img_;
  std::mt19937 rng_{7};
};

TEST_F(CameraWatchTest, LiveFramesAreNeverRefused) {
  for (int i = 0; i < 60; ++i) {
    ASSERT_TRUE(watch_.Observe(Live(), 1000 + 33333u * i)) << i;
    ASSERT_EQ(watch_.check().faults, 0) << i;
    ASSERT_EQ(watch_.check().state, CameraState::kAsCalibrated);
  }
}

TEST_F(CameraWatchTest, TheSameFrameAgainIsRefusedAndThreeRepeatsFlagTheCamera) {
  const YuyvImage& img = Live();
  EXPECT_TRUE(watch_.Observe(img, 0));
  for (int repeat = 1; repeat <= 3; ++repeat) {
    EXPECT_FALSE(watch_.Observe(img, 0)) << repeat;
    EXPECT_EQ(watch_.check().faults, kCameraRepeated);
    EXPECT_EQ(watch_.check().state,
              repeat < 3 ? CameraState::kAsCalibrated : CameraState::kUnusable);
  }
  // Live again: refused until three good frames in a row.
  for (int i = 1; i <= 3; ++i) {
    EXPECT_EQ(watch_.Observe(Live(), 0), i == 3) << i;
    EXPECT_EQ(watch_.check().faults, 0);
  }
  EXPECT_EQ(watch_.check().state, CameraState::kAsCalibrated);
}

TEST_F(CameraWatchTest, AnExposureTimeThatStandsStillIsAStall) {
  EXPECT_TRUE(watch_.Observe(Live(), 5000));
  for (int i = 1; i <= 3; ++i) {
    EXPECT_FALSE(watch_.Observe(Live(), 5000)) << i;  // new pixels, the same time
    EXPECT_EQ(watch_.check().faults, kCameraStaleTime);
  }
  EXPECT_EQ(watch_.check().state, CameraState::kUnusable);
}

TEST_F(CameraWatchTest, BlackSaturatedAndFlatFramesFlagAfterFive) {
  struct Case {
    uint8_t y;
    float sigma;
    uint8_t fault;
  };
  for (const Case c : {Case{3, 2.f, kCameraDark}, Case{252, 1.f, kCameraSaturated},
                       Case{128, 1.5f, kCameraFlat}, Case{40, 2.f, kCameraFlat}}) {
    watch_.Reset();
    for (int i = 1; i <= 5; ++i) {
      EXPECT_FALSE(watch_.Observe(Uniform(c.y, c.sigma), 0)) << int{c.y} << " " << i;
      EXPECT_TRUE(watch_.check().faults & c.fault) << int{c.y};
      EXPECT_EQ(watch_.check().state, i < 5 ? CameraState::kAsCalibrated : CameraState::kUnusable)
          << int{c.y};
    }
  }
  // A dim but real scene is not blind.
  watch_.Reset();
  for (int i = 0; i < 10; ++i) {
    const YuyvImage& img = Live();
    for (size_t o = 0; o < frame_.size(); o += 2) frame_[o] = static_cast<uint8_t>(frame_[o] / 4);
    EXPECT_TRUE(watch_.Observe(img, 0));
    EXPECT_EQ(watch_.check().faults, 0);
  }
}

TEST_F(CameraWatchTest, MissingFramesFlagAfterTenAndAnotherSizeIsLeftToTheFrontEnd) {
  for (int i = 1; i <= 10; ++i) {
    EXPECT_FALSE(watch_.Observe(YuyvImage{}, 0));
    EXPECT_EQ(watch_.check().faults, kCameraMissing);
    EXPECT_EQ(watch_.check().state, i < 10 ? CameraState::kAsCalibrated : CameraState::kUnusable);
  }
  watch_.Reset();
  const YuyvImage small = MakeYuyvImage(frame_.data(), 320, 240);
  for (int i = 0; i < 5; ++i) EXPECT_TRUE(watch_.Observe(small, 0));  // same bytes: not compared
  EXPECT_EQ(watch_.check().faults, 0);
}

TEST_F(CameraWatchTest, TurnedOffItPassesEverything) {
  CameraWatchConfig off;
  off.enabled = false;
  ASSERT_TRUE(watch_.Build(*table_, off).ok());
  const YuyvImage& img = Uniform(0, 0.f);
  for (int i = 0; i < 20; ++i) EXPECT_TRUE(watch_.Observe(img, 0));
  EXPECT_FALSE(watch_.Observe(YuyvImage{}, 0));
  EXPECT_EQ(watch_.check().state, CameraState::kAsCalibrated);
}

// ---- The pipeline on the rendered reference rig (skipped without the shared data). ----

std::string SimDir(const char* scene) { return std::string(BV_SHARED_DATA_DIR) + "/sim/" + scene; }
const std::string kRefCalib = std::string(BV_TEST_DATA_DIR) + "/reference_rig_calib.json";

struct SimRun {
  RigCalibration cal;
  std::unique_ptr<ColorLut> lut = std::make_unique<ColorLut>();
  std::unique_ptr<OwnedPipeline> pipeline = std::make_unique<OwnedPipeline>();
  std::vector<cli::FrameRecord> recs;
};

void RunOn(const host::Sequence& seq, bool stills, SimRun& r) {
  std::string err, used;
  ASSERT_TRUE(cli::LoadCalibrationFile(kRefCalib, r.cal, err)) << err;
  ASSERT_TRUE(cli::LoadLutOrDefault("", kRefCalib, *r.lut, used, err)) << err;
  ASSERT_TRUE(r.pipeline->Init(r.cal, *r.lut, PipelineConfig{}).ok());
  cli::RunSettings rs;
  rs.reset_each_frame = stills;
  ASSERT_TRUE(cli::RunSequence(seq, *r.pipeline, rs, r.recs, err)) << err;
}

bool LoadSim(const char* scene, host::Sequence& seq) {
  std::string err;
  return std::filesystem::exists(kRefCalib) && host::LoadSequence(SimDir(scene), seq, err);
}

TEST(CameraWatchSim, NoFrameOfAnUnchangedSceneIsRefused) {
  for (const char* scene : {"bounce", "clutter", "static_grid"}) {
    host::Sequence seq;
    if (!LoadSim(scene, seq)) GTEST_SKIP() << "no sim/" << scene << " or reference calibration";
    SimRun r;
    RunOn(seq, std::string(scene) == "static_grid", r);
    for (const cli::FrameRecord& rec : r.recs) {
      ASSERT_EQ(rec.state.omni_check.Byte(), 0) << scene << " frame " << rec.index;
      ASSERT_EQ(rec.state.persp_check.Byte(), 0) << scene << " frame " << rec.index;
    }
  }
}

// From frame kFrom on, one camera delivers `stuck` (its frame kFrom again, or a black frame).
struct Broken {
  int flagged_at = -1;       // first frame with the camera kUnusable
  int kept = 0, before = 0;  // frames from kFrom + 10 on with the ball found, broken and intact
  int used_broken = 0;       // frames after the flag where the broken camera's ball was used
};
constexpr int kFrom = 30;

Broken Break(const char* scene, bool omni, const std::string& stuck) {
  host::Sequence seq;
  EXPECT_TRUE(LoadSim(scene, seq));
  SimRun intact, broken;
  RunOn(seq, false, intact);
  for (size_t i = kFrom; i < seq.entries.size(); ++i) {
    std::string& path = omni ? seq.entries[i].omni_path : seq.entries[i].persp_path;
    path = stuck.empty() ? (omni ? seq.entries[kFrom].omni_path : seq.entries[kFrom].persp_path)
                         : stuck;
  }
  RunOn(seq, false, broken);
  Broken b;
  for (size_t i = 0; i < broken.recs.size(); ++i) {
    const BallState& s = broken.recs[i].state;
    const CameraCheck& c = omni ? s.omni_check : s.persp_check;
    const CameraCheck& other = omni ? s.persp_check : s.omni_check;
    EXPECT_EQ(other.Byte(), 0) << i;
    if (static_cast<int>(i) < kFrom) {
      EXPECT_EQ(c.Byte(), 0) << i;
    }
    if (c.state == CameraState::kUnusable && b.flagged_at < 0) b.flagged_at = static_cast<int>(i);
    if (b.flagged_at >= 0) b.used_broken += (omni ? s.omni.found : s.persp.found) ? 1 : 0;
    if (static_cast<int>(i) >= kFrom + 10) {
      b.kept += s.found && !(s.flags & kFlagCoasting);
      b.before += intact.recs[i].state.found && !(intact.recs[i].state.flags & kFlagCoasting);
    }
  }
  std::printf(
      "%s, %s %s from frame %d: flagged at frame %d, ball measured in %d of the %d frames "
      "the intact rig measured it\n",
      scene, omni ? "omni" : "persp", stuck.empty() ? "frozen" : "black", kFrom, b.flagged_at,
      b.kept, b.before);
  return b;
}

TEST(CameraWatchSim, AFrozenOmniIsFlaggedWithinASecondAndThePerspKeepsTheBall) {
  host::Sequence probe;
  if (!LoadSim("bounce", probe)) GTEST_SKIP() << "no sim/bounce or reference calibration";
  const Broken b = Break("bounce", true, "");
  EXPECT_GE(b.flagged_at, kFrom);
  EXPECT_LE(b.flagged_at, kFrom + 30);  // 1 s at 30 Hz
  EXPECT_EQ(b.used_broken, 0);
  EXPECT_GE(b.kept, b.before * 8 / 10);
}

TEST(CameraWatchSim, ABlackPerspIsFlaggedWithinASecondAndTheOmniKeepsTheBall) {
  host::Sequence probe;
  if (!LoadSim("bounce", probe)) GTEST_SKIP() << "no sim/bounce or reference calibration";
  const std::string black = test::TempDir("camera_watch") + "/black.yuyv";
  {
    std::vector<uint8_t> yuyv(static_cast<size_t>(kW) * kH * 2);
    for (size_t o = 0; o < yuyv.size(); o += 2) yuyv[o] = 2, yuyv[o + 1] = 128;
    std::ofstream(black, std::ios::binary)
        .write(reinterpret_cast<const char*>(yuyv.data()),
               static_cast<std::streamsize>(yuyv.size()));
  }
  const Broken b = Break("bounce", false, black);
  EXPECT_GE(b.flagged_at, kFrom);
  EXPECT_LE(b.flagged_at, kFrom + 30);
  EXPECT_EQ(b.used_broken, 0);
  EXPECT_GE(b.kept, b.before * 8 / 10);
}

}  // namespace
}  // namespace bv
