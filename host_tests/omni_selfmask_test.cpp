// The omni self-mask learned from the calibration run (tools/ballvision/calib_omni_selfmask.h),
// scored against the renderer's own mask of the robot (sim/calib_omni/omni_selfmask.png).
#include "tools/ballvision/calib_omni_selfmask.h"

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "hal/host/sequence.h"

namespace bv::cli::omni {
namespace {

namespace fs = std::filesystem;

const std::string kSeq = std::string(BV_SHARED_DATA_DIR) + "/sim/calib_omni";

float AngleGapDeg(float a, float b) {
  const float d = std::fmod(std::fabs(a - b), 360.0f);
  return std::min(d, 360.0f - d);
}

class SelfMaskTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(kSeq + "/omni_selfmask.png")) GTEST_SKIP() << "shared data missing: " << kSeq;
    std::string error;
    ASSERT_TRUE(LoadFrames(kSeq, frames_, error)) << error;
    ASSERT_TRUE(FindCentre(frames_, rim_, error)) << error;
  }
  std::vector<Frame> frames_;
  RimFit rim_;
};

TEST_F(SelfMaskTest, TheReferenceRigsBodyStrutsAndRimAreLearned) {
  SelfMaskResult r;
  std::string error;
  ASSERT_TRUE(LearnSelfMask(frames_, rim_, r, error)) << error;
  const OmniSelfMask& m = r.mask;
  ASSERT_TRUE(m.known);
  EXPECT_LT(r.unchanged_fraction, 0.06);
  // The renderer's mask: body to r ~ 52 px, rim at ~ 220 px, struts at 14.5, 134.8, 256.5 deg.
  EXPECT_NEAR(m.inner_radius_px, 54.0f, 4.0f);
  EXPECT_NEAR(m.outer_radius_px, 219.0f, 3.0f);
  ASSERT_EQ(m.sector_count, 3);
  const float truth[] = {14.5f, 134.8f, 256.5f};
  for (int i = 0; i < 3; ++i) {
    EXPECT_LT(AngleGapDeg(m.sectors[i].angle_deg, truth[i]), 1.5f) << i;
    EXPECT_GE(m.sectors[i].half_width_deg, 1.5f) << i;
    EXPECT_LE(m.sectors[i].half_width_deg, 4.0f) << i;
  }
  // Pixel by pixel inside the mirror.
  std::vector<uint8_t> yuyv;
  int w = 0, h = 0;
  ASSERT_TRUE(host::LoadYuyv(kSeq + "/omni_selfmask.png", yuyv, w, h, error)) << error;
  ASSERT_EQ(w, r.self.cols);
  long in = 0, agree = 0;
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      if (std::hypot(u - rim_.cu, v - rim_.cv) > 215.0) continue;
      const bool truth_self = yuyv[(static_cast<size_t>(v) * w + u) * 2] > 127;
      ++in;
      agree += truth_self == (r.self(v, u) != 0);
    }
  }
  EXPECT_GT(static_cast<double>(agree) / static_cast<double>(in), 0.97);
}

TEST_F(SelfMaskTest, ARobotThatDidNotTurnIsSaidAndNothingIsLearned) {
  std::vector<Frame> still(12, frames_[0]);
  SelfMaskResult r;
  std::string error;
  EXPECT_FALSE(LearnSelfMask(still, rim_, r, error));
  EXPECT_NE(error.find("did the robot turn"), std::string::npos) << error;
  still.resize(5);
  EXPECT_FALSE(LearnSelfMask(still, rim_, r, error));
  EXPECT_NE(error.find("at least 8 frames"), std::string::npos) << error;
}

}  // namespace
}  // namespace bv::cli::omni
