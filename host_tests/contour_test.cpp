// Contour following and chain-code descriptors on synthetic shapes with known answers.
#include "core/contour/contour.h"

#include <gtest/gtest.h>

#include "host_tests/test_util.h"

#include <cmath>
#include <functional>
#include <memory>
#include <tuple>
#include <vector>

namespace bv {
namespace {

constexpr uint8_t kBallY = 200, kBackY = 50;

// Ball and background differ in Y only, so shapes are exact per pixel despite shared chroma.
struct Frame {
  int w = 640, h = 480;
  std::vector<uint8_t> data = std::vector<uint8_t>(640 * 480 * 2, 128);
  Frame() {
    for (size_t i = 0; i < data.size(); i += 2) data[i] = kBackY;
  }
  void Set(int u, int v, bool ball) {
    data[(static_cast<size_t>(v) * w + u) * 2] = ball ? kBallY : kBackY;
  }
  void Draw(const std::function<bool(int, int)>& inside) {
    for (int v = 0; v < h; ++v)
      for (int u = 0; u < w; ++u)
        if (inside(u, v)) Set(u, v, true);
  }
  YuyvImage view() const { return MakeYuyvImage(data.data(), w, h); }
};

const ColorLut& Lut() { return test::BrightIsBallLut(); }

using Set32 = RegionSet<32, 8192>;

TEST(ContourTest, RectangleHasExactDescriptors) {
  Frame f;
  f.Draw([](int u, int v) { return u >= 100 && u < 120 && v >= 50 && v < 60; });
  auto rs = std::make_unique<Set32>();
  ASSERT_EQ(rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, 110, 55), SeedOutcome::kNewRegion);
  ASSERT_EQ(rs->regions().size(), 1u);
  const Region& r = rs->regions()[0];
  EXPECT_FALSE(r.hole);
  EXPECT_EQ(r.start_u, 100);
  EXPECT_EQ(r.u_min, 100);
  EXPECT_EQ(r.u_max, 119);
  EXPECT_EQ(r.v_min, 50);
  EXPECT_EQ(r.v_max, 59);
  EXPECT_EQ(r.chain_length, 2u * 19 + 2 * 9);
  EXPECT_FLOAT_EQ(r.polygon_area_px, 19.0f * 9.0f);
  EXPECT_FLOAT_EQ(r.area_px, 200.0f);
  EXPECT_NEAR(r.cu_px, 109.5f, 1e-4);
  EXPECT_NEAR(r.cv_px, 54.5f, 1e-4);
  EXPECT_NEAR(r.perimeter_px, 0.980f * 56 - 0.091f * 4, 1e-3);
  // The chain closes.
  int du = 0, dv = 0;
  for (uint8_t c : rs->chain(r)) {
    du += kChainDu[c];
    dv += kChainDv[c];
  }
  EXPECT_EQ(du, 0);
  EXPECT_EQ(dv, 0);
}

TEST(ContourTest, DiscAreaCentroidPerimeterRoundness) {
  for (float radius : {3.0f, 6.5f, 12.0f, 30.0f}) {
    const float cx = 200.3f, cy = 150.7f;
    Frame f;
    int count = 0;
    double sx = 0, sy = 0;
    f.Draw([&](int u, int v) {
      const bool in = std::hypot(u - cx, v - cy) <= radius;
      if (in) ++count, sx += u, sy += v;
      return in;
    });
    auto rs = std::make_unique<Set32>();
    ASSERT_EQ(rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, 200, 151), SeedOutcome::kNewRegion);
    const Region& r = rs->regions()[0];
    EXPECT_FLOAT_EQ(r.area_px, static_cast<float>(count)) << radius;  // Pick's theorem, exact
    EXPECT_NEAR(r.cu_px, sx / count, 0.05) << radius;
    EXPECT_NEAR(r.cv_px, sy / count, 0.05) << radius;
    EXPECT_NEAR(r.cu_px, cx, 0.15) << radius;
    EXPECT_NEAR(r.cv_px, cy, 0.15) << radius;
    // The boundary pixel centres lie ~0.5 px inside the true circle.
    EXPECT_NEAR(r.perimeter_px, 2 * 3.14159f * (radius - 0.5f), 0.06f * 2 * 3.14159f * radius)
        << radius;
    EXPECT_GT(r.roundness, radius > 5 ? 0.9f : 0.8f) << radius;
  }
}

