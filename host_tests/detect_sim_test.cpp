// Front end on the rendered sequences (../shared/data/sim): the committed sim LUT regenerates
// byte for byte, and ball detection on the held-out frames (odd indices; the LUT was trained on
// the even ones) meets the accuracy target: centre within 1 px of truth (visible-part centroid
// cu/cv) where the ball is >= 4 px.
#include <gtest/gtest.h>

#include <sys/stat.h>
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>
#include <vector>

#include "core/color_lut/color_lut.h"
#include "tools/ballvision/lut_train.h"

namespace bv {
namespace {

const std::string kSim = std::string(BV_SHARED_DATA_DIR) + "/sim";
const std::string kLutPath = std::string(BV_TEST_DATA_DIR) + "/luts/sim_orange.lut";

bool HaveSim() {
  struct stat st;
  return stat((kSim + "/clutter/truth.csv").c_str(), &st) == 0;
}

std::vector<uint8_t> ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), {});
}

// The same sources and options as the command in host_tests/data/luts/README.md.
TEST(DetectSimTest, CommittedLutRegeneratesIdentically) {
  if (!HaveSim()) GTEST_SKIP() << "no rendered data at " << kSim;
  lut::Trainer t;
  std::string err;
  for (const char* seq : {"static_grid", "bounce", "clutter"}) {
    for (lut::Camera c : {lut::Camera::kOmni, lut::Camera::kPersp}) {
      ASSERT_GT(lut::AddSimSequence(t, kSim + "/" + seq, c, 2, 0, err), 0) << err;
    }
  }
  ASSERT_GT(lut::AddSimSequence(t, kSim + "/calib_omni", lut::Camera::kOmni, 10, 0, err), 0) << err;
  auto lut = std::make_unique<ColorLut>(t.Build());
  std::vector<uint8_t> blob(kColorLutBlobBytes);
  ASSERT_TRUE(SerializeLut(*lut, blob).ok());
  EXPECT_EQ(blob, ReadFile(kLutPath))
      << "regenerate with the command in host_tests/data/luts/README.md";
}

TEST(DetectSimTest, HeldOutFramesMeetTheAccuracyTarget) {
  if (!HaveSim()) GTEST_SKIP() << "no rendered data at " << kSim;
  auto lut = std::make_unique<ColorLut>();
  ASSERT_TRUE(ParseLut(ReadFile(kLutPath), *lut).ok());
  lut::FinderSetup setup;
  setup.omni = ReferenceOmniScanConfig(314.2f, 244.1f);  // rig mirror circle (render/README.md)
  setup.persp = ReferencePerspScanConfig();
  int ball = 0, found = 0, within = 0, false_det = 0, frames = 0;
  double pixels = 0;
  for (const char* seq : {"static_grid", "bounce", "clutter"}) {
    for (lut::Camera c : {lut::Camera::kOmni, lut::Camera::kPersp}) {
      lut::EvalCounts e;
      std::string err;
      ASSERT_TRUE(lut::EvalSim(kSim + "/" + seq, c, *lut, setup, 2, 1, e, err)) << err;
      std::printf("%-11s %-5s ball frames %3d  found %3d  within 1 px %3d  false %d  missed %d\n",
                  seq, c == lut::Camera::kOmni ? "omni" : "persp", e.ball_frames, e.found_on_ball,
                  e.within_1px, e.false_det, e.missed);
      ball += e.ball_frames;
      found += e.found_on_ball;
      within += e.within_1px;
      false_det += e.false_det;
      frames += e.frames;
      pixels += e.pixels_read_sum;
      if (c == lut::Camera::kOmni) {
        EXPECT_EQ(e.overflows, 0u);
      }
    }
  }
  const double within_frac = static_cast<double>(within) / ball;
  std::printf(
      "all: %d ball frames, found %.1f %%, within 1 px %.1f %%, false %d, pixels read %.2f %%\n",
      ball, 100.0 * found / ball, 100.0 * within_frac, false_det,
      100.0 * pixels / frames / (kFrameWidth * kFrameHeight));
  EXPECT_GT(ball, 100);
  EXPECT_GE(within_frac, 0.9);
  EXPECT_GE(static_cast<double>(found) / ball, 0.95);
  EXPECT_LE(false_det, 3);
}

}  // namespace
}  // namespace bv
