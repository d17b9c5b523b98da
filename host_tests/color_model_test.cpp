// The shade-invariant ball colour model and the table built from it: balls red to orange in sun
// and shade are ball, the colours around a field are not, bad models are refused.
#include "core/color_lut/color_model.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>

namespace bv {
namespace {

struct Yuv {
  uint8_t y, u, v;
};

// sRGB (0..255) to YUV as the pipeline's frame loader does (BT.601, full range).
Yuv FromRgb(double r, double g, double b) {
  const double y = 0.299 * r + 0.587 * g + 0.114 * b;
  const auto clamp = [](double x) {
    return static_cast<uint8_t>(std::clamp(std::lround(x), 0L, 255L));
  };
  return {clamp(y), clamp(128 + 0.564 * (b - y)), clamp(128 + 0.713 * (r - y))};
}

// A surface of linear reflectance (r, g, b) lit by `light`, gamma-encoded as a camera does.
Yuv Lit(double r, double g, double b, double light) {
  const auto enc = [&](double x) { return 255.0 * std::pow(std::min(1.0, x * light), 1 / 2.2); };
  return FromRgb(enc(r), enc(g), enc(b));
}

std::unique_ptr<ColorLut> DefaultTable() {
  auto lut = std::make_unique<ColorLut>();
  EXPECT_TRUE(BuildLut(BallColorModel{}, *lut).ok());
  return lut;
}

TEST(ColorModelTest, DefaultModelIsValid) {
  EXPECT_TRUE(ValidateBallColorModel(BallColorModel{}).ok());
}

TEST(ColorModelTest, RedToOrangeBallsAreBallFromDeepShadeToSun) {
  const auto lut = DefaultTable();
  // Linear reflectances from the league's red to orange balls.
  const double balls[][3] = {{0.78, 0.06, 0.022}, {0.85, 0.15, 0.02}, {0.80, 0.10, 0.02}};
  for (const auto& c : balls) {
    // 0.12: deep shade (Y ~ 45); 1.1: direct sun just short of clipping red.
    for (double light = 0.12; light <= 1.1; light *= 1.15) {
      const Yuv p = Lit(c[0], c[1], c[2], light);
      EXPECT_TRUE(InBallColorModel(BallColorModel{}, p.y, p.u, p.v))
          << c[0] << "," << c[1] << "," << c[2] << " light " << light << " -> Y " << int{p.y}
          << " U " << int{p.u} << " V " << int{p.v};
      EXPECT_EQ(lut->Classify(p.y, p.u, p.v), ColorClass::kBall)
          << c[0] << "," << c[1] << "," << c[2] << " light " << light;
    }
  }
}

TEST(ColorModelTest, ACellIsBallWhenHalfOfItsEightSampleColoursAreInTheModel) {
  BallColorModel m;  // also a taught-looking one: narrow window, other floors
  BallColorModel taught;
  taught.hue_min_deg = 113.5f;
  taught.hue_max_deg = 124.0f;
  taught.chroma_min = 0.42f;
  taught.y_min = 36;
  for (const BallColorModel& model : {m, taught}) {
    auto lut = std::make_unique<ColorLut>();
    ASSERT_TRUE(BuildLut(model, *lut).ok());
    int ball_cells = 0;
    for (uint32_t i = 0; i < ColorLut::kEntries; ++i) {
      uint8_t y, u, v;
      ColorLut::CellCenter(i, y, u, v);
      int votes = 0;
      for (int k = 0; k < 8; ++k) {
        votes += InBallColorModel(model, static_cast<uint8_t>(y - 8 + 4 + (k >> 2) * 8),
                                  static_cast<uint8_t>(u - 2 + 1 + ((k >> 1) & 1) * 2),
                                  static_cast<uint8_t>(v - 2 + 1 + (k & 1) * 2));
      }
      ASSERT_EQ(lut->at(i) == ColorClass::kBall, votes >= 4) << "cell " << i;
      ball_cells += votes >= 4;
      if (votes < 4) {
        ASSERT_EQ(lut->at(i), BackgroundClass(y, u, v)) << "cell " << i;
      }
    }
    EXPECT_GT(ball_cells, 50);
  }
}

TEST(ColorModelTest, FieldLinesSkinWoodAndGreyAreNotBall) {
  const auto lut = DefaultTable();
  struct Case {
    const char* name;
    double r, g, b;
  };
  const Case others[] = {
      {"carpet green", 0.05, 0.25, 0.05}, {"white line", 0.8, 0.8, 0.8},
      {"grey wall", 0.3, 0.3, 0.32},      {"skin", 0.55, 0.35, 0.25},
      {"light wood", 0.45, 0.28, 0.15},   {"blue shirt", 0.08, 0.10, 0.35},
      {"yellow", 0.8, 0.7, 0.05},         {"black robot", 0.02, 0.02, 0.02},
      {"magenta", 0.6, 0.05, 0.5},
  };
  for (const Case& c : others) {
    for (double light = 0.15; light <= 1.2; light *= 1.2) {
      const Yuv p = Lit(c.r, c.g, c.b, light);
      EXPECT_NE(lut->Classify(p.y, p.u, p.v), ColorClass::kBall) << c.name << " light " << light;
    }
  }
  const Yuv green = Lit(0.05, 0.25, 0.05, 0.8);
  EXPECT_EQ(lut->Classify(green.y, green.u, green.v), ColorClass::kField);
  const Yuv white = Lit(0.8, 0.8, 0.8, 1.0);
  EXPECT_EQ(lut->Classify(white.y, white.u, white.v), ColorClass::kLine);
}

// The background classes of the built-in table (measured on the clutter renders' omni images: a
// sunlit carpet in a robot's shadow sits at Y 30-50 with U, V 6-15 below grey; a black robot within
// 4 of grey). A shadow classed as obstacle put robots' feet 0.5 m early and made false obstacles.
TEST(ColorModelTest, ShadowedCarpetIsFieldABlackRobotAnObstacle) {
  EXPECT_EQ(BackgroundClass(40, 120, 118), ColorClass::kField);  // carpet in shadow
  EXPECT_EQ(BackgroundClass(30, 122, 116), ColorClass::kField);
  EXPECT_EQ(BackgroundClass(90, 110, 105), ColorClass::kField);     // sunlit carpet
  EXPECT_EQ(BackgroundClass(30, 128, 127), ColorClass::kObstacle);  // black robot
  EXPECT_EQ(BackgroundClass(45, 125, 126), ColorClass::kObstacle);
  EXPECT_EQ(BackgroundClass(200, 126, 124), ColorClass::kLine);  // white line, a little green
  EXPECT_EQ(BackgroundClass(200, 120, 118), ColorClass::kLine);
}

TEST(ColorModelTest, TheModelsBoundsAreItsParameters) {
  // A model narrowed to orange no longer takes red; one widened to yellow takes yellow.
  BallColorModel orange;
  orange.hue_min_deg = 125.0f;
  const Yuv red = Lit(0.78, 0.06, 0.022, 0.5), yellow = Lit(0.8, 0.7, 0.05, 0.5);
  EXPECT_FALSE(InBallColorModel(orange, red.y, red.u, red.v));
  BallColorModel wide;
  wide.hue_max_deg = 175.0f;
  EXPECT_TRUE(InBallColorModel(wide, yellow.y, yellow.u, yellow.v));
  EXPECT_FALSE(InBallColorModel(BallColorModel{}, yellow.y, yellow.u, yellow.v));
  BallColorModel dark_floor;
  dark_floor.y_min = 80;
  const Yuv shade = Lit(0.78, 0.06, 0.022, 0.12);
  EXPECT_TRUE(InBallColorModel(BallColorModel{}, shade.y, shade.u, shade.v));
  EXPECT_FALSE(InBallColorModel(dark_floor, shade.y, shade.u, shade.v));
}

TEST(ColorModelTest, InvalidModelsAreRefusedAndLeaveTheTable) {
  const auto lut = std::make_unique<ColorLut>();
  lut->Fill(ColorClass::kLine);
  const uint32_t before = lut->Id();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  BallColorModel bad[7];
  bad[0].hue_min_deg = nan;
  bad[1].hue_max_deg = bad[1].hue_min_deg;  // empty window
  bad[2].hue_max_deg = bad[2].hue_min_deg + 200.0f;
  bad[3].chroma_min = 0.0f;
  bad[4].chroma_max = 0.1f;  // below the floor
  bad[5].bright_y_end = bad[5].bright_y;
  bad[6].y_min = 255;
  for (const BallColorModel& m : bad) {
    const Status st = BuildLut(m, *lut);
    EXPECT_EQ(st.code(), StatusCode::kInvalidArgument);
    EXPECT_NE(std::strstr(st.message(), "colour model"), nullptr) << st.message();
    EXPECT_EQ(lut->Id(), before);
  }
}

TEST(ColorModelTest, BallRowsUpdatedInStepsMatchAFreshTableAndKeepAVenueTablesOtherClasses) {
  // A table built from one model, updated to another a few rows at a time, equals the table built
  // from the other; the boxes of the steps unite to its Bounds.
  BallColorModel from, to;
  from.hue_min_deg = 95.0f;
  to.hue_max_deg = 165.0f;
  to.y_min = 40;
  auto table = std::make_unique<ColorLut>();
  auto fresh = std::make_unique<ColorLut>();
  ASSERT_TRUE(BuildLut(from, *table).ok());
  ASSERT_TRUE(BuildLut(to, *fresh).ok());
  ChromaBox box;
  box.empty = true;
  for (int first = 0; first < 64; first += 3) {
    ChromaBox rows;
    ASSERT_TRUE(UpdateBallRows(from, to, *table, first, std::min(64, first + 3), rows).ok());
    const ChromaBox want = fresh->Bounds(ColorClass::kBall, static_cast<uint32_t>(first),
                                         static_cast<uint32_t>(std::min(64, first + 3)));
    ASSERT_EQ(rows.empty, want.empty) << first;
    if (!want.empty) {
      EXPECT_EQ(rows.u_min, want.u_min);
      EXPECT_EQ(rows.u_max, want.u_max);
      EXPECT_EQ(rows.v_min, want.v_min);
      EXPECT_EQ(rows.v_max, want.v_max);
    }
    box = Union(box, rows);
  }
  EXPECT_EQ(table->Id(), fresh->Id());
  const ChromaBox all = fresh->Bounds(ColorClass::kBall);
  EXPECT_EQ(box.u_min, all.u_min);
  EXPECT_EQ(box.u_max, all.u_max);
  EXPECT_EQ(box.v_min, all.v_min);
  EXPECT_EQ(box.v_max, all.v_max);

  // A venue table (every non-ball cell "line" here, unlike the built-in rule): its non-ball cells
  // stay, its ball cells the model drops get the built-in background class.
  auto venue = std::make_unique<ColorLut>();
  venue->Fill(ColorClass::kLine);
  uint32_t dropped = 0;
  for (uint32_t i = 0; i < ColorLut::kEntries; ++i) {
    if (fresh->at(i) == ColorClass::kBall) venue->Set(i, ColorClass::kBall);
  }
  BallColorModel narrow;
  narrow.hue_min_deg = 125.0f;
  ChromaBox rows;
  ASSERT_TRUE(UpdateBallRows(to, narrow, *venue, 0, 64, rows).ok());
  auto narrow_fresh = std::make_unique<ColorLut>();
  ASSERT_TRUE(BuildLut(narrow, *narrow_fresh).ok());
  for (uint32_t i = 0; i < ColorLut::kEntries; ++i) {
    const bool ball = narrow_fresh->at(i) == ColorClass::kBall;
    if (ball) {
      ASSERT_EQ(venue->at(i), ColorClass::kBall) << i;
    } else if (fresh->at(i) == ColorClass::kBall) {
      ASSERT_EQ(venue->at(i), narrow_fresh->at(i)) << i;  // the built-in background class
      ++dropped;
    } else {
      ASSERT_EQ(venue->at(i), ColorClass::kLine) << i;
    }
  }
  EXPECT_GT(dropped, 100u);
  EXPECT_EQ(UpdateBallRows(to, narrow, *venue, 60, 65, rows).code(), StatusCode::kInvalidArgument);
  BallColorModel bad;
  bad.y_min = 255;
  const uint32_t before = venue->Id();
  EXPECT_EQ(UpdateBallRows(to, bad, *venue, 0, 4, rows).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(venue->Id(), before);
}

}  // namespace
}  // namespace bv