// The hull measures against their closed forms (disc 1 / 1, half disc 0.73 / 0.5, 3:1 bar
// 0.59 / 0.33), and a disc with a ragged outline: the chain-code roundness collapses, the hull
// roundness does not.
TEST(ContourTest, HullRoundnessAndWidthRatio) {
  struct Case {
    const char* name;
    std::function<bool(int, int)> inside;
    float hull, width;
  };
  const float cx = 300.4f, cy = 240.6f, r = 25.0f;
  const std::vector<Case> cases = {
      {"disc", [&](int u, int v) { return std::hypot(u - cx, v - cy) <= r; }, 0.97f, 1.0f},
      {"half disc", [&](int u, int v) { return std::hypot(u - cx, v - cy) <= r && u >= cx; }, 0.73f,
       0.5f},
      {"3:1 bar", [](int u, int v) { return u >= 250 && u < 340 && v >= 220 && v < 250; }, 0.59f,
       0.33f},
  };
  for (const Case& c : cases) {
    Frame f;
    f.Draw(c.inside);
    auto rs = std::make_unique<Set32>();
    ASSERT_EQ(rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, 310, 235), SeedOutcome::kNewRegion)
        << c.name;
    const Region& reg = rs->regions()[0];
    EXPECT_NEAR(reg.hull_roundness, c.hull, 0.04f) << c.name;
    EXPECT_NEAR(reg.width_ratio, c.width, 0.04f) << c.name;
  }
  // Ragged: every boundary pixel of the disc has its radius modulated by +-2 px at random.
  Frame f;
  uint32_t rng = 12345;
  std::vector<float> edge(64);
  for (float& e : edge) {
    rng = rng * 1664525u + 1013904223u;
    e = r - 2.0f + 4.0f * static_cast<float>(rng >> 8) / 16777216.0f;
  }
  f.Draw([&](int u, int v) {
    const float a = std::atan2(v - cy, u - cx) + 3.14159265f;
    return std::hypot(u - cx, v - cy) <= edge[static_cast<int>(a / 6.2832f * 63.999f)];
  });
  auto rs = std::make_unique<Set32>();
  ASSERT_EQ(rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, 300, 240), SeedOutcome::kNewRegion);
  const Region& reg = rs->regions()[0];
  EXPECT_LT(reg.roundness, 0.6f);
  EXPECT_GT(reg.hull_roundness, 0.85f);
  EXPECT_GT(reg.width_ratio, 0.9f);
}

TEST(ContourTest, RegionsBelowMinKeepAreaAreForgotten) {
  Frame f;
  f.Draw([](int u, int v) { return u >= 10 && u < 13 && v >= 10 && v < 13; });  // 9 px
  f.Draw([](int u, int v) { return u >= 50 && u < 54 && v >= 10 && v < 14; });  // 16 px
  auto rs = std::make_unique<Set32>();
  rs->set_min_keep_area(10.0f);
  EXPECT_EQ(rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, 11, 11), SeedOutcome::kTooSmall);
  EXPECT_EQ(rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, 12, 12), SeedOutcome::kTooSmall);
  EXPECT_EQ(rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, 51, 11), SeedOutcome::kNewRegion);
  ASSERT_EQ(rs->regions().size(), 1u);
  EXPECT_FLOAT_EQ(rs->regions()[0].area_px, 16.0f);
  EXPECT_EQ(rs->dropped_small(), 2u);
  EXPECT_EQ(rs->overflows(), 0u);
}

TEST(ContourTest, SinglePixelAndThinLine) {
  Frame f;
  f.Set(10, 10, true);
  f.Draw([](int u, int v) { return v == 100 && u >= 50 && u < 80; });
  f.Draw([](int u, int v) { return u - 300 == v - 200 && u >= 300 && u < 320; });  // diagonal
  auto rs = std::make_unique<Set32>();
  ASSERT_EQ(rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, 10, 10), SeedOutcome::kNewRegion);
  ASSERT_EQ(rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, 70, 100), SeedOutcome::kNewRegion);
  ASSERT_EQ(rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, 310, 210), SeedOutcome::kNewRegion);
  const auto regions = rs->regions();
  EXPECT_FLOAT_EQ(regions[0].area_px, 1.0f);
  EXPECT_EQ(regions[0].chain_length, 0u);
  EXPECT_FLOAT_EQ(regions[1].area_px, 30.0f);
  EXPECT_NEAR(regions[1].cu_px, 64.5f, 1e-3);
  EXPECT_FLOAT_EQ(regions[1].roundness, 0.0f);
  EXPECT_FLOAT_EQ(regions[2].area_px, 20.0f);
  EXPECT_NEAR(regions[2].cu_px, 309.5f, 1e-3);
  EXPECT_NEAR(regions[2].cv_px, 209.5f, 1e-3);
}

