#include <gtest/gtest.h>

#include "hal/common/frame_pairer.h"

namespace bv::hal {
namespace {

TEST(FramePairer, PairsFramesWithinTolerance) {
  FramePairer p(PairerConfig{2000, 25000});
  PairDecision d;
  EXPECT_FALSE(p.TakePair(0, d));
  p.OnFrameComplete(CameraId::kOmni, 1000, 1, 0);
  EXPECT_FALSE(p.TakePair(1500, d)) << "waits for the partner";
  p.OnFrameComplete(CameraId::kPersp, 2500, 1, 0);
  ASSERT_TRUE(p.TakePair(3000, d));
  EXPECT_TRUE(d.has[0] && d.has[1]);
  EXPECT_EQ(d.flags, 0u);
  EXPECT_EQ(d.skew_us, 1500);
  EXPECT_EQ(d.exposure_us_pair, 1750u);
  EXPECT_FALSE(p.TakePair(3000, d)) << "a pair is served once";
}

TEST(FramePairer, FlagsOutOfSyncMissingAndOutOfOrder) {
  FramePairer p(PairerConfig{2000, 25000});
  PairDecision d;
  p.OnFrameComplete(CameraId::kOmni, 100000, 1, 0);
  p.OnFrameComplete(CameraId::kPersp, 110000, 1, 0);
  ASSERT_TRUE(p.TakePair(110000, d));
  EXPECT_EQ(d.flags, static_cast<uint32_t>(kPairOutOfSync));

  // Perspective camera stops: the omni frame is served alone once its partner is overdue.
  p.OnFrameComplete(CameraId::kOmni, 133000, 2, 1);
  EXPECT_FALSE(p.TakePair(140000, d));
  ASSERT_TRUE(p.TakePair(158000, d));
  EXPECT_EQ(d.flags, static_cast<uint32_t>(kPairPerspMissing));
  EXPECT_TRUE(d.has[0]);
  EXPECT_FALSE(d.has[1]);

  // A frame with an older timestamp than the last pair is flagged.
  p.OnFrameComplete(CameraId::kOmni, 50000, 3, 0);
  p.OnFrameComplete(CameraId::kPersp, 50000, 3, 0);
  ASSERT_TRUE(p.TakePair(160000, d));
  EXPECT_TRUE(d.flags & kPairOutOfOrder);
}

TEST(FramePairer, CountsOverwrittenFramesAsDropped) {
  FramePairer p;
  PairDecision d;
  p.OnFrameComplete(CameraId::kOmni, 0, 1, 0);
  p.OnFrameComplete(CameraId::kOmni, 33333, 2, 1);
  p.OnFrameComplete(CameraId::kOmni, 66666, 3, 0);
  EXPECT_EQ(p.pending_slot(CameraId::kOmni), 0);
  p.OnFrameComplete(CameraId::kPersp, 66666, 3, 0);
  ASSERT_TRUE(p.TakePair(70000, d));
  EXPECT_EQ(d.dropped, 2u);
  EXPECT_EQ(d.sequence[0], 3u);
  EXPECT_EQ(p.pending_slot(CameraId::kOmni), -1);
}

}  // namespace
}  // namespace bv::hal
