// core/field: the field model against an independent distance computation, the localiser on
// synthetic line points (global start, symmetry and the half hint, kidnap, no lines, a wrong
// hint, ambiguous views, NaN), and the feature extractor on a synthetic omni image painted
// through the reference rig's calibration.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <functional>
#include <memory>
#include <random>
#include <vector>

#include "core/field/features.h"
#include "core/field/field_model.h"
#include "core/field/localise.h"
#include "tools/ballvision/calib_io.h"

namespace bv {
namespace {

constexpr double kPi = 3.14159265358979;

// --- an independent model of the default MSL field (double precision, all primitives) ---
double SegDist(double px, double py, double ax, double ay, double bx, double by) {
  const double dx = bx - ax, dy = by - ay;
  const double t = std::clamp(((px - ax) * dx + (py - ay) * dy) / (dx * dx + dy * dy), 0.0, 1.0);
  return std::hypot(px - ax - t * dx, py - ay - t * dy);
}

// Lines lie inside the areas they bound: each centre half a line width (0.0625 m) inside.
double BruteDistance(double x, double y) {
  constexpr double h = 0.0625;
  double d = 1e9;
  for (double sx : {-1.0, 1.0}) {
    for (double sy : {-1.0, 1.0}) {
      d = std::min(d, SegDist(x, y, -(9 - h), (6 - h) * sy, 9 - h, (6 - h) * sy));  // touchlines
      d = std::min(d, SegDist(x, y, (9 - h) * sx, -(6 - h), (9 - h) * sx, 6 - h));  // goal lines
      const double pa = 6.75 + h, pw = 3.25 - h, ga = 8.25 + h, gw = 1.75 - h;
      d = std::min(d, SegDist(x, y, pa * sx, -pw, pa * sx, pw));
      d = std::min(d, SegDist(x, y, pa * sx, pw * sy, (9 - h) * sx, pw * sy));
      d = std::min(d, SegDist(x, y, ga * sx, -gw, ga * sx, gw));
      d = std::min(d, SegDist(x, y, ga * sx, gw * sy, (9 - h) * sx, gw * sy));
      d = std::min(d, std::hypot(x - 6 * sx, y));  // penalty marks
      // Corner arcs (radius 0.75 to the outer edge): the quarter inside the field.
      const double cx = 9 * sx, cy = 6 * sy, r = 0.75 - h;
      const double a = std::atan2(y - cy, x - cx);
      const double qx = std::cos(a), qy = std::sin(a);
      if (qx * sx <= 1e-9 && qy * sy <= 1e-9) {
        d = std::min(d, std::fabs(std::hypot(x - cx, y - cy) - r));
      } else {
        d = std::min(d, std::hypot(x - (cx - r * sx), y - cy));
        d = std::min(d, std::hypot(x - cx, y - (cy - r * sy)));
      }
    }
  }
  d = std::min(d, SegDist(x, y, 0, -(6 - h), 0, 6 - h));     // halfway line
  d = std::min(d, std::fabs(std::hypot(x, y) - (2.0 - h)));  // centre circle
  return d;
}

TEST(FieldModelTest, DistanceMatchesAnIndependentModelEverywhere) {
  auto m = std::make_unique<FieldModel>();
  ASSERT_TRUE(m->Init(FieldConfig{}).ok());
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> ux(-10.4, 10.4), uy(-7.4, 7.4);
  double worst = 0;
  for (int i = 0; i < 20000; ++i) {
    const double x = ux(rng), y = uy(rng);
    float gx, gy;
    const double d = m->Distance(static_cast<float>(x), static_cast<float>(y), gx, gy);
    // The table picks the nearest primitive per 10 cm cell: near a boundary between two
    // primitives it may take the other, whose distance differs by at most a cell diagonal.
    worst = std::max(worst, d - BruteDistance(x, y));
    ASSERT_GE(d, BruteDistance(x, y) - 1e-4) << x << " " << y;
  }
  EXPECT_LT(worst, 0.15);
  // On the lines: exact zeros; the gradient points away from the line.
  float gx, gy;
  // Lines are painted inside the areas they bound: the goal line's centre at 9 - 0.0625.
  EXPECT_NEAR(m->Distance(8.9375f, 2.5f, gx, gy), 0.0f, 1e-5f);
  EXPECT_NEAR(m->Distance(9.0f, 2.5f, gx, gy), 0.0625f, 1e-5f);
  EXPECT_NEAR(m->Distance(0.0f, -4.0f, gx, gy), 0.0f, 1e-5f);
  EXPECT_NEAR(m->Distance(1.9375f * std::cos(1.0f), -1.9375f * std::sin(1.0f), gx, gy), 0.0f,
              1e-5f);
  EXPECT_NEAR(m->Distance(-8.5f, 0.5f, gx, gy), 0.1875f, 1e-5f);  // goal area line at -8.3125
  EXPECT_NEAR(gx, -1.0f, 1e-5f);
  EXPECT_NEAR(gy, 0.0f, 1e-5f);
  EXPECT_NEAR(m->Distance(3.2f, 0.0f, gx, gy), 1.2625f, 1e-5f);  // the circle beats the mark
}

TEST(FieldModelTest, InconsistentConfigurationsAreRefusedWithTheirReason) {
  FieldConfig f;
  EXPECT_TRUE(ValidateFieldConfig(f).ok());
  const auto refused = [](FieldConfig c) {
    auto m = std::make_unique<FieldModel>();
    const Status st = m->Init(c);
    EXPECT_FALSE(m->ready());
    return st.code() == StatusCode::kInvalidArgument ? std::string(st.message()) : std::string();
  };
  f.length_m = -18;
  EXPECT_NE(refused(f).find("length"), std::string::npos);
  f = FieldConfig{};
  f.penalty_area_width_m = 13;
  EXPECT_NE(refused(f).find("field.penalty_area_width_m"), std::string::npos);
  f = FieldConfig{};
  f.goal_area_width_m = 7;
  EXPECT_NE(refused(f).find("field.goal_area_width_m"), std::string::npos);
  f = FieldConfig{};
  f.center_circle_radius_m = 7;
  EXPECT_NE(refused(f).find("field.center_circle_radius_m"), std::string::npos);
  f = FieldConfig{};
  f.width_m = NAN;
  EXPECT_FALSE(refused(f).empty());
  f = FieldConfig{};
  f.line_width_m = 0;
  EXPECT_FALSE(refused(f).empty());
  f = FieldConfig{};
  f.goal_depth_m = NAN;
  EXPECT_NE(refused(f).find("field.goal_depth_m"), std::string::npos);
  f = FieldConfig{};
  f.goal_height_m = 4;
  EXPECT_NE(refused(f).find("field.goal_height_m"), std::string::npos);
}

// --- synthetic line points as the extractor would report them from a pose ---
struct Pose {
  double x, y, h;
};

void ToRobot(const Pose& p, double fx, double fy, double& rx, double& ry) {
  const double dx = fx - p.x, dy = fy - p.y, s = std::sin(p.h), c = std::cos(p.h);
  rx = dx * s - dy * c;  // inverse of field = pose + rx (s, -c) + ry (c, s)
  ry = dx * c + dy * s;
}

// Points every 10 cm along every line within 5 m, as seen from the pose, with noise.
void MakeLinePoints(const Pose& p, std::mt19937& rng, FieldFeatures& f, double noise_m = 0.02) {
  std::normal_distribution<double> n(0.0, noise_m);
  f.line_count = 0;
  std::vector<std::pair<double, double>> pts;
  const auto seg = [&](double ax, double ay, double bx, double by) {
    const double len = std::hypot(bx - ax, by - ay);
    for (double t = 0; t <= len; t += 0.1)
      pts.push_back({ax + (bx - ax) * t / len, ay + (by - ay) * t / len});
  };
  // Line centres, half a line width inside the areas they bound (as painted).
  constexpr double h = 0.0625, L = 9 - h, W = 6 - h, pa = 6.75 + h, pw = 3.25 - h, ga = 8.25 + h,
                   gw = 1.75 - h;
  for (double s : {-1.0, 1.0}) {
    seg(-L, W * s, L, W * s);
    seg(L * s, -W, L * s, W);
    seg(pa * s, -pw, pa * s, pw);
    seg(pa * s, pw, L * s, pw);
    seg(pa * s, -pw, L * s, -pw);
    seg(ga * s, -gw, ga * s, gw);
    seg(ga * s, gw, L * s, gw);
    seg(ga * s, -gw, L * s, -gw);
  }
  seg(0, -W, 0, W);
  for (double a = 0; a < 2 * kPi; a += 0.05)
    pts.push_back({(2 - h) * std::cos(a), (2 - h) * std::sin(a)});
  std::vector<LinePoint> seen;
  for (const auto& q : pts) {
    double rx, ry;
    ToRobot(p, q.first, q.second, rx, ry);
    const double d = std::hypot(rx, ry);
    if (d < 0.4 || d > 5.0) continue;
    LinePoint lp;
    lp.x_m = static_cast<float>(rx + n(rng));
    lp.y_m = static_cast<float>(ry + n(rng));
    double a = std::atan2(ry, rx);
    if (a < 0) a += 2 * kPi;
    lp.ray = static_cast<uint8_t>(static_cast<int>(a / (2 * kPi) * 64) % 64);
    seen.push_back(lp);
  }
  std::sort(seen.begin(), seen.end(),
            [](const LinePoint& a, const LinePoint& b) { return a.ray < b.ray; });
  // The extractor reports about one point per ray and line crossing: thin out to ~60.
  const size_t step = std::max<size_t>(1, seen.size() / 60);
  for (size_t i = 0; i < seen.size() && f.line_count < FieldFeatures::kMaxLinePoints; i += step) {
    f.lines[f.line_count++] = seen[i];
  }
}

// Frames of a global search: 2106 grid poses at up to 100 and 1200 scored points a frame (the
// first frames score every pose in full, ~50 a frame; later most are pruned after a few points),
// then 12 candidates refined 2 a frame (6 frames): about 1.1 s at 30 Hz; 36 frames leave room.
constexpr int kSearchFrames = 36;

struct Loc {
  std::unique_ptr<FieldModel> model = std::make_unique<FieldModel>();
  std::unique_ptr<Localiser> loc = std::make_unique<Localiser>();
  std::unique_ptr<FieldFeatures> f = std::make_unique<FieldFeatures>();
  std::mt19937 rng{11};
  uint64_t t = 0;
  Loc() {
    EXPECT_TRUE(model->Init(FieldConfig{}).ok());
    EXPECT_TRUE(loc->Init(model.get(), LocaliserConfig{}).ok());
  }
  void Step(const Pose& p, int frames) {
    for (int i = 0; i < frames; ++i) {
      MakeLinePoints(p, rng, *f);
      t += 33333;
      loc->Update(*f, t, nullptr);
    }
  }
  // Pose error, allowing the point-symmetric twin while the estimate says it is ambiguous.
  std::pair<double, double> Error(const Pose& p) const {
    const PoseEstimate& e = loc->pose();
    const auto err = [&](double x, double y, double h) {
      double dh = std::fmod(std::fabs(h - p.h), 2 * kPi);
      if (dh > kPi) dh = 2 * kPi - dh;
      return std::make_pair(std::hypot(x - p.x, y - p.y), dh);
    };
    auto a = err(e.x_m, e.y_m, e.heading_rad);
    if (e.ambiguous) {
      const auto b = err(-e.x_m, -e.y_m, e.heading_rad + kPi);
      if (b.first < a.first) a = b;
    }
    return a;
  }
};

TEST(LocaliserTest, FindsThePoseFromAnUnknownStartAcrossTheField) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> ux(-8.0, 8.0), uy(-5.5, 5.5), uh(-kPi, kPi);
  int converged = 0;
  for (int k = 0; k < 12; ++k) {
    Loc l;
    const Pose p{ux(rng), uy(rng), uh(rng)};
    l.Step(p, kSearchFrames);
    if (!l.loc->pose().usable()) continue;
    const auto e = l.Error(p);
    EXPECT_LT(e.first, 0.05) << p.x << " " << p.y << " " << p.h;
    EXPECT_LT(e.second, 0.02);
    EXPECT_TRUE(l.loc->pose().ambiguous);
    converged += e.first < 0.05;
  }
  // A view may be ambiguous (a corner: four look alike); most are not.
  EXPECT_GE(converged, 10);
}

TEST(LocaliserTest, HalfHintResolvesTheSymmetryAndTrackingKeepsIt) {
  Loc l;
  const Pose p{-4.2, 2.1, 0.7};
  ASSERT_TRUE(l.loc->SetHint(PoseHint{false, 0, 0, 0, -1}).ok());
  l.Step(p, kSearchFrames);
  ASSERT_TRUE(l.loc->pose().usable());
  EXPECT_FALSE(l.loc->pose().ambiguous);
  EXPECT_NEAR(l.loc->pose().x_m, p.x, 0.05);
  EXPECT_NEAR(l.loc->pose().y_m, p.y, 0.05);
  // The robot drives (no odometry sent): tracking follows 3 cm a frame.
  Pose q = p;
  for (int i = 0; i < 30; ++i) {
    q.x += 0.03;
    l.Step(q, 1);
  }
  EXPECT_FALSE(l.loc->pose().ambiguous);
  EXPECT_NEAR(l.loc->pose().x_m, q.x, 0.06);
  EXPECT_NEAR(l.loc->pose().y_m, q.y, 0.06);
  EXPECT_GT(l.loc->pose().quality, 0.5f);
}

TEST(LocaliserTest, KidnappedRobotIsRelocalised) {
  Loc l;
  const Pose a{3.0, 1.0, 0.3}, b{-5.0, -2.5, 2.0};
  l.Step(a, kSearchFrames);
  ASSERT_LT(l.Error(a).first, 0.05);
  l.Step(b, 20 + kSearchFrames);  // 20 bad frames to give up, then a global search
  ASSERT_TRUE(l.loc->pose().usable());
  EXPECT_LT(l.Error(b).first, 0.05);
}

TEST(LocaliserTest, NoLinesCoastsWithGrowingUncertainty) {
  Loc l;
  const Pose p{2.0, -3.0, 1.0};
  l.Step(p, kSearchFrames);
  ASSERT_TRUE(l.loc->pose().usable());
  float last = l.loc->pose().sigma_x_m;
  l.f->line_count = 0;
  for (int i = 0; i < 30; ++i) {
    l.t += 33333;
    l.loc->Update(*l.f, l.t, nullptr);
    EXPECT_EQ(l.loc->pose().state, PoseEstimate::kCoasting);
    EXPECT_GT(l.loc->pose().sigma_x_m, last);
    last = l.loc->pose().sigma_x_m;
  }
  EXPECT_GT(last, LocaliserConfig{}.usable_sigma_m);  // after 1 s: too uncertain for the rule
  EXPECT_NEAR(l.loc->pose().x_m, p.x, 0.05);          // coasting never moves the pose
}

TEST(LocaliserTest, AHintThatContradictsTheLinesIsRejected) {
  Loc l;
  const Pose p{-6.0, 4.0, -0.5};
  l.Step(p, kSearchFrames);
  ASSERT_LT(l.Error(p).first, 0.05);
  ASSERT_TRUE(l.loc->SetHint(PoseHint{true, 1.0f, 1.0f, 2.0f, 0}).ok());
  l.Step(p, 1);
  EXPECT_TRUE(l.loc->pose().hint_rejected);
  EXPECT_LT(l.Error(p).first, 0.05);
  // A hint that the lines confirm seeds the pose and resolves the symmetry.
  ASSERT_TRUE(l.loc->SetHint(PoseHint{true, -5.9f, 4.1f, -0.45f, 0}).ok());
  l.Step(p, 1);
  EXPECT_FALSE(l.loc->pose().hint_rejected);
  EXPECT_FALSE(l.loc->pose().ambiguous);
  EXPECT_NEAR(l.loc->pose().x_m, p.x, 0.05);
  EXPECT_FALSE(l.loc->SetHint(PoseHint{true, NAN, 0, 0, 0}).ok());
  EXPECT_FALSE(l.loc->SetHint(PoseHint{false, 0, 0, 0, 3}).ok());
}

TEST(LocaliserTest, TwoLinesAloneGiveNoPose) {
  // One corner's two lines fit all four corners: no pose rather than a guess.
  Loc l;
  for (int i = 0; i < 30; ++i) {
    l.f->line_count = 0;
    for (int k = 0; k < 40; ++k) {
      LinePoint a;
      a.x_m = 1.0f;
      a.y_m = -2.0f + 0.1f * static_cast<float>(k);
      a.ray = static_cast<uint8_t>(k);
      l.f->lines[l.f->line_count++] = a;
    }
    for (int k = 0; k < 40; ++k) {
      LinePoint a;
      a.x_m = -2.0f + 0.075f * static_cast<float>(k);
      a.y_m = 2.0f;
      a.ray = static_cast<uint8_t>(k);
      l.f->lines[l.f->line_count++] = a;
    }
    l.t += 33333;
    l.loc->Update(*l.f, l.t, nullptr);
  }
  EXPECT_FALSE(l.loc->pose().usable());
}

TEST(LocaliserTest, NanPointsNeverMakeANanPose) {
  Loc l;
  const Pose p{1.5, 2.5, -2.0};
  for (int i = 0; i < kSearchFrames + 5; ++i) {
    MakeLinePoints(p, l.rng, *l.f);
    for (int k = 0; k < l.f->line_count; k += 5) l.f->lines[k].x_m = NAN;
    l.t += 33333;
    l.loc->Update(*l.f, l.t, nullptr);
  }
  const PoseEstimate& e = l.loc->pose();
  EXPECT_TRUE(std::isfinite(e.x_m) && std::isfinite(e.y_m) && std::isfinite(e.heading_rad));
  EXPECT_TRUE(std::isfinite(e.sigma_x_m));
  ASSERT_TRUE(e.usable());
  EXPECT_LT(l.Error(p).first, 0.05);
}

// --- the extractor on a synthetic omni image through the reference calibration ---
class FeatureImageTest : public ::testing::Test {
 protected:
  static constexpr double kLineX = 1.0;                   // a line along y at x = 1 m
  static constexpr double kRobotX = -1.5, kRobotY = 1.5;  // an obstacle, radius 0.26 m
  static constexpr double kRobotR = 0.26;
  void SetUp() override {
    std::string err;
    ASSERT_TRUE(cli::LoadCalibrationFile(
        std::string(BV_TEST_DATA_DIR) + "/reference_rig_calib.json", cal_, err))
        << err;
    for (uint32_t i = 0; i < ColorLut::kEntries; ++i) {
      uint8_t y, u, v;
      ColorLut::CellCenter(i, y, u, v);
      ColorClass c = ColorClass::kUnknown;
      if (u < 112 && v < 112) c = ColorClass::kField;
      if (u >= 120 && u <= 136 && v >= 120 && v <= 136) {
        c = y >= 180 ? ColorClass::kLine : (y < 40 ? ColorClass::kObstacle : c);
      }
      lut_->Set(i, c);
    }
    scan_ = ReferenceOmniScanConfig(cal_.omni.center_u, cal_.omni.center_v);
    scan_.features.rays = 64;
    scan_.features.end_radius_px = 178;
    scan_.features.step_inner_px = 3;
    scan_.features.step_outer_px = 1;
    Paint(&Scene);
  }
  // Y per pixel; chroma per YUYV pair: green when either pixel of the pair is field.
  void Paint(const std::function<uint8_t(double gx, double gy)>& shade) {
    img_.assign(kFrameBytes, 128);
    for (int v = 0; v < kFrameHeight; ++v) {
      for (int u = 0; u < kFrameWidth; u += 2) {
        uint8_t* px = &img_[(static_cast<size_t>(v) * kFrameWidth + u) * 2];
        bool green = false;
        for (int k = 0; k < 2; ++k) {
          float gx, gy;
          uint8_t y = 90;  // beyond the map: grey
          if (OmniPixelToGround(cal_.omni, static_cast<float>(u + k), static_cast<float>(v), gx, gy)
                  .ok()) {
            y = shade(gx, gy);
          }
          px[2 * k] = y;
          green |= y == kGreenY;
        }
        px[1] = px[3] = green ? 90 : 128;
      }
    }
  }
  static uint8_t Scene(double gx, double gy) {
    const double d = std::hypot(gx, gy), b = std::atan2(gy, gx);
    const double dc = std::hypot(kRobotX, kRobotY), bc = std::atan2(kRobotY, kRobotX);
    const double half = std::asin(kRobotR / dc);
    double db = std::fabs(b - bc);
    if (db > kPi) db = 2 * kPi - db;
    if (db < half && d >= dc - kRobotR * std::cos(db / half * kPi / 2)) return 20;  // robot
    if (std::fabs(gx - kLineX) <= 0.0625) return 230;
    return kGreenY;
  }
  static constexpr uint8_t kGreenY = 100;
  YuyvImage view() const { return MakeYuyvImage(img_.data(), kFrameWidth, kFrameHeight); }
  // Extracts from the painted image with scan_: one obstacle, the robot.
  void ExtractFindingTheRobot(FieldFeatures& f) const {
    auto ex = std::make_unique<FieldFeatureExtractor>();
    auto walk = std::make_unique<FieldFeatureWalk>();
    ASSERT_TRUE(ex->Init(scan_, cal_.omni, FieldFeatureConfig{}, *walk).ok());
    ASSERT_TRUE(ex->Extract(view(), *lut_, f).ok());
    ASSERT_EQ(f.obstacle_count, 1);
    EXPECT_NEAR(f.obstacles[0].x_m, kRobotX, 0.15);
    EXPECT_NEAR(f.obstacles[0].y_m, kRobotY, 0.15);
    EXPECT_NEAR(f.obstacles[0].radius_m, kRobotR, 0.1);
  }