TEST(ContourTest, EachRegionTracedOnceWhateverTheSeeds) {
  Frame f;
  // A U shape: seeds in both arms and the base belong to one region.
  f.Draw([](int u, int v) {
    return v >= 100 && v < 160 && u >= 100 && u < 160 && !(u >= 115 && u < 145 && v < 145);
  });
  auto rs = std::make_unique<Set32>();
  EXPECT_EQ(rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, 150, 110), SeedOutcome::kNewRegion);
  const uint32_t reads_after_first = rs->pixels_read();
  EXPECT_EQ(rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, 105, 110),
            SeedOutcome::kAlreadyTraced);
  EXPECT_EQ(rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, 130, 150),
            SeedOutcome::kAlreadyTraced);
  EXPECT_EQ(rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, 158, 140),
            SeedOutcome::kAlreadyTraced);
  EXPECT_EQ(rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, 130, 120), SeedOutcome::kNotInClass);
  EXPECT_EQ(rs->regions().size(), 1u);
  EXPECT_LT(rs->pixels_read() - reads_after_first, 200u);  // walks, no re-trace
  EXPECT_FLOAT_EQ(rs->regions()[0].area_px, 60.0f * 60.0f - 30.0f * 45.0f);
}

TEST(ContourTest, SeedsInAnyOrderFindTheirContourWhereverTheLastWalkStopped) {
  // A ring (one outer contour, one hole) with a disc in its hole. Seeds come down the rows, then
  // up, then at random, twice: every check walks on from where the last hit on that contour was
  // (wrapping past the chain's end); each contour is traced once, and the second pass traces none.
  Frame f;
  f.Draw([](int u, int v) {
    const float d = std::hypot(u - 300.0f, v - 240.0f);
    return (d <= 80.0f && d >= 40.0f) || d <= 10.0f;
  });
  std::vector<std::pair<int, int>> seeds;
  for (int v = 165; v <= 315; v += 3) seeds.push_back({370, v});
  for (int v = 315; v >= 165; v -= 3) seeds.push_back({375, v});
  uint32_t x = 99;
  for (int i = 0; i < 300; ++i) {
    x = x * 1664525u + 1013904223u;
    seeds.push_back({220 + static_cast<int>(x >> 8) % 161, 160 + static_cast<int>(x >> 20) % 161});
  }
  auto rs = std::make_unique<Set32>();
  int new_regions = 0;
  for (const auto& [u, v] : seeds)
    new_regions +=
        rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, u, v) == SeedOutcome::kNewRegion;
  ASSERT_EQ(rs->regions().size(), 3u);  // the ring, its hole, the disc
  EXPECT_EQ(new_regions, 2);
  int holes = 0;
  for (const Region& r : rs->regions()) holes += r.hole;
  EXPECT_EQ(holes, 1);
  int traced = 0;
  for (const auto& [u, v] : seeds) {
    const SeedOutcome o = rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, u, v);
    ASSERT_TRUE(o == SeedOutcome::kAlreadyTraced || o == SeedOutcome::kNotInClass) << u << "," << v;
    traced += o == SeedOutcome::kAlreadyTraced;
  }
  EXPECT_GT(traced, 100);
  EXPECT_EQ(rs->regions().size(), 3u);
}

TEST(ContourTest, HoleIsTracedOnceAndFilled) {
  const float cx = 320, cy = 240;
  Frame f;
  f.Draw([&](int u, int v) {
    const float d = std::hypot(u - cx, v - cy);
    return d <= 20.0f &&
           !(u >= 322 && u < 330 && v >= 236 && v < 244);  // highlight right of centre
  });
  auto rs = std::make_unique<Set32>();
  // Seed right of the highlight: walks left into the hole first.
  EXPECT_EQ(rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, 335, 240), SeedOutcome::kNewRegion);
  ASSERT_EQ(rs->regions().size(), 2u);
  EXPECT_TRUE(rs->regions()[0].hole);
  EXPECT_FALSE(rs->regions()[1].hole);
  EXPECT_NEAR(rs->regions()[1].cu_px, cx, 0.1);
  EXPECT_NEAR(rs->regions()[1].cv_px, cy, 0.1);
  // Another seed right of the hole: no new trace.
  EXPECT_EQ(rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, 333, 238),
            SeedOutcome::kAlreadyTraced);
  EXPECT_EQ(rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, 305, 240),
            SeedOutcome::kAlreadyTraced);
  EXPECT_EQ(rs->regions().size(), 2u);
}

