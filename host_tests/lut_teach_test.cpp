// One-step venue teaching (tools/ballvision/lut_teach): the fit from ball pixels, the refusals
// (too few pixels, grey, a "ball" that is the field, a click on nothing), and a whole teach over
// a rendered sequence that finds the ball with the taught table.
#include "tools/ballvision/lut_teach.h"
#include "tools/ballvision/box_teach.h"

#include "core/color_lut/color_teach.h"

#include <gtest/gtest.h>

#include <sys/stat.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

namespace bv::lut {
namespace {

const std::string kSim = std::string(BV_SHARED_DATA_DIR) + "/sim";

bool Exists(const std::string& p) {
  struct stat st;
  return stat(p.c_str(), &st) == 0;
}

Yuv FromRgb(double r, double g, double b) {
  const double y = 0.299 * r + 0.587 * g + 0.114 * b;
  return {static_cast<uint8_t>(std::lround(y)),
          static_cast<uint8_t>(std::lround(128 + 0.564 * (b - y))),
          static_cast<uint8_t>(std::lround(128 + 0.713 * (r - y)))};
}

TEST(LutTeachTest, FitCoversTheTaughtBallFromShadeToLightAndNothingGrey) {
  // An orange surface from shade to light (the sRGB triple scaled), with a little spread.
  std::vector<Yuv> ball;
  for (int i = 0; i < 2000; ++i) {
    const double k = 0.25 + 0.7 * (i % 100) / 100.0, g = 0.40 + 0.05 * ((i / 100) % 4);
    ball.push_back(FromRgb(250 * k, 250 * g * k, 20 * k));
  }
  BallColorModel m;
  std::string why;
  ASSERT_TRUE(FitBallColorModel(ball, BallColorModel{}, m, why)) << why;
  int in = 0;
  for (const Yuv& p : ball) in += InBallColorModel(m, p.y, p.u, p.v);
  EXPECT_GE(in, static_cast<int>(0.95 * ball.size()));
  EXPECT_LT(m.hue_max_deg - m.hue_min_deg, 60.0f) << "a fit narrower than the default";
  const Yuv grey = FromRgb(120, 120, 120), white = FromRgb(230, 230, 230);
  EXPECT_FALSE(InBallColorModel(m, grey.y, grey.u, grey.v));
  EXPECT_FALSE(InBallColorModel(m, white.y, white.u, white.v));
}

// A click teaches a near ball's inside, all strongly coloured (relative chroma ~0.6-0.9 here).
// The same ball far away is a few pixels, all edge, mixed with the carpet: its chroma is lower,
// so the taught floor stays at the start model's (lob 173 lost its far omni ball with 0.40).
TEST(LutTeachTest, TheChromaFloorsNeverRiseAboveTheStartModels) {
  std::vector<Yuv> ball;
  for (int i = 0; i < 2000; ++i) {
    const double k = 0.4 + 0.5 * (i % 100) / 100.0;
    ball.push_back(FromRgb(250 * k, 60 * k, 10 * k));
  }
  const BallColorModel start;
  BallColorModel m;
  std::string why;
  ASSERT_TRUE(FitBallColorModel(ball, start, m, why)) << why;
  EXPECT_LE(m.chroma_min, start.chroma_min);
  EXPECT_LE(m.chroma_min_bright, start.chroma_min_bright);
  // An edge pixel at the ball's hue with a third of its chroma (relative chroma ~0.3).
  const Yuv inside = FromRgb(200, 48, 8);
  const Yuv mixed = {inside.y, static_cast<uint8_t>(128 + (inside.u - 128) / 3),
                     static_cast<uint8_t>(128 + (inside.v - 128) / 3)};
  ASSERT_LT(RelativeChroma(mixed), 0.35f);
  ASSERT_GT(RelativeChroma(mixed), start.chroma_min);
  EXPECT_TRUE(InBallColorModel(m, mixed.y, mixed.u, mixed.v))
      << "chroma " << RelativeChroma(mixed) << " hue " << HueDeg(mixed) << " floor " << m.chroma_min
      << " window " << m.hue_min_deg << ".." << m.hue_max_deg;
}

TEST(LutTeachTest, FitRefusesTooFewOrGreyPixels) {
  BallColorModel m;
  std::string why;
  EXPECT_FALSE(FitBallColorModel(std::vector<Yuv>(50, FromRgb(250, 100, 20)), {}, m, why));
  EXPECT_NE(why.find("ball pixels to learn from"), std::string::npos) << why;
  EXPECT_FALSE(FitBallColorModel(std::vector<Yuv>(5000, FromRgb(128, 120, 118)), {}, m, why));
  EXPECT_NE(why.find("nearly grey"), std::string::npos) << why;
}

TEST(LutTeachTest, AYellowBallAcrossPlusMinus180DegreesIsOneWindow) {
  // Yellow sits at the +-180 deg seam of atan2(V-128, U-128): half the pixels on each side.
  std::vector<Yuv> ball;
  for (int i = 0; i < 1000; ++i) {
    const double k = 0.5 + 0.4 * (i % 50) / 50.0, b = (i % 2) ? 10 : 60;
    ball.push_back(FromRgb(240 * k, 225 * k, b * k));
  }
  BallColorModel m;
  std::string why;
  ASSERT_TRUE(FitBallColorModel(ball, {}, m, why)) << why;
  EXPECT_LT(m.hue_max_deg - m.hue_min_deg, 90.0f);
  int in = 0;
  for (const Yuv& p : ball) in += InBallColorModel(m, p.y, p.u, p.v);
  EXPECT_GE(in, 900);
}

TEST(LutTeachTest, NarrowingLeavesOutABackgroundClusterBesideTheBall) {
  // Ball hue 112-117 deg; a red box at ~109 deg in the background; the window must end between.
  std::vector<Yuv> ball, background;
  for (int i = 0; i < 3000; ++i) {
    const double k = 0.4 + 0.5 * (i % 60) / 60.0, g = 0.22 + 0.04 * ((i / 60) % 3);
    ball.push_back(FromRgb(235 * k, 235 * g * k, 40 * k));
  }
  for (int i = 0; i < 400; ++i) {
    const double k = 0.4 + 0.5 * (i % 40) / 40.0;
    background.push_back(FromRgb(210 * k, 40 * k, 40 * k));
  }
  BallColorModel m;
  std::string why;
  ASSERT_TRUE(FitBallColorModel(ball, {}, m, why)) << why;
  int box_in = 0;
  for (const Yuv& p : background) box_in += InBallColorModel(m, p.y, p.u, p.v);
  ASSERT_GT(box_in, 0) << "the test needs a box the plain fit takes";
  NarrowAgainstBackground(ball, background, 64.0, m);
  int box_after = 0, ball_after = 0;
  for (const Yuv& p : background) box_after += InBallColorModel(m, p.y, p.u, p.v);
  for (const Yuv& p : ball) ball_after += InBallColorModel(m, p.y, p.u, p.v);
  EXPECT_EQ(box_after, 0);
  EXPECT_GE(ball_after, static_cast<int>(0.9 * ball.size()));
}

TEST(LutTeachTest, TeachingTheCarpetAsBallIsRefused) {
  const std::string img = kSim + "/bounce/persp/000000.png";
  if (!Exists(img)) GTEST_SKIP() << "no data at " << img;
  // A "ball" box on the carpet below the ball: the taught class would be green.
  cli::AnnotatedImage im;
  im.name = "000000.png";
  im.path = img;
  im.boxes.push_back({0, 100, 400, 160, 460, 1});
  cli::BoxTeach r;
  std::string error;
  EXPECT_FALSE(cli::TeachFromBoxes("boxes.txt", {im}, cli::BoxTeachOptions{}, r, error));
  EXPECT_NE(error.find("the field's or the lines'"), std::string::npos) << error;
}

TEST(LutTeachTest, OneClickTeachOnASequenceFindsTheBallEverywhere) {
  const std::string seq = kSim + "/bounce";
  if (!Exists(seq + "/truth.csv")) GTEST_SKIP() << "no data at " << seq;
  FinderSetup setup;
  setup.omni = ReferenceOmniScanConfig(314.2f, 244.1f);
  setup.persp = ReferencePerspScanConfig();
  TeachOptions opt;
  opt.click = true;
  opt.click_index = 0;
  opt.click_camera = Camera::kPersp;
  opt.click_u = 318;  // the ball in frame 0 (truth: 318.2, 152.5)
  opt.click_v = 152;
  TeachReport r;
  std::string error;
  ASSERT_TRUE(TeachSequence(seq, setup, opt, r, error)) << error;
  EXPECT_GT(r.frames[0], 20) << "the omni camera, acquired by the clicked ball's colour";
  EXPECT_GT(r.frames[1], 20);
  EXPECT_LT(r.model.hue_max_deg - r.model.hue_min_deg, 52.0f) << "narrower than the default";
  auto lut = std::make_unique<ColorLut>();
  ASSERT_TRUE(BuildLut(r.model, *lut).ok());
  for (Camera cam : {Camera::kOmni, Camera::kPersp}) {
    EvalCounts e;
    ASSERT_TRUE(EvalSim(seq, cam, *lut, setup, 1, 0, e, error)) << error;
    EXPECT_EQ(e.found_on_ball, e.ball_frames) << (cam == Camera::kOmni ? "omni" : "persp");
    EXPECT_EQ(e.false_det, 0);
  }
  // A click where nothing ball-coloured is: refused, naming the click.
  opt.click_u = 600;
  opt.click_v = 50;
  EXPECT_FALSE(TeachSequence(seq, setup, opt, r, error));
  EXPECT_NE(error.find("no ball-coloured region at the click"), std::string::npos) << error;
}

}  // namespace
}  // namespace bv::lut

