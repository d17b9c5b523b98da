// Colour LUT: indexing, blob round trip, and every corruption of the blob rejected.
#include "core/color_lut/color_lut.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <memory>
#include <vector>

#include "core/common/blob.h"

namespace bv {
namespace {

std::unique_ptr<ColorLut> Pattern() {
  auto lut = std::make_unique<ColorLut>();
  for (uint32_t i = 0; i < ColorLut::kEntries; ++i) {
    lut->Set(i, static_cast<ColorClass>((i * 7 + (i >> 5)) % kColorClassCount));
  }
  return lut;
}

TEST(ColorLutTest, IndexUsesTopBitsOfEachChannel) {
  EXPECT_EQ(ColorLut::Index(0, 0, 0), 0u);
  EXPECT_EQ(ColorLut::Index(255, 255, 255), ColorLut::kEntries - 1);
  EXPECT_EQ(ColorLut::Index(0x10, 0, 0), 1u << 12);
  EXPECT_EQ(ColorLut::Index(0x0F, 0x03, 0x03), 0u);  // dropped low bits
  EXPECT_EQ(ColorLut::Index(0, 4, 0), 1u << 6);
  EXPECT_EQ(ColorLut::Index(0, 0, 4), 1u);
  for (uint32_t i : {0u, 1u, 4095u, 4096u, 40000u, 65535u}) {
    uint8_t y, u, v;
    ColorLut::CellCenter(i, y, u, v);
    EXPECT_EQ(ColorLut::Index(y, u, v), i);
  }
  static_assert(sizeof(ColorLut) <= 65536, "LUT memory <= 64 KB");
}

TEST(ColorLutTest, ClassifyReadsTheTable) {
  auto lut = std::make_unique<ColorLut>();
  lut->Fill(ColorClass::kField);
  lut->Set(ColorLut::Index(120, 90, 200), ColorClass::kBall);
  EXPECT_EQ(lut->Classify(120, 90, 200), ColorClass::kBall);
  EXPECT_EQ(lut->Classify(127, 91, 203), ColorClass::kBall);  // same cell
  EXPECT_EQ(lut->Classify(135, 90, 200), ColorClass::kField);
  EXPECT_STREQ(ColorClassName(ColorClass::kObstacle), "obstacle");
}

TEST(ColorLutTest, PackedCellsAreIndependent) {
  // Two cells share a byte; setting one must never change its neighbour.
  auto lut = std::make_unique<ColorLut>();
  lut->Fill(ColorClass::kField);
  lut->Set(10, ColorClass::kBall);
  lut->Set(13, ColorClass::kObstacle);
  EXPECT_EQ(lut->at(10), ColorClass::kBall);
  EXPECT_EQ(lut->at(11), ColorClass::kField);
  EXPECT_EQ(lut->at(12), ColorClass::kField);
  EXPECT_EQ(lut->at(13), ColorClass::kObstacle);
  lut->Set(10, ColorClass::kUnknown);
  EXPECT_EQ(lut->at(10), ColorClass::kUnknown);
  EXPECT_EQ(lut->at(11), ColorClass::kField);
  EXPECT_LE(sizeof(ColorLut), 32u * 1024u);
}

TEST(ColorLutTest, ChromaBoxHoldsEveryBallPixel) {
  // The committed sim LUT: every (y, u, v) classified as ball lies inside the box, and the box
  // is tight enough to reject the field green.
  std::vector<uint8_t> blob;
  {
    FILE* f = std::fopen((std::string(BV_TEST_DATA_DIR) + "/luts/sim_orange.lut").c_str(), "rb");
    ASSERT_NE(f, nullptr);
    blob.resize(kColorLutBlobBytes);
    blob.resize(std::fread(blob.data(), 1, blob.size(), f));
    std::fclose(f);
  }
  auto lut = std::make_unique<ColorLut>();
  ASSERT_TRUE(ParseLut(blob, *lut).ok());
  const ChromaBox box = lut->Bounds(ColorClass::kBall);
  ASSERT_FALSE(box.empty);
  int ball = 0;
  for (int y = 0; y < 256; y += 3) {
    for (int u = 0; u < 256; ++u) {
      for (int v = 0; v < 256; ++v) {
        if (lut->Classify(uint8_t(y), uint8_t(u), uint8_t(v)) != ColorClass::kBall) continue;
        ++ball;
        ASSERT_TRUE(box.Contains(uint8_t(u), uint8_t(v))) << y << " " << u << " " << v;
      }
    }
  }
  EXPECT_GT(ball, 0);
  EXPECT_FALSE(box.Contains(90, 100)) << "field green (low V) must be rejected by the box";
  EXPECT_TRUE(std::make_unique<ColorLut>()->Bounds(ColorClass::kBall).empty);
  EXPECT_TRUE(ChromaBox{}.Contains(0, 255));
}

TEST(ColorLutTest, PairChromaTestKeepsExactlyWhatItsBoxContains) {
  // The scanlines' test on a whole YUYV pair word (Y0 U Y1 V): the box's U and V ranges, Y
  // ignored; a wrapped range (min > max) keeps everything, a superset of Contains().
  const ChromaBox boxes[] = {ChromaBox{}, ChromaBox{100, 140, 160, 200, false},
                             ChromaBox{0, 0, 255, 255, false}, ChromaBox{200, 40, 10, 90, false}};
  uint32_t seed = 12345;
  for (const ChromaBox& box : boxes) {
    const PairChromaTest test(box);
    const bool wraps = box.u_min > box.u_max || box.v_min > box.v_max;
    for (int i = 0; i < 20000; ++i) {
      seed = seed * 1664525u + 1013904223u;
      const uint32_t w = seed;
      const auto u = static_cast<uint8_t>(w >> 8), v = static_cast<uint8_t>(w >> 24);
      if (!wraps) {
        ASSERT_EQ(test.Holds(w), box.Contains(u, v)) << std::hex << w;
      } else if (box.Contains(u, v)) {
        ASSERT_TRUE(test.Holds(w)) << std::hex << w;
      }
    }
    // The range ends themselves, with any Y.
    if (!wraps) {
      const uint32_t y = 0x00FF00FFu;
      EXPECT_TRUE(test.Holds(y | uint32_t{box.u_min} << 8 | uint32_t{box.v_max} << 24));
      EXPECT_TRUE(test.Holds(uint32_t{box.u_max} << 8 | uint32_t{box.v_min} << 24));
    }
  }
  const PairChromaTest narrow(ChromaBox{100, 140, 160, 200, false});
  EXPECT_FALSE(narrow.Holds(99u << 8 | 180u << 24));
  EXPECT_FALSE(narrow.Holds(141u << 8 | 180u << 24));
  EXPECT_FALSE(narrow.Holds(120u << 8 | 159u << 24));
  EXPECT_FALSE(narrow.Holds(120u << 8 | 201u << 24));
}

TEST(ColorLutTest, BlobRoundTrip) {
  auto lut = Pattern();
  std::vector<uint8_t> blob(kColorLutBlobBytes);
  Result<size_t> n = SerializeLut(*lut, blob);
  ASSERT_TRUE(n.ok());
  EXPECT_EQ(*n, kColorLutBlobBytes);
  auto back = std::make_unique<ColorLut>();
  ASSERT_TRUE(ParseLut(blob, *back).ok());
  for (uint32_t i = 0; i < ColorLut::kEntries; ++i) ASSERT_EQ(back->at(i), lut->at(i)) << i;
  EXPECT_EQ(back->Id(), lut->Id());
  std::vector<uint8_t> small(kColorLutBlobBytes - 1);
  EXPECT_EQ(SerializeLut(*lut, small).status().code(), StatusCode::kResourceExhausted);
}

TEST(ColorLutTest, CorruptBlobsAreRejectedAndLeaveTheLutUntouched) {
  auto lut = Pattern();
  std::vector<uint8_t> good(kColorLutBlobBytes);
  ASSERT_TRUE(SerializeLut(*lut, good).ok());
  auto target = std::make_unique<ColorLut>();
  target->Fill(ColorClass::kLine);
  const uint32_t before = target->Id();

  std::vector<uint8_t> b = good;
  b[16 + 4 + 1000] ^= 1;  // payload bit flip
  EXPECT_EQ(ParseLut(b, *target).code(), StatusCode::kDataLoss);
  b = good;
  b.resize(b.size() - 10);  // truncated
  EXPECT_EQ(ParseLut(b, *target).code(), StatusCode::kDataLoss);
  b = good;
  b[0] = 'X';  // magic
  EXPECT_EQ(ParseLut(b, *target).code(), StatusCode::kDataLoss);
  b = good;
  b[4] = static_cast<uint8_t>(BlobKind::kCalibration);  // kind
  EXPECT_EQ(ParseLut(b, *target).code(), StatusCode::kInvalidArgument);
  b = good;
  b[6] = kColorLutBlobVersion + 1;  // newer version
  EXPECT_EQ(ParseLut(b, *target).code(), StatusCode::kUnimplemented);
  EXPECT_EQ(ParseLut(std::span<const uint8_t>(good.data(), 8), *target).code(),
            StatusCode::kDataLoss);

  // Valid CRC but bad contents: rebuild the blob around an edited payload.
  std::vector<uint8_t> payload(good.begin() + 16, good.end());
  std::vector<uint8_t> rewrapped(good.size());
  payload[0] = 5;  // Y bits
  ASSERT_TRUE(WriteBlob(BlobKind::kColorLut, kColorLutBlobVersion, payload, rewrapped).ok());
  EXPECT_EQ(ParseLut(rewrapped, *target).code(), StatusCode::kInvalidArgument);
  payload[0] = ColorLut::kYBits;
  payload[4 + 77] = kColorClassCount;  // unknown class value
  ASSERT_TRUE(WriteBlob(BlobKind::kColorLut, kColorLutBlobVersion, payload, rewrapped).ok());
  EXPECT_EQ(ParseLut(rewrapped, *target).code(), StatusCode::kInvalidArgument);
  payload[4 + 77] = 0;
  payload.pop_back();  // wrong payload size
  std::vector<uint8_t> shorter(good.size() - 1);
  ASSERT_TRUE(WriteBlob(BlobKind::kColorLut, kColorLutBlobVersion, payload, shorter).ok());
  EXPECT_EQ(ParseLut(shorter, *target).code(), StatusCode::kInvalidArgument);

  EXPECT_EQ(target->Id(), before);
}

}  // namespace
}  // namespace bv