TEST(ContourTest, CapacityOverflowIsReportedAndBounded) {
  Frame f;
  for (int i = 0; i < 40; ++i) f.Set(10 + 4 * i, 20, true);
  auto rs = std::make_unique<RegionSet<8, 8192>>();
  int full = 0;
  for (int i = 0; i < 40; ++i) {
    full += rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, 10 + 4 * i, 20) ==
            SeedOutcome::kRegionsFull;
  }
  EXPECT_EQ(rs->regions().size(), 8u);
  EXPECT_EQ(full, 32);
  EXPECT_EQ(rs->overflows(), 1u);

  Frame big;
  big.Draw([](int u, int v) { return u >= 100 && u < 300 && v >= 100 && v < 300; });
  auto small = std::make_unique<RegionSet<4, 64>>();
  EXPECT_EQ(small->TraceSeed(big.view(), Lut(), ColorClass::kBall, 200, 200),
            SeedOutcome::kChainFull);
  EXPECT_EQ(small->regions().size(), 0u);
  EXPECT_EQ(small->overflows(), 1u);
  small->Clear();
  EXPECT_EQ(small->overflows(), 0u);
}

TEST(ContourTest, WhenFullARounderRegionReplacesTheWeakestUnprotectedOne) {
  // Eight strips fill a set of 8 (the first two protected), then a disc and another strip come.
  Frame f;
  for (int i = 0; i < 9; ++i)
    for (int du = 0; du < 20 + i; ++du) f.Set(20 + du, 20 + 10 * i, true);
  f.Draw([](int u, int v) { return std::hypot(u - 300.0f, v - 300.0f) <= 10.0f; });
  auto rs = std::make_unique<RegionSet<8, 8192>>();
  for (int i = 0; i < 2; ++i)
    ASSERT_EQ(rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, 20, 20 + 10 * i),
              SeedOutcome::kNewRegion);
  rs->ProtectTraced();
  for (int i = 2; i < 8; ++i)
    ASSERT_EQ(rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, 20, 20 + 10 * i),
              SeedOutcome::kNewRegion);
  EXPECT_EQ(rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, 295, 300), SeedOutcome::kReplaced);
  // Not stronger than any unprotected strip left: let go.
  EXPECT_EQ(rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, 20, 100), SeedOutcome::kRegionsFull);
  EXPECT_EQ(rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, 305, 300),
            SeedOutcome::kAlreadyTraced);
  ASSERT_EQ(rs->regions().size(), 8u);
  EXPECT_EQ(rs->overflows(), 1u);
  EXPECT_EQ(rs->replaced(), 1u);
  int discs = 0, protected_kept = 0;
  for (const Region& r : rs->regions()) {
    discs += std::fabs(r.cu_px - 300.0f) < 0.1f && std::fabs(r.cv_px - 300.0f) < 0.1f;
    protected_kept += r.v_min == 20 || r.v_min == 30;
  }
  EXPECT_EQ(discs, 1);
  EXPECT_EQ(protected_kept, 2);

  // All protected: nothing is replaced.
  rs->Clear();
  for (int i = 0; i < 8; ++i) rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, 20, 20 + 10 * i);
  rs->ProtectTraced();
  EXPECT_EQ(rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, 295, 300), SeedOutcome::kRegionsFull);
  EXPECT_EQ(rs->replaced(), 0u);
}

TEST(ContourTest, WholeFrameInClassTracesTheBorder) {
  Frame f;
  f.Draw([](int, int) { return true; });
  auto rs = std::make_unique<Set32>();
  EXPECT_EQ(rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, 320, 240), SeedOutcome::kNewRegion);
  EXPECT_EQ(rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, 600, 40),
            SeedOutcome::kAlreadyTraced);
  const Region& r = rs->regions()[0];
  EXPECT_FLOAT_EQ(r.area_px, 640.0f * 480.0f);
  EXPECT_NEAR(r.cu_px, 319.5f, 1e-3);
  EXPECT_EQ(r.chain_length, 2u * 639 + 2 * 479);
}

}  // namespace
}  // namespace bv

