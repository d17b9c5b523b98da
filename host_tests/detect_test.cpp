// BallFinder on synthetic frames: ball choice, attention, bad input, overflow.
#include "core/detect/detect.h"

#include <gtest/gtest.h>

#include "core/color_lut/color_model.h"
#include "core/common/round.h"

#include "host_tests/test_util.h"

#include <cmath>
#include <functional>
#include <memory>
#include <random>
#include <vector>

namespace bv {
namespace {

constexpr float kCu = 314.2f, kCv = 244.1f;
constexpr uint8_t kBallY = 200, kBackY = 50;

struct Frame {
  std::vector<uint8_t> data = std::vector<uint8_t>(kFrameBytes, 128);
  Frame() { Fill(kBackY); }
  void Fill(uint8_t y) {
    for (size_t i = 0; i < data.size(); i += 2) data[i] = y;
  }
  void Set(int u, int v, uint8_t y) {
    if (u >= 0 && v >= 0 && u < kFrameWidth && v < kFrameHeight)
      data[(static_cast<size_t>(v) * kFrameWidth + u) * 2] = y;
  }
  void Disc(float cu, float cv, float r, uint8_t y = kBallY) {
    for (int v = static_cast<int>(cv - r - 1); v <= cv + r + 1; ++v)
      for (int u = static_cast<int>(cu - r - 1); u <= cu + r + 1; ++u)
        if (std::hypot(u - cu, v - cv) <= r) Set(u, v, y);
  }
  YuyvImage view() const { return MakeYuyvImage(data.data(), kFrameWidth, kFrameHeight); }
};

const ColorLut& Lut() { return test::BrightIsBallLut(); }

struct Omni {
  std::unique_ptr<ScanlineTable<kOmniScanPixels>> scan =
      std::make_unique<ScanlineTable<kOmniScanPixels>>();
  std::unique_ptr<BallFinder> finder = std::make_unique<BallFinder>();
  explicit Omni(BallFinderConfig cfg = {}) {
    EXPECT_TRUE(scan->BuildOmni(ReferenceOmniScanConfig(kCu, kCv), kFrameWidth, kFrameHeight).ok());
    EXPECT_TRUE(finder->Init(*scan, cfg).ok());
  }
};

TEST(DetectTest, RoundToIntIsTheLibrarysRoundingWithoutTheCall) {
  // Every float the detector rounds: ties, the float just below a tie, signs, large values.
  std::vector<float> xs = {0.0f,      -0.0f,       0.5f,  -0.5f,         1.5f,          -2.5f,
                           2.5f,      0.49999997f, 1e6f,  -1e6f,         8388607.5f,    -8388607.5f,
                           8388609.f, 2e9f,        -2e9f, 2147483520.0f, -2147483520.0f};
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> wide(-5000.0f, 5000.0f), unit(-4.0f, 4.0f);
  for (int i = 0; i < 200000; ++i) xs.push_back(i % 2 ? wide(rng) : unit(rng));
  for (int i = -4000; i <= 4000; ++i) {
    const float tie = static_cast<float>(i) + 0.5f;
    xs.push_back(tie);
    xs.push_back(std::nextafter(tie, 0.0f));
    xs.push_back(std::nextafter(tie, 2.0f * tie));
  }
  for (const float x : xs) {
    if (std::fabs(x) < 2147483520.0f) {
      ASSERT_EQ(RoundToInt(x), std::lround(x)) << x;
    }
  }
  EXPECT_EQ(RoundToInt(std::nanf("")), INT32_MIN);
  EXPECT_EQ(RoundToInt(3e9f), INT32_MIN);
  EXPECT_EQ(RoundToInt(-INFINITY), INT32_MIN);
}

TEST(DetectTest, FindsADiscWithSubPixelCentroidReadingFewPixels) {
  Omni o;
  Frame f;
  f.Disc(455.9f, 363.3f, 3.0f);  // r = 185 px from the centre: ~7 px balls expected there
  BallDetection d;
  FrontEndStats s;
  ASSERT_TRUE(o.finder->Find(f.view(), Lut(), nullptr, d, s).ok());
  ASSERT_TRUE(d.found);
  // Against the centroid of the digitised disc (its pixel set), and loosely the true centre.
  double su = 0, sv = 0;
  int n = 0;
  for (int v = 355; v < 372; ++v)
    for (int u = 448; u < 464; ++u)
      if (std::hypot(u - 455.9f, v - 363.3f) <= 3.0f) su += u, sv += v, ++n;
  EXPECT_NEAR(d.u_px, su / n, 0.1);
  EXPECT_NEAR(d.v_px, sv / n, 0.1);
  EXPECT_NEAR(d.u_px, 455.9f, 0.3f);
  EXPECT_NEAR(d.v_px, 363.3f, 0.3f);
  EXPECT_NEAR(d.radius_px, 3.0f, 0.4f);
  EXPECT_GT(d.roundness, 0.85f);
  EXPECT_GT(d.confidence, 0.5f);
  EXPECT_EQ(s.regions, 1u);
  EXPECT_GE(s.seeds, 1u);
  EXPECT_EQ(s.overflows, 0u);
  EXPECT_LT(s.pixels_read, kFrameWidth * kFrameHeight / 15);  // < 7 % of the frame
  EXPECT_EQ(s.scan_pixels, o.scan->pixel_count());
}

TEST(DetectTest, BadInputIsRejected) {
  BallFinder unready;
  Frame f;
  BallDetection d;
  FrontEndStats s;
  EXPECT_EQ(unready.Find(f.view(), Lut(), nullptr, d, s).code(), StatusCode::kFailedPrecondition);
  Omni o;
  const YuyvImage small = MakeYuyvImage(f.data.data(), 320, 240);
  EXPECT_EQ(o.finder->Find(small, Lut(), nullptr, d, s).code(), StatusCode::kInvalidArgument);
  YuyvImage null_data = f.view();
  null_data.data = nullptr;
  EXPECT_EQ(o.finder->Find(null_data, Lut(), nullptr, d, s).code(), StatusCode::kInvalidArgument);
  EXPECT_FALSE(d.found);
  BallFinderConfig cfg;
  cfg.attention_samples = 100000;
  EXPECT_EQ(BallFinder().Init(*o.scan, cfg).code(), StatusCode::kInvalidArgument);
  auto empty = std::make_unique<ScanlineTable<8>>();
  EXPECT_EQ(BallFinder().Init(*empty, {}).code(), StatusCode::kFailedPrecondition);
}

TEST(DetectTest, BlackSaturatedAndAllBallFramesAreBounded) {
  Omni o;
  BallDetection d;
  FrontEndStats s;
  Frame black;
  black.Fill(0);
  ASSERT_TRUE(o.finder->Find(black.view(), Lut(), nullptr, d, s).ok());
  EXPECT_FALSE(d.found);
  EXPECT_EQ(s.pixels_read, s.scan_pixels);
  Frame all;
  all.Fill(255);  // everything ball-coloured
  ASSERT_TRUE(o.finder->Find(all.view(), Lut(), nullptr, d, s).ok());
  EXPECT_EQ(s.regions, 1u);  // one region, traced once
  EXPECT_LT(s.pixels_read, 20u * kFrameWidth * kFrameHeight);
}

TEST(DetectTest, SpeckleNoiseIsDroppedWithoutUsingTheCapacity) {
  Omni o;
  Frame f;
  std::mt19937 rng(7);
  for (int v = 0; v < kFrameHeight; v += 3)
    for (int u = 0; u < kFrameWidth; u += 3)
      if (rng() % 3 == 0) f.Set(u, v, kBallY);
  f.Disc(455.9f, 363.3f, 4.0f);  // a ball among the specks
  BallDetection d;
  FrontEndStats s;
  ASSERT_TRUE(o.finder->Find(f.view(), Lut(), nullptr, d, s).ok());
  EXPECT_EQ(s.overflows, 0u);
  EXPECT_GT(s.small, 100u);  // single pixels: traced, below min_area_px, forgotten
  EXPECT_EQ(s.regions, 1u);
  ASSERT_TRUE(d.found);
  EXPECT_NEAR(d.u_px, 455.9f, 0.5f);
}

TEST(DetectTest, BlobNoiseOverflowsRegionsAndReportsIt) {
  Omni o;
  Frame f;
  for (int v = 2; v + 4 < kFrameHeight; v += 9)  // 4x4 blobs (16 px, above min_area_px)
    for (int u = 2; u + 4 < kFrameWidth; u += 9)
      for (int dv = 0; dv < 4; ++dv)
        for (int du = 0; du < 4; ++du) f.Set(u + du, v + dv, kBallY);
  BallDetection d;
  FrontEndStats s;
  ASSERT_TRUE(o.finder->Find(f.view(), Lut(), nullptr, d, s).ok());
  EXPECT_GE(s.overflows, 1u);
  EXPECT_EQ(s.regions, BallFinder::kMaxRegions);
  // Bounded by the chain pool (traces let go after the capacity is reached keep their codes
  // used): no full-frame work.
  EXPECT_LT(s.pixels_read, 0.2 * kFrameWidth * kFrameHeight);
  EXPECT_TRUE(d.found);  // squares pass the shape test; what matters is the bound and the report
}

// Runs the finder; the ball must be found at (u, v). Returns the counters.
FrontEndStats ExpectBallAt(const Omni& o, const Frame& f, const Prediction* p, float u, float v,
                           float tol_px) {
  BallDetection d;
  FrontEndStats s;
  EXPECT_TRUE(o.finder->Find(f.view(), Lut(), p, d, s).ok());
  EXPECT_TRUE(d.found);
  EXPECT_NEAR(d.u_px, u, tol_px);
  EXPECT_NEAR(d.v_px, v, tol_px);
  return s;
}

// Thin ball-coloured strips (a badly taught table in a cluttered hall) fill the region capacity
// before the scanlines reach the ball: the ball replaces the weakest of them.
TEST(DetectTest, ABallBeyondTheCapacityOfClutterIsStillFound) {
  Omni o;
  Frame f;
  int strips = 0;
  for (int v = 30; v < 150; v += 10)
    for (int u = 150; u < 480; u += 30, ++strips)
      for (int du = 0; du < 20; ++du) f.Set(u + du, v, kBallY);
  ASSERT_GT(strips, static_cast<int>(BallFinder::kMaxRegions));
  f.Disc(330.4f, 400.6f, 8.0f);
  EXPECT_EQ(ExpectBallAt(o, f, nullptr, 330.4f, 400.6f, 0.3f).overflows, 1u);
}

// With no prediction, shape outweighs size: a blob of hull roundness ~0.7 (a shirt) twice the
// ball's area is not chosen over the round ball.
TEST(DetectTest, WithoutAPredictionARoundBallBeatsALargerBlob) {
  Omni o;
  Frame f;
  for (int v = 120; v <= 180; ++v)
    for (int u = 130; u <= 270; ++u) {
      const float x = (u - 200.0f) / 60.0f, y = (v - 150.0f) / 25.0f;
      if (x * x + y * y <= 1.0f) f.Set(u, v, kBallY);
    }
  f.Disc(440.3f, 330.7f, 24.0f);
  ExpectBallAt(o, f, nullptr, 440.3f, 330.7f, 0.5f);
}

// A small ball in the air, anti-aliased (each pixel the mix of ball and background it covers):
// the grey hall above it, the green field below, under the built-in colour model. The binary
// class keeps the mixed pixels against grey and drops them against green, so the region's
// centroid sits high; the soft centroid unmixes the boundary and finds the centre.
TEST(DetectTest, SoftCentroidOfABallBetweenHallAndField) {
  auto lut = std::make_unique<ColorLut>();
  ASSERT_TRUE(BuildLut(BallColorModel{}, *lut).ok());
  constexpr float kU = 455.3f, kV = 363.6f, kR = 4.5f;
  constexpr float kBall[3] = {90, 100, 190}, kGrey[3] = {100, 128, 128}, kGreen[3] = {70, 157, 108};
  std::vector<float> yuv(static_cast<size_t>(kFrameWidth) * kFrameHeight * 3);
  for (int v = 0; v < kFrameHeight; ++v) {
    for (int u = 0; u < kFrameWidth; ++u) {
      int in = 0;  // of 8 x 8 subsamples
      if (std::hypot(u - kU, v - kV) < kR + 1.5f)
        for (int j = 0; j < 8; ++j)
          for (int i = 0; i < 8; ++i)
            in += std::hypot(u - 0.4375f + i / 8.0f - kU, v - 0.4375f + j / 8.0f - kV) <= kR;
      const float a = in / 64.0f;
      const float* bg = v < kV ? kGrey : kGreen;
      for (int c = 0; c < 3; ++c)
        yuv[(static_cast<size_t>(v) * kFrameWidth + u) * 3 + c] = a * kBall[c] + (1 - a) * bg[c];
    }
  }
  Frame f;  // YUYV: U and V averaged over each pixel pair, as the camera delivers them
  for (int v = 0; v < kFrameHeight; ++v) {
    for (int u = 0; u < kFrameWidth; u += 2) {
      const float* p = &yuv[(static_cast<size_t>(v) * kFrameWidth + u) * 3];
      uint8_t* q = &f.data[(static_cast<size_t>(v) * kFrameWidth + u) * 2];
      q[0] = static_cast<uint8_t>(std::lround(p[0]));
      q[2] = static_cast<uint8_t>(std::lround(p[3]));
      q[1] = static_cast<uint8_t>(std::lround(0.5f * (p[1] + p[4])));
      q[3] = static_cast<uint8_t>(std::lround(0.5f * (p[2] + p[5])));
    }
  }
  for (bool soft : {false, true}) {
    BallFinderConfig cfg;
    cfg.soft_centroid = soft;
    Omni o(cfg);
    BallDetection d;
    FrontEndStats s;
    ASSERT_TRUE(o.finder->Find(f.view(), *lut, nullptr, d, s).ok());
    ASSERT_TRUE(d.found);
    if (soft) {
      EXPECT_NEAR(d.u_px, kU, 0.15f);  // 0.1 px along u: the chroma shared by pixel pairs
      EXPECT_NEAR(d.v_px, kV, 0.05f);
    } else {
      EXPECT_LT(d.v_px, kV - 0.15f);  // the bias the soft centroid removes
    }
  }
}

// The predicted ball, small and far, is traced by the attention samples first; larger discs the
// scanlines find after the capacity is reached do not replace it.
TEST(DetectTest, ClutterCannotReplaceThePredictedBall) {
  Omni o;
  Frame f;
  for (int v = 40; v < 440; v += 24)
    for (int u = 60; u < 580; u += 24)
      if (std::hypot(u - 500.0f, v - 300.0f) > 40.0f) f.Disc(u, v, 5.0f);
  f.Disc(500.3f, 300.2f, 2.5f);
  Prediction p;
  p.u_px = 500.0f;
  p.v_px = 300.0f;
  p.sigma_px = 4.0f;
  EXPECT_GE(ExpectBallAt(o, f, &p, 500.3f, 300.2f, 0.5f).overflows, 1u);
}

TEST(DetectTest, ChoosesRoundThenInFieldThenNearestPrediction) {
  Frame f;
  f.Disc(420, 150, 9);  // round
  for (int v = 290; v < 296; ++v)
    for (int u = 180; u < 240; ++u) f.Set(u, v, kBallY);  // elongated
  f.Disc(250, 330, 10.5f);                                // second round, larger
  {
    Omni o;
    BallDetection d;
    FrontEndStats s;
    ASSERT_TRUE(o.finder->Find(f.view(), Lut(), nullptr, d, s).ok());
    EXPECT_EQ(s.candidates, 2u);    // the bar fails the roundness test
    EXPECT_NEAR(d.u_px, 250, 0.2);  // no prediction: the larger round region
  }
  {
    Omni o;
    BallDetection d;
    FrontEndStats s;
    Prediction p{415, 155, 6};
    ASSERT_TRUE(o.finder->Find(f.view(), Lut(), &p, d, s).ok());
    EXPECT_NEAR(d.u_px, 420, 0.2);  // nearest the prediction
  }
  {
    struct RightOf300 final : FieldPredicate {
      bool Inside(float u, float, float) const override { return u > 300; }
    };
    static const RightOf300 field;
    BallFinderConfig cfg;
    cfg.field = &field;
    Omni o(cfg);
    BallDetection d;
    FrontEndStats s;
    Prediction p{255, 325, 6};
    ASSERT_TRUE(o.finder->Find(f.view(), Lut(), &p, d, s).ok());
    EXPECT_NEAR(d.u_px, 420, 0.2);  // inside the field beats near the prediction
  }
}

TEST(DetectTest, AttentionFindsABallBetweenScanlines) {
  Omni o;
  // Find a 3 px disc position the scanlines miss (they are laid out for >= 4 px at the rim).
  std::vector<uint8_t> mark(kFrameWidth * kFrameHeight, 0);
  ForEachScanPixel(*o.scan, [&](int u, int v) { mark[v * kFrameWidth + u] = 1; });
  float bu = -1, bv = -1;
  for (int v = 40; v < 440 && bu < 0; ++v)
    for (int u = 100; u < 540 && bu < 0; ++u) {
      const float r = std::hypot(u - kCu, v - kCv);
      if (r < 120 || r > 200) continue;
      bool hit = false;
      for (int dv = -2; dv <= 2; ++dv)
        for (int du = -2; du <= 2; ++du) hit |= mark[(v + dv) * kFrameWidth + u + du] != 0;
      if (!hit) bu = static_cast<float>(u), bv = static_cast<float>(v);
    }
  ASSERT_GE(bu, 0) << "no gap between scanlines found";
  Frame f;
  f.Disc(bu, bv, 2.0f);  // 13 pixels
  BallDetection d;
  FrontEndStats s;
  ASSERT_TRUE(o.finder->Find(f.view(), Lut(), nullptr, d, s).ok());
  EXPECT_FALSE(d.found);
  Prediction p{bu + 1.5f, bv - 1.0f, 3.0f};
  ASSERT_TRUE(o.finder->Find(f.view(), Lut(), &p, d, s).ok());
  EXPECT_TRUE(d.found);
  EXPECT_NEAR(d.u_px, bu, 0.2);
  EXPECT_EQ(s.attention_samples, 64u);
  // Deterministic: a fresh finder draws the same samples.
  Omni o2;
  BallDetection d2;
  ASSERT_TRUE(o2.finder->Find(f.view(), Lut(), &p, d2, s).ok());
  ASSERT_EQ(o2.finder->attention_count(), o.finder->attention_count());
  Omni o3;
  ASSERT_TRUE(o3.finder->Find(f.view(), Lut(), &p, d2, s).ok());
  for (int i = 0; i < o2.finder->attention_count(); ++i) {
    EXPECT_EQ(o2.finder->attention_u(i), o3.finder->attention_u(i));
  }
  // The samples are spread like N(prediction, sigma).
  double su = 0, suu = 0;
  for (int i = 0; i < o3.finder->attention_count(); ++i) {
    su += o3.finder->attention_u(i) - p.u_px;
    suu += std::pow(o3.finder->attention_u(i) - p.u_px, 2);
  }
  const double n = o3.finder->attention_count();
  EXPECT_NEAR(su / n, 0.0, 1.2);
  EXPECT_NEAR(std::sqrt(suu / n), 3.0, 1.2);
}

TEST(DetectTest, BallCutByAStrutGivesTheVisiblePart) {
  Omni o;
  Frame f;
  const float cu = kCu + 150 * std::cos(14.5f / 57.29578f),
              cv = kCv + 150 * std::sin(14.5f / 57.29578f);
  f.Disc(cu + 6, cv - 3, 9.0f);
  // Dark strut wedge through the disc: 4 px wide band along the strut direction.
  for (int v = 0; v < kFrameHeight; ++v)
    for (int u = 0; u < kFrameWidth; ++u) {
      const float ang = std::atan2(v - kCv, u - kCu) * 57.29578f;
      const float r = std::hypot(u - kCu, v - kCv);
      if (std::fabs(ang - 14.5f) * r / 57.29578f < 2.0f && r > 60) f.Set(u, v, 20);
    }
  BallDetection d;
  FrontEndStats s;
  ASSERT_TRUE(o.finder->Find(f.view(), Lut(), nullptr, d, s).ok());
  ASSERT_TRUE(d.found);
  EXPECT_GE(s.regions, 1u);  // the part inside the skipped wedge may stay unseeded
  EXPECT_LT(d.area_px, 0.8f * 3.14159f * 81.0f);  // one visible part, not the whole ball
  EXPECT_LT(std::hypot(d.u_px - (cu + 6), d.v_px - (cv - 3)), 9.0f);  // on the ball
}

}  // namespace
}  // namespace bv

