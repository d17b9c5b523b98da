// Online colour adaptation: the table follows the ball's colour as the light changes, only from
// detections both cameras confirm, a refit that would take the guard samples is refused.
#include "core/color_lut/color_adapt.h"

#include <gtest/gtest.h>

#include <sys/stat.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "core/pipeline.h"
#include "hal/host/sequence.h"
#include "tools/ballvision/calib_io.h"
#include "tools/ballvision/lut_train.h"

namespace bv {
namespace {

// One 640x480 YUYV frame: grey-green carpet and a disc of one colour.
struct Frame {
  std::vector<uint8_t> px = std::vector<uint8_t>(kFrameWidth * kFrameHeight * 2);
  Frame(int cu, int cv, int r, Yuv ball, Yuv around) {
    for (int v = 0; v < kFrameHeight; ++v) {
      for (int u = 0; u < kFrameWidth; ++u) {
        const bool in = (u - cu) * (u - cu) + (v - cv) * (v - cv) <= r * r;
        const Yuv p = in ? ball : around;
        uint8_t* q = px.data() + (static_cast<size_t>(v) * kFrameWidth + u) * 2;
        q[0] = p.y;
        q[1] = (u & 1) ? p.v : p.u;
      }
    }
  }
  YuyvImage view() const { return MakeYuyvImage(px.data(), kFrameWidth, kFrameHeight); }
};

BallDetection At(float u, float v, float r) {
  BallDetection d;
  d.found = true;
  d.u_px = u;
  d.v_px = v;
  d.radius_px = r;
  return d;
}

TEST(ColorAdaptTest, TheTableFollowsTheBallsColourAsTheLightChanges) {
  // The light turns the ball's hue from 145 deg towards 158 deg, past the built-in window's end
  // (152 deg): Y 120, chroma 60, hue h -> U = 128 + 60 cos h, V = 128 + 60 sin h.
  const auto ball_at = [](float hue_deg) {
    const float h = hue_deg * 3.14159265f / 180.0f;
    return Yuv{120, static_cast<uint8_t>(128 + 60 * std::cos(h)),
               static_cast<uint8_t>(128 + 60 * std::sin(h))};
  };
  const Yuv green{90, 100, 100};
  auto table = std::make_unique<ColorLut>();
  ASSERT_TRUE(BuildLut(BallColorModel{}, *table).ok());
  const Yuv late = ball_at(158.0f);
  ASSERT_NE(table->Classify(late.y, late.u, late.v), ColorClass::kBall);
  auto adapter = std::make_unique<ColorAdapter>();
  adapter->Start(BallColorModel{}, table.get());
  for (int i = 0; i < 400; ++i) {
    const float hue = 145.0f + 13.0f * std::min(1.0f, static_cast<float>(i) / 250.0f);
    const Frame f(320, 240, 20, ball_at(hue), green);
    adapter->Observe(f.view(), At(320, 240, 20));
    adapter->Step();
  }
  EXPECT_GT(adapter->stats().refits, 5u);
  EXPECT_EQ(adapter->stats().refits_refused, 0u);
  EXPECT_EQ(table->Classify(late.y, late.u, late.v), ColorClass::kBall) << "followed the light";
  EXPECT_EQ(table->Classify(green.y, green.u, green.v), ColorClass::kField);
}

TEST(ColorAdaptTest, WithoutObservationsNothingChanges) {
  auto table = std::make_unique<ColorLut>();
  ASSERT_TRUE(BuildLut(BallColorModel{}, *table).ok());
  const uint32_t id = table->Id();
  auto adapter = std::make_unique<ColorAdapter>();
  adapter->Start(BallColorModel{}, table.get());
  for (int i = 0; i < 200; ++i) adapter->Step();
  EXPECT_EQ(table->Id(), id);
  EXPECT_EQ(adapter->stats().frames_observed, 0u);
}

TEST(ColorAdaptTest, RefitsNeverLoseTheStartModelsColours) {
  // Many frames of a ball in one light (hue 128 deg, relative chroma 0.5) refit the model to that
  // light; a colour the start model holds but that light never shows (the shaded side, hue 108
  // deg, chroma 0.32 — a ball resting half hidden behind a robot) stays ball. Clutter seed 113
  // lost its ball for that: three refits narrowed the model to 117..135 deg, chroma >= 0.45.
  const auto at = [](float hue_deg, float rel_chroma, uint8_t y) {
    const float h = hue_deg * 3.14159265f / 180.0f, c = rel_chroma * y;
    return Yuv{y, static_cast<uint8_t>(128 + c * std::cos(h)),
               static_cast<uint8_t>(128 + c * std::sin(h))};
  };
  const Yuv lit = at(128.0f, 0.5f, 120), shaded = at(108.0f, 0.32f, 70), green{90, 100, 100};
  auto table = std::make_unique<ColorLut>();
  ASSERT_TRUE(BuildLut(BallColorModel{}, *table).ok());
  ASSERT_EQ(table->Classify(shaded.y, shaded.u, shaded.v), ColorClass::kBall);
  auto adapter = std::make_unique<ColorAdapter>();
  adapter->Start(BallColorModel{}, table.get());
  for (int i = 0; i < 200; ++i) {
    const Frame f(320, 240, 20, lit, green);
    adapter->Observe(f.view(), At(320, 240, 20));
    adapter->Step();
  }
  EXPECT_GT(adapter->stats().refits + adapter->stats().refits_unchanged, 2u);
  EXPECT_LE(adapter->model().hue_min_deg, 104.0f);
  EXPECT_GE(adapter->model().hue_max_deg, 152.0f);
  EXPECT_LE(adapter->model().chroma_min, 0.28f);
  EXPECT_EQ(table->Classify(shaded.y, shaded.u, shaded.v), ColorClass::kBall);
  EXPECT_EQ(table->Classify(lit.y, lit.u, lit.v), ColorClass::kBall);
  EXPECT_EQ(table->Classify(green.y, green.u, green.v), ColorClass::kField);
}

TEST(ColorAdaptTest, ARefitTakingTheGuardSamplesIsRefused) {
  // An orange the table (by hand here) calls line: pixels of it around the ball are guard
  // samples, so a refit that keeps the ball's colour (which is the same) must be refused. The
  // control, green around the ball, is accepted.
  const Yuv orange{150, 90, 170}, green{90, 100, 100};
  for (const bool guarded : {true, false}) {
    auto table = std::make_unique<ColorLut>();
    ASSERT_TRUE(BuildLut(BallColorModel{}, *table).ok());
    table->Set(ColorLut::Index(orange.y, orange.u, orange.v), ColorClass::kLine);
    auto adapter = std::make_unique<ColorAdapter>();
    adapter->Start(BallColorModel{}, table.get());
    for (int i = 0; i < 48; ++i) {
      const Frame f(320, 240, 20, orange, guarded ? orange : green);
      adapter->Observe(f.view(), At(320, 240, 20));
      adapter->Step();
    }
    if (guarded) {
      EXPECT_GT(adapter->stats().refits_refused, 0u);
      EXPECT_EQ(adapter->stats().refits, 0u);
      EXPECT_EQ(table->Classify(orange.y, orange.u, orange.v), ColorClass::kLine);
    } else {  // the orange lies inside the start model: accepted, nothing to rebuild
      EXPECT_EQ(adapter->stats().refits_refused, 0u);
      EXPECT_GT(adapter->stats().refits + adapter->stats().refits_unchanged, 0u);
    }
  }
}

TEST(ColorAdaptTest, OnlyDetectionsBothCamerasConfirmTeach) {
  const std::string seq_dir = std::string(BV_SHARED_DATA_DIR) + "/sim/bounce";
  struct stat st;
  if (stat((seq_dir + "/frames.csv").c_str(), &st) != 0) GTEST_SKIP() << "no " << seq_dir;
  host::Sequence seq;
  std::string err;
  ASSERT_TRUE(host::LoadSequence(seq_dir, seq, err)) << err;
  RigCalibration cal;
  ASSERT_TRUE(cli::LoadCalibrationFile(std::string(BV_TEST_DATA_DIR) + "/reference_rig_calib.json",
                                       cal, err))
      << err;
  for (const bool both : {false, true}) {
    auto table = std::make_unique<ColorLut>();
    ASSERT_TRUE(BuildLut(BallColorModel{}, *table).ok());
    auto adapter = std::make_unique<ColorAdapter>();
    adapter->Start(BallColorModel{}, table.get());
    auto pipeline = std::make_unique<OwnedPipeline>();
    ASSERT_TRUE(pipeline->Init(cal, *table, PipelineConfig{}).ok());
    pipeline->SetColorAdapter(adapter.get());
    int n = 0;
    for (const auto& e : seq.entries) {
      if (++n > 30) break;
      lut::Image omni, persp;
      ASSERT_TRUE(lut::LoadImage(e.omni_path, omni, err)) << err;
      ASSERT_TRUE(lut::LoadImage(e.persp_path, persp, err)) << err;
      FrameInput in;
      in.omni = omni.view();
      if (both) in.persp = persp.view();
      in.t_us = e.t_us;
      BallState s;
      ASSERT_TRUE(pipeline->Process(in, s).ok());
    }
    if (both) {
      EXPECT_GT(adapter->stats().frames_observed, 10u);
    } else {
      EXPECT_EQ(adapter->stats().frames_observed, 0u) << "one camera alone never teaches";
    }
  }
}

}  // namespace
}  // namespace bv