namespace bv {
namespace {

// The outline's circle: a disc merged with what lies behind it, partly hidden, or alone.
struct CircleCase {
  Frame f;
  std::unique_ptr<Set32> rs = std::make_unique<Set32>();
  void Disc(float cu, float cv, float r) {
    f.Draw([&](int u, int v) { return std::hypot(u - cu, v - cv) <= r; });
  }
  const Region& Trace(int u, int v) {
    EXPECT_EQ(rs->TraceSeed(f.view(), Lut(), ColorClass::kBall, u, v), SeedOutcome::kNewRegion);
    return rs->regions().back();
  }
};

TEST(ContourCircleTest, AWholeDiscIsItsOwnCircle) {
  for (float radius : {4.0f, 9.5f, 25.0f}) {
    CircleCase c;
    c.Disc(300.4f, 200.7f, radius);
    c.Trace(300, 201);
    CircleFit fit;
    ASSERT_TRUE(c.rs->FitCircle(0, CircleSearch{}, fit)) << radius;
    EXPECT_EQ(fit.sectors, kCircleSectors) << radius;
    EXPECT_NEAR(fit.cu_px, 300.4f, 0.25f) << radius;
    EXPECT_NEAR(fit.cv_px, 200.7f, 0.25f) << radius;
    EXPECT_NEAR(fit.radius_px, radius, 0.5f) << radius;
    EXPECT_GT(fit.on_circle, 0.9f) << radius;
  }
}

// A ball in front of a box of its colour: one region whose centroid lies between the two; the
// circle is the ball's.
TEST(ContourCircleTest, ABallMergedWithABoxBehindItKeepsItsCircle) {
  CircleCase c;
  c.Disc(200.3f, 150.6f, 12.0f);
  c.f.Draw([](int u, int v) { return u >= 205 && u < 245 && v >= 120 && v < 148; });
  const Region& r = c.Trace(200, 151);
  ASSERT_GT(std::hypot(r.cu_px - 200.3f, r.cv_px - 150.6f), 8.0f);  // the centroid is not the ball
  CircleFit fit;
  ASSERT_TRUE(c.rs->FitCircle(0, CircleSearch{}, fit));
  EXPECT_GE(fit.sectors, 8);
  EXPECT_LT(fit.sectors, kCircleSectors);
  EXPECT_NEAR(fit.cu_px, 200.3f, 0.4f);
  EXPECT_NEAR(fit.cv_px, 150.6f, 0.4f);
  EXPECT_NEAR(fit.radius_px, 12.0f, 0.6f);
  c.rs->SetCircle(0, fit);
  const Region& d = c.rs->regions()[0];
  EXPECT_EQ(d.arc_sectors, fit.sectors);
  EXPECT_FLOAT_EQ(d.cu_px, fit.cu_px);
  EXPECT_NEAR(d.area_px, 3.14159f * 144.0f, 20.0f);
}

// Half hidden by a robot (a straight edge through it) and touching a cone above: with the radius
// known, the arc that is left (~140 deg) still gives the centre, which the region's centroid
// misses by a third of the radius.
TEST(ContourCircleTest, AHalfHiddenBallWithAConeOnTopGivesItsCentreWhenTheRadiusIsKnown) {
  CircleCase c;
  const float cu = 320.2f, cv = 240.4f, rad = 14.0f;
  c.f.Draw([&](int u, int v) {
    const bool ball = std::hypot(u - cu, v - cv) <= rad && u < 326;  // the robot from u = 326
    const bool cone = v >= 200 && v <= 230 && std::fabs(u - 316.0f) <= (v - 200) * 0.5f;
    return ball || cone;
  });
  const Region& r = c.Trace(315, 242);
  ASSERT_GT(std::hypot(r.cu_px - cu, r.cv_px - cv), 4.0f);
  CircleSearch s;
  s.expected_radius_px = rad;
  s.r_min_px = 0.8f * rad;
  s.r_max_px = 1.25f * rad + 1;
  s.min_sectors = 5;
  s.cu_px = cu + 3;  // a prediction a few px off
  s.cv_px = cv - 2;
  s.max_centre_px = rad;
  CircleFit fit;
  ASSERT_TRUE(c.rs->FitCircle(0, s, fit));
  EXPECT_NEAR(fit.cu_px, cu, 0.6f);
  EXPECT_NEAR(fit.cv_px, cv, 0.6f);
  EXPECT_NEAR(fit.radius_px, rad, 0.8f);
}

// A ball within a metre of the perspective camera is cut by the image border: a cap of its circle
// (~115 deg) is left, whose centroid lies 70 px inside. With the image known, the arc inside it
// gives the circle; a box on the border gives none.
TEST(ContourCircleTest, ABallCutByTheImageBorderGivesItsCircle) {
  CircleCase c;
  const float cu = 318.3f, cv = 541.2f, rad = 115.0f;
  c.Disc(cu, cv, rad);
  c.f.Draw([](int u, int v) { return u >= 40 && u < 100 && v >= 440; });
  const Region& r = c.Trace(318, 470);
  ASSERT_GT(std::fabs(r.cv_px - cv), 60.0f);
  c.Trace(60, 470);
  CircleSearch s;
  s.r_max_px = 200.0f;
  CircleFit fit;
  EXPECT_FALSE(c.rs->FitCircle(0, s, fit));  // 5 of 16 sectors: not a circle without the border
  s.image_width = 640;
  s.image_height = 480;
  ASSERT_TRUE(c.rs->FitCircle(0, s, fit));
  EXPECT_NEAR(fit.cu_px, cu, 1.0f);
  EXPECT_NEAR(fit.cv_px, cv, 1.5f);
  EXPECT_NEAR(fit.radius_px, rad, 1.5f);
  // Its outline points on the circle, for a camera model to refine it: none on the border.
  c.rs->SetCircle(0, fit);
  int16_t u[64], v[64];
  const size_t n = c.rs->CirclePoints(0, 640, 480, u, v);
  EXPECT_GE(n, 24u);
  for (size_t k = 0; k < n; ++k) {
    EXPECT_LT(v[k], 479) << k;
    EXPECT_NEAR(std::hypot(u[k] - cu, v[k] - cv), rad, 2.0f) << k;
  }
  EXPECT_FALSE(c.rs->FitCircle(1, s, fit));
}

// Two balls touching: the centre constraint picks the one predicted.
TEST(ContourCircleTest, TwoTouchingBallsThePredictedOneIsFitted) {
  CircleCase c;
  c.Disc(200.0f, 200.0f, 10.0f);
  c.Disc(217.0f, 196.0f, 9.0f);
  c.Trace(200, 200);
  for (const auto& [u, v, r] : {std::tuple{200.0f, 200.0f, 10.0f}, {217.0f, 196.0f, 9.0f}}) {
    CircleSearch s;
    s.expected_radius_px = r;
    s.r_min_px = 0.8f * r;
    s.r_max_px = 1.25f * r + 1;
    s.min_sectors = 5;
    s.cu_px = u + 1.5f;
    s.cv_px = v - 1.0f;
    s.max_centre_px = r;
    CircleFit fit;
    ASSERT_TRUE(c.rs->FitCircle(0, s, fit)) << u;
    EXPECT_NEAR(fit.cu_px, u, 0.6f) << u;
    EXPECT_NEAR(fit.cv_px, v, 0.6f) << u;
    EXPECT_NEAR(fit.radius_px, r, 0.8f) << u;
  }
}

// Not circles: a square (its outline meets its inscribed circle in four short arcs), a 3:1 bar, a
// thin line; nor a circle outside the search's radius range or away from its centre.
TEST(ContourCircleTest, SquaresBarsLinesAndCirclesOutsideTheSearchAreRefused) {
  CircleCase c;
  c.f.Draw([](int u, int v) { return u >= 100 && u < 136 && v >= 100 && v < 136; });
  c.f.Draw([](int u, int v) { return u >= 200 && u < 260 && v >= 100 && v < 120; });
  c.f.Draw([](int u, int v) { return u >= 300 && u < 360 && v == 100; });
  c.Disc(450.0f, 300.0f, 15.0f);
  c.Trace(110, 110);
  c.Trace(210, 110);
  c.Trace(310, 100);
  c.Trace(450, 300);
  CircleFit fit;
  for (size_t i = 0; i < 3; ++i) EXPECT_FALSE(c.rs->FitCircle(i, CircleSearch{}, fit)) << i;
  EXPECT_LT(fit.sectors, 8);
  ASSERT_TRUE(c.rs->FitCircle(3, CircleSearch{}, fit));
  CircleSearch small;
  small.r_max_px = 10;
  EXPECT_FALSE(c.rs->FitCircle(3, small, fit));
  CircleSearch elsewhere;
  elsewhere.cu_px = 480;
  elsewhere.cv_px = 300;
  elsewhere.max_centre_px = 15;
  EXPECT_FALSE(c.rs->FitCircle(3, elsewhere, fit));
  EXPECT_FALSE(c.rs->FitCircle(99, CircleSearch{}, fit));  // no such region
}

}  // namespace
}  // namespace bv