  RigCalibration cal_;
  std::unique_ptr<ColorLut> lut_ = std::make_unique<ColorLut>();
  OmniScanConfig scan_;
  std::vector<uint8_t> img_;
};

TEST_F(FeatureImageTest, LinePointsLieOnTheLineAndTheObstacleIsFound) {
  auto ex = std::make_unique<FieldFeatureExtractor>();
  auto walk = std::make_unique<FieldFeatureWalk>();
  ASSERT_TRUE(ex->Init(scan_, cal_.omni, FieldFeatureConfig{}, *walk).ok());
  auto f = std::make_unique<FieldFeatures>();
  ASSERT_TRUE(ex->Extract(view(), *lut_, *f).ok());
  ASSERT_GE(f->line_count, 8);
  for (int i = 0; i < f->line_count; ++i) {
    EXPECT_NEAR(f->lines[i].x_m, kLineX, 0.06) << f->lines[i].y_m;
  }
  EXPECT_EQ(f->goal_count, 0);  // the carpet runs on behind the line: no goal
  ASSERT_EQ(f->obstacle_count, 1);
  EXPECT_NEAR(f->obstacles[0].x_m, kRobotX, 0.15);
  EXPECT_NEAR(f->obstacles[0].y_m, kRobotY, 0.15);
  EXPECT_NEAR(f->obstacles[0].radius_m, kRobotR, 0.1);
  EXPECT_GT(f->lookups, 0u);
}

// A robot standing right behind a line (a circle around us, 0.2 m wide so that it spans several
// samples as a line does farther out, its outer edge at the robot's foot): the rays see green, a
// few white samples, then the robot. It is found all the same; the line is still seen on the rays
// that miss the robot.
TEST_F(FeatureImageTest, ARobotRightBehindALineIsFound) {
  const double foot = std::hypot(kRobotX, kRobotY) - kRobotR;
  Paint([foot](double gx, double gy) -> uint8_t {
    const uint8_t robot_or_floor = Scene(gx, gy);
    if (robot_or_floor == 20) return 20;
    return std::fabs(std::hypot(gx, gy) - (foot - 0.1)) <= 0.1 ? 230 : kGreenY;
  });
  const auto f = std::make_unique<FieldFeatures>();
  ExtractFindingTheRobot(*f);
  ASSERT_GE(f->line_count, 20);
  for (int i = 0; i < f->line_count; ++i) {
    EXPECT_NEAR(std::hypot(f->lines[i].x_m, f->lines[i].y_m), foot - 0.1, 0.06);
  }
  EXPECT_EQ(f->goal_count, 0);
}

// A goal ahead: the goal line at x = 2.5 m, the goal's floor (carpet) 0.6 m deep behind it, then
// the net (unclassified grey) up to the image edge within the mouth's angle (back and side nets);
// beside the goal the carpet runs on. The same grey 2 m behind the line (the border's end) is no
// goal.
TEST_F(FeatureImageTest, AGoalIsFoundWhereTheCarpetEndsAGoalDepthBehindTheLine) {
  constexpr double kGoalX = 2.5;
  const auto goal_scene = [](double back_m) {
    return [back_m](double gx, double gy) -> uint8_t {
      if (std::fabs(gx - kGoalX) <= 0.0625) return 230;                    // goal line
      if (gx > kGoalX + back_m && std::fabs(gy) < gx / kGoalX) return 60;  // net
      return kGreenY;
    };
  };
  Paint(goal_scene(0.6));
  auto ex = std::make_unique<FieldFeatureExtractor>();
  auto walk = std::make_unique<FieldFeatureWalk>();
  ASSERT_TRUE(ex->Init(scan_, cal_.omni, FieldFeatureConfig{}, *walk).ok());
  auto f = std::make_unique<FieldFeatures>();
  ASSERT_TRUE(ex->Extract(view(), *lut_, *f).ok());
  ASSERT_EQ(f->goal_count, 1);
  const Goal& g = f->goals[0];
  EXPECT_NEAR(g.x_m, kGoalX, 0.15);
  EXPECT_NEAR(g.y_m, 0.0, 0.25);
  EXPECT_NEAR(g.distance_m, std::hypot(g.x_m, g.y_m), 1e-4);
  EXPECT_NEAR(g.bearing_rad, 0.0, 0.1);
  // The mouth spans +-atan(1 / 2.5) = +-21.8 deg; the range is the rays' plus half a ray.
  EXPECT_GT(g.half_width_rad, 0.25);
  EXPECT_LT(g.half_width_rad, 0.5);
  EXPECT_GE(g.rays, 4);
  EXPECT_EQ(g.which, 0);  // the extractor has no pose
  EXPECT_EQ(f->goals_dropped, 0u);
  // The same grey where the border ends (2 m behind the line): not a goal.
  Paint(goal_scene(2.0));
  ASSERT_TRUE(ex->Extract(view(), *lut_, *f).ok());
  EXPECT_EQ(f->goal_count, 0);
}

TEST_F(FeatureImageTest, BadFramesAndConfigurationsAreRefused) {
  auto ex = std::make_unique<FieldFeatureExtractor>();
  auto walk = std::make_unique<FieldFeatureWalk>();
  auto f = std::make_unique<FieldFeatures>();
  EXPECT_EQ(ex->Extract(view(), *lut_, *f).code(), StatusCode::kFailedPrecondition);
  OmniScanConfig none = scan_;
  none.features.rays = 0;
  EXPECT_EQ(ex->Init(none, cal_.omni, FieldFeatureConfig{}, *walk).code(),
            StatusCode::kInvalidArgument);
  none.features.rays = 48;  // not a power of two
  EXPECT_EQ(ex->Init(none, cal_.omni, FieldFeatureConfig{}, *walk).code(),
            StatusCode::kInvalidArgument);
  ASSERT_TRUE(ex->Init(scan_, cal_.omni, FieldFeatureConfig{}, *walk).ok());
  YuyvImage small = view();
  small.width = 320;
  EXPECT_EQ(ex->Extract(small, *lut_, *f).code(), StatusCode::kInvalidArgument);
  YuyvImage null = view();
  null.data = nullptr;
  EXPECT_EQ(ex->Extract(null, *lut_, *f).code(), StatusCode::kInvalidArgument);
  YuyvImage huge = view();
  huge.stride_bytes = 1 << 23;  // offsets past 31 bits
  EXPECT_EQ(ex->Extract(huge, *lut_, *f).code(), StatusCode::kInvalidArgument);
}

// A robot with one side behind a strut of our own (a mask sector over its edge, holding a feature
// ray; the strut itself dark in the middle of the sector): the ray is moved beside the sector, the
// robot is found where it stands, and its hidden side is not taken from the strut's dark pixels.
TEST_F(FeatureImageTest, ARobotHalfBehindOurOwnStrutIsFoundWhereItStands) {
  float ru = 0, rv = 0;
  ASSERT_TRUE(OmniGroundToPixel(cal_.omni, kRobotX, kRobotY, ru, rv).ok());
  const auto image_deg = [&](float u, float v) {
    return std::atan2(v - cal_.omni.center_v, u - cal_.omni.center_u) * 180.0 / kPi;
  };
  const double robot_deg = image_deg(ru, rv);
  const double half_deg = std::asin(kRobotR / std::hypot(kRobotX, kRobotY)) * 180.0 / kPi;
  const double strut_deg = robot_deg + half_deg;  // on the robot's edge
  const auto off = [](double a, double b) { return std::fabs(std::remainder(a - b, 360.0)); };
  scan_.strut_count = 1;
  scan_.struts[0] = {static_cast<float>(strut_deg), 3.0f};
  Paint([&](double gx, double gy) -> uint8_t {
    float u = 0, v = 0;
    if (OmniGroundToPixel(cal_.omni, static_cast<float>(gx), static_cast<float>(gy), u, v).ok() &&
        off(image_deg(u, v), strut_deg) <= 1.5) {
      return 20;  // the strut
    }
    return Scene(gx, gy);
  });
  int moved = 0;
  for (int i = 0; i < scan_.features.rays; ++i) {
    const double nominal = 360.0 * i / scan_.features.rays;
    if (off(nominal, strut_deg) > 3.0) continue;
    ++moved;
    EXPECT_FALSE(OmniFeatureRayBlocked(scan_, i)) << i;
    const double a = OmniFeatureRayAngle(scan_, i) * 180.0 / kPi;
    EXPECT_GT(off(a, strut_deg), 3.0) << i;
    EXPECT_LT(off(a, nominal), 0.5 * 360.0 / scan_.features.rays) << i;
  }
  ASSERT_GE(moved, 1);
  const auto f = std::make_unique<FieldFeatures>();
  ExtractFindingTheRobot(*f);
}

// The walk's offsets are for one stride: a frame with padded rows gets them rebuilt, and the
// same features.
TEST_F(FeatureImageTest, AnotherStrideGivesTheSameFeatures) {
  auto ex = std::make_unique<FieldFeatureExtractor>();
  auto walk = std::make_unique<FieldFeatureWalk>();
  ASSERT_TRUE(ex->Init(scan_, cal_.omni, FieldFeatureConfig{}, *walk).ok());
  const YuyvImage packed = view();
  const int stride = packed.stride_bytes + 96;
  std::vector<uint8_t> padded(static_cast<size_t>(stride) * packed.height, 0);
  for (int v = 0; v < packed.height; ++v) {
    std::memcpy(&padded[static_cast<size_t>(v) * stride],
                packed.data + static_cast<size_t>(v) * packed.stride_bytes, 2 * packed.width);
  }
  YuyvImage wide = packed;
  wide.data = padded.data();
  wide.stride_bytes = stride;
  auto a = std::make_unique<FieldFeatures>(), b = std::make_unique<FieldFeatures>();
  const auto same = [&] {
    ASSERT_GE(a->line_count, 8);
    ASSERT_EQ(a->line_count, b->line_count);
    ASSERT_EQ(a->obstacle_count, b->obstacle_count);
    for (int i = 0; i < a->line_count; ++i) {
      EXPECT_EQ(a->lines[i].x_m, b->lines[i].x_m);
      EXPECT_EQ(a->lines[i].y_m, b->lines[i].y_m);
    }
  };
  ASSERT_TRUE(ex->Extract(packed, *lut_, *a).ok());
  ASSERT_TRUE(ex->Extract(wide, *lut_, *b).ok());
  same();
  ASSERT_TRUE(ex->Extract(packed, *lut_, *b).ok());  // and back
  same();
}

TEST_F(FeatureImageTest, AFloodOfLinesIsBoundedAndCounted) {
  // White and green rings every 20 cm: far more crossings than the capacity.
  Paint([](double gx, double gy) -> uint8_t {
    return std::fmod(std::hypot(gx, gy), 0.2) < 0.08 ? 230 : kGreenY;
  });
  auto ex = std::make_unique<FieldFeatureExtractor>();
  auto walk = std::make_unique<FieldFeatureWalk>();
  ASSERT_TRUE(ex->Init(scan_, cal_.omni, FieldFeatureConfig{}, *walk).ok());
  auto f = std::make_unique<FieldFeatures>();
  ASSERT_TRUE(ex->Extract(view(), *lut_, *f).ok());
  EXPECT_EQ(f->line_count, FieldFeatures::kMaxLinePoints);
  EXPECT_GT(f->lines_dropped, 0u);
}

}  // namespace
}  // namespace bv