namespace bv {
namespace {

TEST(DetectTest, PerspBallCutByTheImageBorderGivesTheVisiblePart) {
  auto scan = std::make_unique<ScanlineTable<kPerspScanPixels>>();
  ASSERT_TRUE(scan->BuildPersp(ReferencePerspScanConfig(), kFrameWidth, kFrameHeight).ok());
  auto finder = std::make_unique<BallFinder>();
  ASSERT_TRUE(finder->Init(*scan, {}).ok());
  Frame f;
  f.Disc(635.0f, 200.0f, 20.0f);  // 3/4 of the disc is outside the right border
  double su = 0, sv = 0;
  int n = 0;
  for (int v = 180; v <= 220; ++v)
    for (int u = 615; u < kFrameWidth; ++u)
      if (std::hypot(u - 635.0f, v - 200.0f) <= 20.0f) su += u, sv += v, ++n;
  BallDetection d;
  FrontEndStats s;
  ASSERT_TRUE(finder->Find(f.view(), Lut(), nullptr, d, s).ok());
  ASSERT_TRUE(d.found);
  EXPECT_NEAR(d.u_px, su / n, 0.5);
  EXPECT_NEAR(d.v_px, sv / n, 0.2);
  EXPECT_NEAR(d.area_px, n, 1.0);
}

}  // namespace
}  // namespace bv

