// core/ball_check: size and place from a calibration and from a learned profile, the scan pattern
// a profile gives, the candidate features, and the classifier blob (round trip, every refusal).
#include "core/ball_check/ball_check.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <vector>

#include <Eigen/Geometry>

#include "core/common/blob.h"
#include "tools/ballvision/calib_io.h"

namespace bv {
namespace {

const std::string kRefCalib = std::string(BV_TEST_DATA_DIR) + "/reference_rig_calib.json";

RigCalibration RefCalibration() {
  RigCalibration cal;
  std::string err;
  EXPECT_TRUE(cli::LoadCalibrationFile(kRefCalib, cal, err)) << err;
  return cal;
}

// The candidate a ball of radius R at robot-frame point p makes in the persp image.
CandidateShape Seen(const PerspCalibration& cal, const Eigen::Vector3f& p, float R) {
  CandidateShape c;
  float u = 0, v = 0, u2 = 0, v2 = 0;
  EXPECT_TRUE(PerspProject(cal, p, u, v).ok());
  // A point R to the side of the centre, across the viewing direction: the apparent radius.
  const Eigen::Vector3f view = p - cal.t_robot_cam;
  const Eigen::Vector3f side = Eigen::Vector3f(view.y(), -view.x(), 0.0f).normalized();
  EXPECT_TRUE(PerspProject(cal, p + R * side, u2, v2).ok());
  c.u_px = u;
  c.v_px = v;
  c.radius_px = std::hypot(u2 - u, v2 - v);
  c.area_px = 3.14159265f * c.radius_px * c.radius_px;
  return c;
}

TEST(BallGeometryTest, CalibratedPerspTellsTheFloorBallFromALampAndASpeck) {
  const RigCalibration cal = RefCalibration();
  BallGeometry g;
  ASSERT_TRUE(g.SetPersp(cal.persp, BallGeometryConfig{}).ok());
  BallPlace where;
  // A ball on the floor 3 m ahead.
  const CandidateShape ball = Seen(cal.persp, {0.3f, 3.0f, 0.11f}, 0.11f);
  EXPECT_EQ(g.Check(ball, where), PlaceVerdict::kPlausible);
  EXPECT_TRUE(where.known);
  EXPECT_NEAR(where.height_m, 0.11f, 0.03f);
  EXPECT_NEAR(where.floor_ratio, 1.0f, 0.05f);
  // A ball in the air (a lob at 2 m height, 4 m away) is a ball too.
  EXPECT_EQ(g.Check(Seen(cal.persp, {0.0f, 4.0f, 2.0f}, 0.11f), where), PlaceVerdict::kPlausible);
  EXPECT_NEAR(where.height_m, 2.0f, 0.1f);
  // A ceiling lamp's 0.3 m glow 8 m up and 12 m away looks like a ball 5 m away at 3.2 m: still
  // a ball for size and place (the classifier's case); a 0.15 m bulb there would be 6 m up.
  EXPECT_EQ(g.Check(Seen(cal.persp, {1.0f, 12.0f, 8.0f}, 0.3f), where), PlaceVerdict::kPlausible);
  EXPECT_EQ(g.Check(Seen(cal.persp, {1.0f, 12.0f, 8.0f}, 0.15f), where), PlaceVerdict::kTooHigh);
  EXPECT_GT(where.height_m, 5.5f);
  // A speck on the carpet 1.5 m ahead, a fifth of a ball's size there.
  CandidateShape speck = Seen(cal.persp, {0.0f, 1.5f, 0.11f}, 0.11f);
  speck.radius_px *= 0.2f;
  EXPECT_EQ(g.Check(speck, where), PlaceVerdict::kTooSmall);
  // Nothing is known without geometry.
  BallGeometry none;
  EXPECT_EQ(none.Check(speck, where), PlaceVerdict::kPlausible);
  EXPECT_FALSE(where.known);
}

TEST(BallGeometryTest, ALearnedProfileGivesHeightAboveTheHorizonAndSizeBelowIt) {
  FloorBallProfile p;
  p.valid = true;
  p.width_px = 608;
  p.height_px = 800;
  p.horizon_v_px = 380;
  p.slope = 0.16f;  // a camera at 0.11 * (1 + 1 / 0.16) = 0.80 m
  p.spread = 0.05f;
  BallGeometry g;
  ASSERT_TRUE(g.SetProfile(p, BallGeometryConfig{}).ok());
  BallPlace where;
  CandidateShape c;
  c.u_px = 300;
  c.v_px = 480;  // 100 rows below the horizon: a floor ball of radius 16
  c.radius_px = 16;
  EXPECT_EQ(g.Check(c, where), PlaceVerdict::kPlausible);
  EXPECT_NEAR(where.floor_ratio, 1.0f, 1e-4f);
  EXPECT_NEAR(where.height_m, 0.11f, 1e-3f);
  c.radius_px = 2;  // 8 times too small
  EXPECT_EQ(g.Check(c, where), PlaceVerdict::kTooSmall);
  c.v_px = 80;  // 300 rows above the horizon, 3 px: 0.8 + 0.11 * 300 / 3 = 11.8 m up
  c.radius_px = 3;
  EXPECT_EQ(g.Check(c, where), PlaceVerdict::kTooHigh);
  EXPECT_NEAR(where.height_m, 11.8f, 0.05f);
  // A profile the boxes hardly agreed on says nothing of height.
  p.spread = 0.5f;
  ASSERT_TRUE(g.SetProfile(p, BallGeometryConfig{}).ok());
  EXPECT_EQ(g.Check(c, where), PlaceVerdict::kPlausible);
  // An invalid profile is refused.
  p.slope = 0;
  EXPECT_EQ(g.SetProfile(p, BallGeometryConfig{}).code(), StatusCode::kInvalidArgument);
}

TEST(BallGeometryTest, ProfileScanPatternHitsEveryBallThePlaceCheckTakes) {
  FloorBallProfile p;
  p.valid = true;
  p.width_px = 608;
  p.height_px = 800;
  p.horizon_v_px = 360;
  p.slope = 0.14f;
  const BallGeometryConfig g;
  const PerspScanConfig scan = PerspScanFromProfile(p, g, 800, 6.0f);
  ScanlineTable<kPerspScanPixels> table;
  ASSERT_TRUE(table.BuildPersp(scan, 608, 800).ok());
  EXPECT_LT(table.pixel_count(), 608u * 800u / 20u) << "no more than 5 % of the pixels";
  std::vector<std::vector<int>> rows(800);
  int row = 0;
  table.ForEachSample([&](int v) { row = v; }, [&](int u, bool) { rows[row].push_back(u); });
  // The smallest ball the place check takes at a row: below the horizon a floor ball
  // max_floor_ratio times too small, above it a ball at max_height; never under 6 px.
  const float h = g.ball_radius_m * (1.0f + 1.0f / p.slope);
  for (int v = 0; v < 800; v += 7) {
    float d = v > p.horizon_v_px
                  ? 2.0f * p.RadiusAt(v) / g.max_floor_ratio
                  : 2.0f * g.ball_radius_m * (p.horizon_v_px - v) / (g.max_height_m - h);
    // The brick lattice covers a disc of its row's diameter; where the diameter changes from row
    // to row its offsets do not line up, so 15 % of margin.
    d = 1.15f * std::max(d, 6.0f);
    for (int u = 40; u < 560; u += 37) {
      bool hit = false;  // a sample of the rows the disc spans lies inside it
      for (int sv = static_cast<int>(v - d / 2); sv <= static_cast<int>(v + d / 2) && !hit; ++sv) {
        if (sv < 0 || sv >= 800) continue;
        for (int su : rows[sv]) {
          const float du = static_cast<float>(su - u), dv = static_cast<float>(sv - v);
          hit |= du * du + dv * dv <= 0.25f * d * d;
        }
      }
      EXPECT_TRUE(hit) << "no scan pixel in a disc of " << d << " px at (" << u << ", " << v << ")";
      if (!hit) return;
    }
  }
}

// A YUYV image filled with one colour, a disc of another drawn on it.
struct Canvas {
  std::vector<uint8_t> px;
  int w, h;
  Canvas(int width, int height, Yuv bg)
      : px(static_cast<size_t>(width) * height * 2), w(width), h(height) {
    for (int v = 0; v < h; ++v)
      for (int u = 0; u < w; ++u) Set(u, v, bg);
  }
  void Set(int u, int v, Yuv c) {
    uint8_t* p = px.data() + (static_cast<size_t>(v) * w + u) * 2;
    p[0] = c.y;
    p[1] = (u & 1) ? c.v : c.u;
  }
  void Disc(float cu, float cv, float r0, float r1, Yuv c) {
    for (int v = 0; v < h; ++v)
      for (int u = 0; u < w; ++u) {
        const float d = std::hypot(u - cu, v - cv);
        if (d >= r0 && d <= r1) Set(u, v, c);
      }
  }
  YuyvImage view() const { return MakeYuyvImage(px.data(), w, h); }
};

TEST(BallFeaturesTest, ASolidBallAndAHollowDigitDiffer) {
  ColorLut lut;
  lut.Fill(ColorClass::kField);
  const Yuv yellow{180, 60, 150}, green{90, 100, 90};
  for (int y = 0; y < 256; y += 16)
    for (int u = 40; u < 80; u += 4)
      for (int v = 130; v < 170; v += 4)
        lut.Set(ColorLut::Index(static_cast<uint8_t>(y), static_cast<uint8_t>(u),
                                static_cast<uint8_t>(v)),
                ColorClass::kBall);
  Canvas ball(120, 100, green), ring(120, 100, green);
  ball.Disc(60, 50, 0, 15, yellow);
  ring.Disc(60, 50, 8, 15, yellow);
  ring.Disc(60, 50, 0, 8, Yuv{20, 128, 128});
  CandidateShape c;
  c.u_px = 60;
  c.v_px = 50;
  c.radius_px = 15;
  c.area_px = 707;
  c.u_min = 45, c.u_max = 75, c.v_min = 35, c.v_max = 65;
  c.roundness = c.hull_roundness = c.width_ratio = 0.95f;
  BallFeatures fb, fr;
  ComputeBallFeatures(ball.view(), lut, c, fb);
  ComputeBallFeatures(ring.view(), lut, c, fr);
  EXPECT_GT(fb.pixels_read, 60u);
  for (float f : fb.f) EXPECT_TRUE(std::isfinite(f));
  EXPECT_NEAR(fb.f[kFeatInBall], 1.0f, 1e-6f);
  EXPECT_NEAR(fb.f[kFeatCoreBall], 1.0f, 1e-6f);
  EXPECT_LT(fr.f[kFeatCoreBall], 0.2f) << "the digit's hollow centre";
  EXPECT_NEAR(fb.f[kFeatOutField], 1.0f, 1e-6f) << "green all around";
  EXPECT_GT(fb.f[kFeatEdgeFraction], 0.9f);
  EXPECT_NEAR(fb.f[kFeatInTexture], 0.0f, 1e-6f) << "a flat disc has no texture";
  EXPECT_GT(fr.f[kFeatInTexture], 0.3f);
  // Cut by the border: samples outside the image are left out, not read.
  c.u_px = 2;
  c.u_min = 0;
  ComputeBallFeatures(ball.view(), lut, c, fb);
  EXPECT_EQ(fb.f[kFeatCut], 1.0f);
  for (float f : fb.f) EXPECT_TRUE(std::isfinite(f));
}

BallClassifierWeights SmallWeights() {
  BallClassifierWeights w;
  w.hidden = 2;
  for (int i = 0; i < kBallFeatureCount; ++i) {
    w.in_mean[i] = 0.5f;
    w.in_scale[i] = 32.0f;
  }
  w.w1[0][kFeatInBall] = 100;   // unit 0: ball-coloured inside
  w.w1[1][kFeatOutBall] = 100;  // unit 1: the colour goes on outside
  w.s1 = 0.01f;
  w.w2[0] = 50;
  w.w2[1] = -50;
  w.b2 = -10;
  w.s2 = 0.02f;
  w.threshold_logit = 0.5f;
  return w;
}

TEST(BallClassifierTest, BlobRoundTripAndTheInt8NetworkItHolds) {
  const BallClassifierWeights w = SmallWeights();
  std::vector<uint8_t> blob(kBallClassifierBlobMaxBytes);
  const Result<size_t> n = SerializeBallClassifier(w, blob);
  ASSERT_TRUE(n.ok());
  blob.resize(*n);
  EXPECT_EQ(*n, 16 + BallClassifierPayloadBytes(2));
  BallClassifier c;
  ASSERT_TRUE(c.Parse(blob).ok());
  EXPECT_TRUE(c.loaded());
  EXPECT_NE(c.id(), 0u);
  BallFeatures ball, shirt;
  ball.f[kFeatInBall] = 1.0f;  // x = 16: unit 0 acc 1600 -> 16, logit (50*16 - 10) * 0.02
  shirt.f[kFeatInBall] = 1.0f;
  shirt.f[kFeatOutBall] = 1.0f;  // unit 1 as strong: it cancels
  EXPECT_NEAR(c.Logit(ball), (50 * 16 - 10) * 0.02f, 1e-4f);
  EXPECT_NEAR(c.Logit(shirt), -10 * 0.02f, 1e-4f);
  EXPECT_GT(c.Logit(ball), c.threshold_logit());
  EXPECT_LT(c.Logit(shirt), c.threshold_logit());
}

TEST(BallClassifierTest, BadBlobsAreRefusedAndTheWeightsInUseStay) {
  std::vector<uint8_t> good(kBallClassifierBlobMaxBytes);
  const Result<size_t> n = SerializeBallClassifier(SmallWeights(), good);
  ASSERT_TRUE(n.ok());
  good.resize(*n);
  BallClassifier c;
  ASSERT_TRUE(c.Parse(BuiltInBallClassifierBlob()).ok()) << "the built-in weights parse";
  const uint32_t before = c.id();
  std::vector<uint8_t> b = good;
  b.resize(b.size() - 3);  // wrong size (truncated)
  EXPECT_EQ(c.Parse(b).code(), StatusCode::kDataLoss);
  b = good;
  b[16 + 40] ^= 0x10;  // CRC
  EXPECT_EQ(c.Parse(b).code(), StatusCode::kDataLoss);
  b = good;
  b[6] = kBallClassifierBlobVersion + 1;  // newer version
  EXPECT_EQ(c.Parse(b).code(), StatusCode::kUnimplemented);
  b = good;
  b[4] = static_cast<uint8_t>(BlobKind::kColorLut);  // another kind
  EXPECT_EQ(c.Parse(b).code(), StatusCode::kInvalidArgument);
  // Valid CRC around bad contents.
  std::vector<uint8_t> payload(good.begin() + 16, good.end()), wrapped(good.size() + 64);
  payload[1] = kBallFeatureCount + 1;  // another feature set
  ASSERT_TRUE(WriteBlob(BlobKind::kBallClassifier, 1, payload, wrapped).ok());
  EXPECT_EQ(c.Parse(std::span(wrapped).first(good.size())).code(), StatusCode::kInvalidArgument);
  payload[1] = kBallFeatureCount;
  payload[2] = 3;  // hidden units that do not match the payload's size
  ASSERT_TRUE(WriteBlob(BlobKind::kBallClassifier, 1, payload, wrapped).ok());
  EXPECT_EQ(c.Parse(std::span(wrapped).first(good.size())).code(), StatusCode::kInvalidArgument);
  payload[2] = 2;
  const float nan = std::nanf("");
  std::memcpy(payload.data() + 4, &nan, 4);  // in_mean[0]
  ASSERT_TRUE(WriteBlob(BlobKind::kBallClassifier, 1, payload, wrapped).ok());
  EXPECT_EQ(c.Parse(std::span(wrapped).first(good.size())).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(c.id(), before) << "a refused blob leaves the weights in use";
  BallClassifierWeights w = SmallWeights();
  w.s1 = -1;
  EXPECT_EQ(SerializeBallClassifier(w, good).status().code(), StatusCode::kInvalidArgument);
  w = SmallWeights();
  w.s2 = 3e38f;  // finite, but the logit would not be
  EXPECT_EQ(SerializeBallClassifier(w, good).status().code(), StatusCode::kInvalidArgument);
  w = SmallWeights();
  w.b1[1] = INT32_MAX;  // the int32 sums would overflow
  EXPECT_EQ(SerializeBallClassifier(w, good).status().code(), StatusCode::kInvalidArgument);
}

TEST(BallClassifierTest, AnyAcceptedNetworkGivesAFiniteLogitEvenOnANanFeature) {
  BallClassifierWeights w = SmallWeights();
  w.s1 = w.s2 = 1e6f;  // the largest scales and biases it accepts
  w.b1[0] = w.b2 = 1 << 24;
  for (auto& row : w.w1)
    for (int8_t& x : row) x = 127;
  for (int8_t& x : w.w2) x = 127;
  std::vector<uint8_t> blob(kBallClassifierBlobMaxBytes);
  const Result<size_t> n = SerializeBallClassifier(w, blob);
  ASSERT_TRUE(n.ok());
  BallClassifier c;
  ASSERT_TRUE(c.Parse(std::span(blob).first(*n)).ok());
  BallFeatures f;
  for (float& x : f.f) x = 1e30f;
  EXPECT_TRUE(std::isfinite(c.Logit(f)));
  f.f[kFeatInBall] = std::nanf("");
  EXPECT_TRUE(std::isfinite(c.Logit(f)));
}

// The classifier holding w as the device loads it: serialised, then parsed.
void Load(const BallClassifierWeights& w, BallClassifier& c) {
  std::vector<uint8_t> blob(kBallClassifierBlobMaxBytes);
  const Result<size_t> n = SerializeBallClassifier(w, blob);
  ASSERT_TRUE(n.ok());
  ASSERT_TRUE(c.Parse(std::span(blob).first(*n)).ok());
}

TEST(BallCheckTest, APlaceRefusalNeedsNoPixelsAndTheTrackBonusKeepsABorderlineBall) {
  const RigCalibration cal = RefCalibration();
  BallGeometry g;
  ASSERT_TRUE(g.SetPersp(cal.persp, BallGeometryConfig{}).ok());
  BallClassifier c;
  BallClassifierWeights w = SmallWeights();
  w.threshold_logit = 100;  // nothing passes on its look alone
  ASSERT_NO_FATAL_FAILURE(Load(w, c));
  BallCheck check;
  check.Init(&g, &c, BallCheckConfig{});
  ASSERT_TRUE(check.active());
  Canvas img(640, 480, Yuv{90, 100, 90});
  ColorLut lut;
  lut.Fill(ColorClass::kField);
  const CandidateShape lamp = Seen(cal.persp, {1.0f, 12.0f, 8.0f}, 0.15f);
  const CandidateVerdict v = check.Evaluate(img.view(), lut, lamp);
  EXPECT_FALSE(v.pass);
  EXPECT_EQ(v.place, PlaceVerdict::kTooHigh);
  EXPECT_EQ(v.pixels_read, 0u);
  const CandidateShape ball = Seen(cal.persp, {0.3f, 3.0f, 0.11f}, 0.11f);
  EXPECT_FALSE(check.Evaluate(img.view(), lut, ball).pass);
  EXPECT_TRUE(check.Evaluate(img.view(), lut, ball, nullptr, 200.0f).pass);
}

// A tracked candidate's bonus that no logit can offset decides without the features: the same
// verdict and score as the full look, no pixel read. A bonus within reach of the logit still looks.
TEST(BallCheckTest, ABonusNoLogitCanOffsetDecidesWithoutReadingPixels) {
  const RigCalibration cal = RefCalibration();
  BallGeometry g;
  ASSERT_TRUE(g.SetPersp(cal.persp, BallGeometryConfig{}).ok());
  BallClassifier c;
  ASSERT_NO_FATAL_FAILURE(Load(SmallWeights(), c));
  const float bound = c.MaxAbsLogit();
  EXPECT_NEAR(bound, 0.02f * (10 + 127 * (50 + 50)), 1e-3f);
  uint32_t seed = 12345;
  for (int t = 0; t < 2000; ++t) {
    BallFeatures f;
    for (float& x : f.f) {
      seed = seed * 1664525u + 1013904223u;
      x = static_cast<float>(seed >> 8) / 16777216.0f * 20.0f - 10.0f;
    }
    ASSERT_LE(std::fabs(c.Logit(f)), bound);
  }
  BallCheck check;
  check.Init(&g, &c, BallCheckConfig{});
  Canvas img(640, 480, Yuv{90, 100, 90});
  ColorLut lut;
  lut.Fill(ColorClass::kField);
  const CandidateShape ball = Seen(cal.persp, {0.3f, 3.0f, 0.11f}, 0.11f);
  const float sure = bound + 1000.0f;
  BallFeatures feat;
  const CandidateVerdict full = check.Evaluate(img.view(), lut, ball, &feat, sure);
  const CandidateVerdict fast = check.Evaluate(img.view(), lut, ball, nullptr, sure);
  EXPECT_TRUE(full.pass);
  EXPECT_EQ(fast.pass, full.pass);
  EXPECT_EQ(fast.score, full.score);
  EXPECT_EQ(fast.classified, full.classified);
  EXPECT_GT(full.pixels_read, 0u);
  EXPECT_EQ(fast.pixels_read, 0u);
  EXPECT_GT(check.Evaluate(img.view(), lut, ball, nullptr, bound).pixels_read, 0u)
      << "a bonus a logit can offset: the look decides";
}

}  // namespace
}  // namespace bv