// ---- host training (tools/ballvision/lut_train) ----
#include "hal/host/sequence.h"
#include "tools/ballvision/lut_train.h"

namespace bv {
namespace {

// An orange disc lit from one side (brightness 0.45..1.1 across it) with a white highlight on
// green carpet with a white line. Teaching one pixel in the lit part must make the whole disc
// ball, including the shadowed side, and neither carpet, line nor highlight.
TEST(LutTrainTest, TeachFromOneSeedCopesWithShading) {
  constexpr int kW = 160, kH = 120;
  std::vector<uint8_t> rgb(kW * kH * 3);
  const auto put = [&](int u, int v, float r, float g, float b) {
    uint8_t* p = &rgb[(v * kW + u) * 3];
    p[0] = static_cast<uint8_t>(std::min(255.f, r));
    p[1] = static_cast<uint8_t>(std::min(255.f, g));
    p[2] = static_cast<uint8_t>(std::min(255.f, b));
  };
  std::vector<uint8_t> truth(kW * kH, 0);  // 1 ball, 2 highlight
  for (int v = 0; v < kH; ++v)
    for (int u = 0; u < kW; ++u) {
      const float dx = u - 80.f, dy = v - 60.f;
      if (dx * dx + dy * dy <= 30 * 30) {
        const float k = 0.45f + 0.65f * (dx + 30) / 60;  // shading across the ball
        if ((u - 90) * (u - 90) + (v - 50) * (v - 50) <= 9) {
          put(u, v, 250, 250, 245);
          truth[v * kW + u] = 2;
        } else {
          put(u, v, 235 * k, 95 * k, 30 * k);
          truth[v * kW + u] = 1;
        }
      } else if (v >= 100 && v < 106) {
        put(u, v, 235, 235, 235);
      } else {
        put(u, v, 40, 130 + (u % 7), 45);
      }
    }
  lut::Image img;
  img.width = kW;
  img.height = kH;
  img.yuyv.resize(kW * kH * 2);
  host::RgbToYuyv(rgb.data(), kW, kH, img.yuyv.data());
  lut::Trainer t;
  EXPECT_GT(t.Teach(img, 100, 60, ColorClass::kBall), 1500);  // grows over the whole shaded disc
  for (int v = 0; v < kH; v += 2)
    for (int u = 0; u < kW; u += 2)
      if (!truth[v * kW + u]) {
        const Yuv p = img.view().at(u, v);
        t.AddOther(p.y, p.u, p.v);
      }
  auto lut = std::make_unique<ColorLut>(t.Build());
  int ball_px = 0, ball_hit = 0, other_px = 0, other_hit = 0;
  for (int v = 0; v < kH; ++v)
    for (int u = 2; u < kW - 2; ++u) {
      if ((u - 80) * (u - 80) + (v - 60) * (v - 60) > 27 * 27 && truth[v * kW + u] == 1) continue;
      const Yuv p = img.view().at(u, v);
      const bool is_ball = lut->Classify(p.y, p.u, p.v) == ColorClass::kBall;
      if (truth[v * kW + u] == 1) {
        ++ball_px;
        ball_hit += is_ball;
      } else if (truth[v * kW + u] == 0) {
        ++other_px;
        other_hit += is_ball;
      }
    }
  EXPECT_GE(ball_hit, ball_px * 97 / 100) << ball_hit << " of " << ball_px;
  EXPECT_EQ(other_hit, 0);
  const Yuv line = img.view().at(50, 102), grass = img.view().at(10, 10);
  EXPECT_EQ(lut->Classify(line.y, line.u, line.v), ColorClass::kLine);
  EXPECT_EQ(lut->Classify(grass.y, grass.u, grass.v), ColorClass::kField);
}

}  // namespace
}  // namespace bv

namespace bv {
namespace {

TEST(ColorLutTest, BoundsOfRowBandsUniteToTheWholeTablesBounds) {
  const auto lut = Pattern();
  for (ColorClass c : {ColorClass::kBall, ColorClass::kField, ColorClass::kLine}) {
    ChromaBox acc;
    acc.empty = true;
    for (uint32_t first = 0; first < 64; first += 4)
      acc = Union(acc, lut->Bounds(c, first, first + 4));
    const ChromaBox all = lut->Bounds(c);
    EXPECT_EQ(acc.empty, all.empty);
    EXPECT_EQ(acc.u_min, all.u_min);
    EXPECT_EQ(acc.u_max, all.u_max);
    EXPECT_EQ(acc.v_min, all.v_min);
    EXPECT_EQ(acc.v_max, all.v_max);
  }
  // A band without the class is empty.
  ColorLut one;
  one.Set(ColorLut::Index(100, 200, 40), ColorClass::kBall);
  EXPECT_TRUE(one.Bounds(ColorClass::kBall, 0, 50).empty);
  EXPECT_FALSE(one.Bounds(ColorClass::kBall, 50, 51).empty);
}

}  // namespace
}  // namespace bv