namespace bv {
namespace {

// A persp ball in front of a box of its colour: one region, not round, whose centroid is off the
// ball. With circles on, the finder reports the ball's own centre and radius.
TEST(DetectTest, PerspBallMergedWithABoxBehindItIsFoundByItsCircle) {
  auto scan = std::make_unique<ScanlineTable<kPerspScanPixels>>();
  ASSERT_TRUE(scan->BuildPersp(ReferencePerspScanConfig(), kFrameWidth, kFrameHeight).ok());
  Frame f;
  const float cu = 300.4f, cv = 260.3f, rad = 13.0f;
  f.Disc(cu, cv, rad);
  for (int v = 215; v < 256; ++v)
    for (int u = 306; u < 372; ++u) f.Set(u, v, kBallY);  // the box, up and right of the ball
  for (bool circles : {false, true}) {
    BallFinderConfig cfg;
    cfg.fit_circles = circles;
    auto finder = std::make_unique<BallFinder>();
    ASSERT_TRUE(finder->Init(*scan, cfg).ok());
    for (bool predicted : {false, true}) {
      Prediction p;
      p.u_px = cu + 2;
      p.v_px = cv + 1;
      p.sigma_px = 2 * rad;
      p.radius_px = rad;
      BallDetection d;
      FrontEndStats s;
      ASSERT_TRUE(finder->Find(f.view(), Lut(), predicted ? &p : nullptr, d, s).ok());
      if (!circles) {
        // The merged region: not round enough, or a centroid far from the ball.
        EXPECT_TRUE(!d.found || std::hypot(d.u_px - cu, d.v_px - cv) > 5.0f) << predicted;
        EXPECT_EQ(d.arc_sectors, 0);
        continue;
      }
      ASSERT_TRUE(d.found) << predicted;
      EXPECT_GE(d.arc_sectors, 8) << predicted;
      EXPECT_NEAR(d.u_px, cu, 0.5f) << predicted;
      EXPECT_NEAR(d.v_px, cv, 0.5f) << predicted;
      EXPECT_NEAR(d.radius_px, rad, 0.7f) << predicted;
      BallDetection c[4];
      ASSERT_EQ(finder->Candidates(c), 1u);
      EXPECT_EQ(c[0].arc_sectors, d.arc_sectors);
    }
  }
  // A clean disc keeps its centroid (it averages every pixel).
  Frame g;
  g.Disc(cu, cv, rad);
  BallFinderConfig cfg;
  cfg.fit_circles = true;
  auto finder = std::make_unique<BallFinder>();
  ASSERT_TRUE(finder->Init(*scan, cfg).ok());
  BallDetection d;
  FrontEndStats s;
  ASSERT_TRUE(finder->Find(g.view(), Lut(), nullptr, d, s).ok());
  ASSERT_TRUE(d.found);
  EXPECT_EQ(d.arc_sectors, 0);
  cfg.min_arc_sectors = 17;
  EXPECT_FALSE(finder->Init(*scan, cfg).ok());
}

}  // namespace
}  // namespace bv
