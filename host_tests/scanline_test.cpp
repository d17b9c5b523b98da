// Scan patterns: every ball-sized disc in the mirror ring / perspective image has a scan pixel
// centre inside it; struts and the robot body are not read; bad configs and overflow reported.
#include "core/scanline/scanline.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <vector>

namespace bv {
namespace {

constexpr float kCu = 314.2f, kCv = 244.1f;

std::vector<uint8_t> Mark(const ScanlineTableBase& t, int& out_of_image) {
  std::vector<uint8_t> m(static_cast<size_t>(t.width()) * t.height(), 0);
  out_of_image = 0;
  ForEachScanPixel(t, [&](int u, int v) {
    if (u < 0 || v < 0 || u >= t.width() || v >= t.height()) {
      ++out_of_image;
      return;
    }
    m[static_cast<size_t>(v) * t.width() + u] = 1;
  });
  return m;
}

// True if some marked pixel centre lies strictly inside the disc (cx, cy, d/2).
bool Hit(const std::vector<uint8_t>& m, int w, int h, float cx, float cy, float d) {
  const float r = d * 0.5f;
  const int rr = static_cast<int>(std::ceil(r));
  const int u0 = static_cast<int>(std::lround(cx)), v0 = static_cast<int>(std::lround(cy));
  for (int dv = -rr; dv <= rr; ++dv) {
    for (int du = -rr; du <= rr; ++du) {
      const int u = u0 + du, v = v0 + dv;
      if (u < 0 || v < 0 || u >= w || v >= h || !m[static_cast<size_t>(v) * w + u]) continue;
      if (std::hypot(u - cx, v - cy) < r) return true;
    }
  }
  return false;
}

float AngleDiffDeg(float a, float b) {
  float d = std::fmod(std::fabs(a - b), 360.0f);
  return d > 180.0f ? 360.0f - d : d;
}

// Checks every disc on a 0.5 px grid of centres that lies inside the ring, outside the strut
// wedges (there the strut hides the ball) and inside the image.
int UncoveredOmniDiscs(const OmniScanConfig& c, const std::vector<uint8_t>& m, int w, int h,
                       int& checked) {
  int missed = 0;
  checked = 0;
  for (float y = 0; y < h; y += 0.5f) {
    for (float x = 0; x < w; x += 0.5f) {
      const float r = std::hypot(x - c.center_u, y - c.center_v);
      if (r < c.inner_radius_px || r > c.outer_radius_px) continue;
      const float d = c.diameter.count > 0 ? c.diameter.At(r) : 4.0f;
      if (r < c.inner_radius_px + d / 2 || r > c.outer_radius_px - d / 2) continue;
      if (x < d / 2 || y < d / 2 || x > w - 1 - d / 2 || y > h - 1 - d / 2) continue;
      const float ang = std::atan2(y - c.center_v, x - c.center_u) * 57.29578f;
      bool strut = false;
      for (int s = 0; s < c.strut_count; ++s) {
        strut |= AngleDiffDeg(ang, c.struts[s].angle_deg) <=
                 c.struts[s].half_width_deg + std::asin(d / 2 / r) * 57.29578f;
      }
      if (strut) continue;
      ++checked;
      if (!Hit(m, w, h, x, y, d)) {
        if (++missed <= 8) std::printf("uncovered (%.1f, %.1f) r %.1f d %.1f\n", x, y, r, d);
      }
    }
  }
  return missed;
}

TEST(ScanlineTest, OmniEvery4pxDiscInRingIsHit) {
  auto t = std::make_unique<ScanlineTable<60000>>();  // more than the device table holds
  OmniScanConfig c = ReferenceOmniScanConfig(kCu, kCv);
  c.diameter.count = 0;  // 4 px everywhere
  ASSERT_TRUE(t->BuildOmni(c, 640, 480).ok());
  int outside = 0;
  const auto m = Mark(*t, outside);
  EXPECT_EQ(outside, 0);
  int checked = 0;
  EXPECT_EQ(UncoveredOmniDiscs(c, m, 640, 480, checked), 0);
  EXPECT_GT(checked, 400000);
  std::printf("omni, 4 px discs everywhere: %d rows, %u pixels = %.2f %% of the frame\n",
              t->height(), t->pixel_count(), 100.0 * t->pixel_count() / (640 * 480));
}

TEST(ScanlineTest, OmniReferenceProfileHitsEveryBallOfItsRadius) {
  auto t = std::make_unique<ScanlineTable<kOmniScanPixels>>();
  const OmniScanConfig c = ReferenceOmniScanConfig(kCu, kCv);
  ASSERT_TRUE(t->BuildOmni(c, 640, 480).ok());
  int outside = 0;
  const auto m = Mark(*t, outside);
  EXPECT_EQ(outside, 0);
  int checked = 0;
  EXPECT_EQ(UncoveredOmniDiscs(c, m, 640, 480, checked), 0);
  std::printf("omni, reference ball-size profile (4 px at the rim): %d rows, %u pixels = %.2f %%\n",
              t->height(), t->pixel_count(), 100.0 * t->pixel_count() / (640 * 480));
  // Nothing read inside the body, beyond the rim or in a strut wedge.
  ForEachScanPixel(*t, [&](int u, int v) {
    const float r = std::hypot(u - kCu, v - kCv);
    ASSERT_GE(r, c.inner_radius_px - 1.0f);
    ASSERT_LE(r, c.outer_radius_px + 1.0f);
    const float ang = std::atan2(v - kCv, u - kCu) * 57.29578f;
    for (int s = 0; s < c.strut_count; ++s) {
      ASSERT_GT(AngleDiffDeg(ang, c.struts[s].angle_deg), c.struts[s].half_width_deg - 0.6f)
          << u << "," << v;
    }
  });
}

TEST(ScanlineTest, PerspEvery8pxDiscIsHit) {
  auto t = std::make_unique<ScanlineTable<kPerspScanPixels>>();
  const PerspScanConfig c = ReferencePerspScanConfig();
  ASSERT_TRUE(t->BuildPersp(c, 640, 480).ok());
  int outside = 0;
  const auto m = Mark(*t, outside);
  EXPECT_EQ(outside, 0);
  int missed = 0;
  for (float y = 4; y <= 475; y += 0.5f) {
    for (float x = 4; x <= 635; x += 0.5f) missed += !Hit(m, 640, 480, x, y, 8.0f);
  }
  EXPECT_EQ(missed, 0);
  std::printf("persp, 8 px discs: %d rows, %u pixels = %.2f %%\n", t->height(), t->pixel_count(),
              100.0 * t->pixel_count() / (640 * 480));
}

TEST(ScanlineTest, BadConfigsAreRejected) {
  auto t = std::make_unique<ScanlineTable<kOmniScanPixels>>();
  OmniScanConfig c = ReferenceOmniScanConfig(kCu, kCv);
  c.center_u = -5;
  EXPECT_EQ(t->BuildOmni(c, 640, 480).code(), StatusCode::kInvalidArgument);
  c = ReferenceOmniScanConfig(kCu, kCv);
  c.inner_radius_px = 300;
  EXPECT_EQ(t->BuildOmni(c, 640, 480).code(), StatusCode::kInvalidArgument);
  c = ReferenceOmniScanConfig(kCu, kCv);
  c.diameter.diameter_px[2] = 1.0f;
  EXPECT_EQ(t->BuildOmni(c, 640, 480).code(), StatusCode::kInvalidArgument);
  c = ReferenceOmniScanConfig(kCu, kCv);
  c.diameter.at_px[3] = c.diameter.at_px[2];  // not increasing
  EXPECT_EQ(t->BuildOmni(c, 640, 480).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(t->BuildOmni(ReferenceOmniScanConfig(kCu, kCv), 0, 480).code(),
            StatusCode::kInvalidArgument);
  PerspScanConfig p;
  p.first_row = 500;
  EXPECT_EQ(t->BuildPersp(p, 640, 480).code(), StatusCode::kInvalidArgument);
  EXPECT_FALSE(t->built());
}

TEST(ScanlineTest, CapacityOverflowLeavesTableEmpty) {
  auto t = std::make_unique<ScanlineTable<2000>>();
  const Status s = t->BuildOmni(ReferenceOmniScanConfig(kCu, kCv), 640, 480);
  EXPECT_EQ(s.code(), StatusCode::kResourceExhausted);
  EXPECT_FALSE(t->built());
  EXPECT_EQ(t->pixel_count(), 0u);
  auto p = std::make_unique<ScanlineTable<2000>>();
  EXPECT_EQ(p->BuildPersp(ReferencePerspScanConfig(), 640, 480).code(),
            StatusCode::kResourceExhausted);
}

// The build keeps each row's columns in the table's unwritten tail: a table with a little room to
// spare is the same table, one too small is refused whole (never a partial or corrupt table).
enum class Fit { kMust, kMustNot, kEither };
template <size_t kCapacity>
void ExpectSameOrRefused(const std::vector<std::pair<int, int>>& want, Fit fit) {
  auto t = std::make_unique<ScanlineTable<kCapacity>>();
  const Status st = t->BuildOmni(ReferenceOmniScanConfig(kCu, kCv), 640, 480);
  EXPECT_FALSE(fit == Fit::kMustNot && st.ok()) << kCapacity;
  if (!st.ok()) {
    EXPECT_NE(fit, Fit::kMust) << kCapacity;
    EXPECT_EQ(st.code(), StatusCode::kResourceExhausted) << kCapacity;
    EXPECT_FALSE(t->built());
    return;
  }
  std::vector<std::pair<int, int>> got;
  ForEachScanPixel(*t, [&](int u, int v) { got.push_back({u, v}); });
  EXPECT_EQ(got, want) << kCapacity;
}

TEST(ScanlineTest, ATableWithLittleRoomToSpareIsTheSameTableOrRefusedWhole) {
  auto big = std::make_unique<ScanlineTable<kOmniScanPixels>>();
  ASSERT_TRUE(big->BuildOmni(ReferenceOmniScanConfig(kCu, kCv), 640, 480).ok());
  std::vector<std::pair<int, int>> want;
  ForEachScanPixel(*big, [&](int u, int v) { want.push_back({u, v}); });
  ASSERT_GT(want.size(), 15000u);
  ExpectSameOrRefused<15000>(want, Fit::kMustNot);  // fewer bytes than samples
  ExpectSameOrRefused<15100>(want, Fit::kEither);
  ExpectSameOrRefused<15200>(want, Fit::kEither);
  ExpectSameOrRefused<15400>(want, Fit::kEither);
  ExpectSameOrRefused<16000>(want, Fit::kMust);
  ExpectSameOrRefused<17001>(want, Fit::kMust);  // an odd capacity
}

// A large mirror ring on a 1280 x 960 frame: rows through the body leave gaps over 255 px (escape
// entries); the outer diameter sets how dense the outer samples are.
OmniScanConfig BigRing(float outer_diameter_px) {
  OmniScanConfig c;
  c.center_u = 640.3f;
  c.center_v = 480.2f;
  c.inner_radius_px = 300;
  c.outer_radius_px = 470;
  c.diameter.count = 2;
  c.diameter.at_px[0] = 300;
  c.diameter.at_px[1] = 470;
  c.diameter.diameter_px[0] = 24;
  c.diameter.diameter_px[1] = outer_diameter_px;
  return c;
}

// One hit(u, v, word, follows) of ForEachKeptPair.
struct KeptHit {
  int u, v;
  uint32_t w;
  bool follows;
  bool operator==(const KeptHit&) const = default;
};

// A YUYV frame of pseudo-random bytes.
std::vector<uint8_t> HashFrame(int w, int h, uint32_t seed) {
  std::vector<uint8_t> frame(static_cast<size_t>(w) * h * 2);
  for (uint8_t& b : frame) {
    seed = seed * 1664525u + 1013904223u;
    b = static_cast<uint8_t>(seed >> 24);
  }
  return frame;
}

TEST(ScanlineTest, KeptPairsAreTheKeptSamplesInOrderAndFollowsMeansTheSampleBeforeWasKept) {
  // A large mirror ring leaves gaps over 255 px (escape entries) on rows through the body; every
  // sample's pair word is a hash of its position, and a third of them are kept.
  constexpr int kW = 1280, kH = 960;
  auto t = std::make_unique<ScanlineTable<65535>>();
  ASSERT_TRUE(t->BuildOmni(BigRing(12.0f), kW, kH).ok());
  const std::vector<uint8_t> frame = HashFrame(kW, kH, 7);
  auto keep = [](uint32_t w) { return (w >> 8 & 0xFFu) % 3 == 0; };
  std::vector<KeptHit> want, got;
  int row_v = -1, in_row = 0, escapes = 0;
  bool prev_kept = false;
  t->ForEachSample(
      [&](int v) {
        row_v = v;
        in_row = 0;
      },
      [&](int u, bool restart) {
        uint32_t w;
        std::memcpy(&w, &frame[(static_cast<size_t>(row_v) * kW + (u & ~1)) * 2], 4);
        if (restart && in_row > 0) ++escapes;
        const bool k = keep(w);
        if (k) want.push_back({u, row_v, w, !restart && prev_kept});
        prev_kept = k;
        ++in_row;
      });
  t->ForEachKeptPair(frame.data(), kW * 2, keep, [&](int u, int v, uint32_t w, bool follows) {
    got.push_back({u, v, w, follows});
  });
  EXPECT_GT(escapes, 0) << "the pattern must exercise escape entries";
  ASSERT_GT(want.size(), 1000u);
  ASSERT_EQ(got.size(), want.size());
  for (size_t i = 0; i < want.size(); ++i) ASSERT_TRUE(got[i] == want[i]) << "hit " << i;
  int follows = 0;
  for (const KeptHit& h : got) follows += h.follows;
  EXPECT_GT(follows, 0);
}

TEST(ScanlineTest, KeptPairsInABoxAreTheSameCallsAsTheBoxTestedOneByOne) {
  // The chroma-box form (on x86-64 hosts with AVX2: 16 samples a step) against the generic loop
  // with the same box, on an omni table with escapes and a persp lattice: every call, in order.
  constexpr int kW = 1280, kH = 960;
  auto omni = std::make_unique<ScanlineTable<65535>>();
  ASSERT_TRUE(omni->BuildOmni(BigRing(4.0f), kW, kH).ok());
  auto persp = std::make_unique<ScanlineTable<65535>>();
  ASSERT_TRUE(persp->BuildPersp(ReferencePerspScanConfig(), kW, kH).ok());
  const std::vector<uint8_t> frame = HashFrame(kW, kH, 11);
  ChromaBox narrow;  // a ball-like box: few samples kept
  narrow.u_min = 40, narrow.u_max = 90, narrow.v_min = 150, narrow.v_max = 230;
  ChromaBox wide;  // most kept: runs of neighbours that follow each other
  wide.u_min = 10, wide.u_max = 250, wide.v_min = 5, wide.v_max = 240;
  ChromaBox wraps;  // min > max on U keeps every U
  wraps.u_min = 200, wraps.u_max = 20, wraps.v_min = 0, wraps.v_max = 120;
  for (const ScanlineTableBase* t : {static_cast<const ScanlineTableBase*>(omni.get()),
                                     static_cast<const ScanlineTableBase*>(persp.get())}) {
    for (const ChromaBox& b : {narrow, wide, wraps, ChromaBox{}}) {
      const PairChromaTest box(b);
      std::vector<KeptHit> want, got;
      t->ForEachKeptPair(
          frame.data(), kW * 2, [&box](uint32_t w) { return box.Holds(w); },
          [&](int u, int v, uint32_t w, bool follows) {
            want.push_back({u, v, w, follows});
          });
      t->ForEachKeptPair(frame.data(), kW * 2, box, [&](int u, int v, uint32_t w, bool follows) {
        got.push_back({u, v, w, follows});
      });
      ASSERT_GT(want.size(), 100u);
      ASSERT_EQ(got.size(), want.size());
      for (size_t i = 0; i < want.size(); ++i) ASSERT_TRUE(got[i] == want[i]) << "hit " << i;
    }
  }
}

}  // namespace
}  // namespace bv