namespace bv::cli {
namespace {

// A band of floor balls seen by a camera 0.7 m up, and three balls held up above the band (a
// person's hands, a robot's top): the profile must not put the horizon above the held ones and
// hand the floor balls to the curve (that put a real set's camera 3-19 m up).
TEST(FloorProfileTest, HeldBallsAboveTheFloorBandLeaveTheCameraAtItsHeight) {
  constexpr float kR = 0.11f, kHeight = 0.7f, kHorizon = 330.0f;
  const float k = kR / (kHeight - kR);
  AnnotatedImage im;
  int i = 0;
  for (float v = 360.0f; v <= 470.0f; v += 4.0f, ++i) {
    const float r = k * (v - kHorizon) * (1.0f + 0.05f * static_cast<float>(i % 3 - 1));
    im.boxes.push_back({0, 300.0f - r, v - r, 300.0f + r, v + r, i});
  }
  for (float v : {250.0f, 280.0f, 310.0f})
    im.boxes.push_back({0, 100.0f, v - 15, 130.0f, v + 15, 0});
  FloorBallProfile p;
  std::string note;
  ASSERT_TRUE(LearnFloorProfile({im}, 608, 800, p, note)) << note;
  EXPECT_NEAR(p.horizon_v_px, kHorizon, 15.0f);
  const float height = kR * (1.0f + 1.0f / p.slope);
  EXPECT_GT(height, 0.5f);
  EXPECT_LT(height, 0.95f);
  EXPECT_LT(p.spread, 0.15f);
}

TEST(TeachBlurTest, FewBallSamplesWidenTheBlurUpToTwoCellsMore) {
  const BoxTeachOptions o;  // +-2 cells at 16,000 samples
  EXPECT_EQ(TeachBlur(o, 60000), o.smooth);
  EXPECT_EQ(TeachBlur(o, o.reference_ball_samples), o.smooth);
  EXPECT_EQ(TeachBlur(o, 2400), o.smooth + 1);  // a first-5 teach: (16000 / 2400)^(1/6) = 1.37
  EXPECT_EQ(TeachBlur(o, 10), o.smooth + 2);    // capped
  EXPECT_EQ(TeachBlur(o, 0), o.smooth + 2);
}

}  // namespace
}  // namespace bv::cli
