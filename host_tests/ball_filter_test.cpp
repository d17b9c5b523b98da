#include "core/ball_filter/ball_filter.h"

#include <cmath>
#include <cstdint>
#include <vector>

#include <gtest/gtest.h>

namespace bv {
namespace {

constexpr float kR = 0.11f;
constexpr float kG = 9.81f;

uint64_t FrameUs(int k) { return static_cast<uint64_t>(std::llround(k * 1e6 / 30.0)); }

BallMeasurement Meas(uint64_t t_us, float x, float y, float z) {
  BallMeasurement m;
  m.t_us = t_us;
  m.p_m = Eigen::Vector3f(x, y, z);
  return m;
}

// Deterministic small noise in [-a, a].
float Noise(int k, int axis, float a) {
  const uint32_t h = static_cast<uint32_t>(k * 2654435761u) ^ static_cast<uint32_t>(axis * 40503u);
  return a * (static_cast<float>((h >> 8) % 2001u) / 1000.f - 1.f);
}

bool AllFinite(const BallState& s) {
  for (float v : {s.x_m, s.y_m, s.z_m, s.vx_mps, s.vy_mps, s.vz_mps, s.px_m, s.py_m, s.pz_m}) {
    if (!std::isfinite(v)) return false;
  }
  return true;
}

TEST(BallFilter, RollingConstantVelocityIsExact) {
  BallFilter f;
  BallState s;
  for (int k = 0; k < 20; ++k) {
    const float t = k / 30.f;
    ASSERT_EQ(f.Update(Meas(FrameUs(k), 0.5f + 1.f * t, 3.f - 2.f * t, kR)), 0);
    f.FillState(FrameUs(k), 200000, s);
    if (k < 2) continue;
    EXPECT_TRUE(s.found);
    EXPECT_EQ(s.mode, BallMode::kRolling);
    EXPECT_NEAR(s.vx_mps, 1.f, 1e-3f);
    EXPECT_NEAR(s.vy_mps, -2.f, 1e-3f);
    EXPECT_FLOAT_EQ(s.z_m, kR);
    EXPECT_FLOAT_EQ(s.vz_mps, 0.f);
    EXPECT_FALSE(s.flags & kFlagHasBounce);
    EXPECT_NEAR(s.px_m, 0.5f + (t + 0.2f), 1e-3f);
    EXPECT_NEAR(s.py_m, 3.f - 2.f * (t + 0.2f), 1e-3f);
  }
  EXPECT_EQ(f.window_size(), 10);
}

// Quadratic air drag as in the renderer: Cd 0.25, A 0.038 m^2, 0.43 kg, rho 1.2.
struct DragBall {
  Eigen::Vector3f p, v;
  void Step(float dt) {
    const float k = 0.5f * 1.2f * 0.25f * 0.038f / 0.43f;
    for (int i = 0; i < 100; ++i) {
      const float h = dt / 100.f;
      const Eigen::Vector3f a = -k * v.norm() * v - Eigen::Vector3f(0, 0, kG);
      v += a * h;
      p += v * h;
    }
  }
};

TEST(BallFilter, LobWithDragPredicts200msWithin5cmAndTouchdownWithin30ms) {
  // 6.6 m/s at 35 deg towards the robot from 6 m, 1 cm measurement noise.
  DragBall ball{Eigen::Vector3f(0.8f, 6.f, kR),
                Eigen::Vector3f(0, -6.6f * std::cos(0.6109f), 6.6f * std::sin(0.6109f))};
  std::vector<Eigen::Vector3f> truth;
  std::vector<uint64_t> times;
  double touchdown_s = -1;
  for (int k = 0; k < 60; ++k) {
    truth.push_back(ball.p);
    times.push_back(FrameUs(k));
    const Eigen::Vector3f before = ball.p;
    ball.Step(1.f / 30.f);
    if (touchdown_s < 0 && ball.p.z() < kR && k > 0) {
      touchdown_s = (k + (before.z() - kR) / (before.z() - ball.p.z())) / 30.0;
      break;
    }
  }
  ASSERT_GT(touchdown_s, 0.6);
  const int n = static_cast<int>(truth.size());
  BallFilter f;
  BallState s;
  int checked = 0;
  for (int k = 0; k < n; ++k) {
    const Eigen::Vector3f& p = truth[k];
    ASSERT_EQ(f.Update(Meas(times[k], p.x() + Noise(k, 0, 0.01f), p.y() + Noise(k, 1, 0.01f),
                            p.z() + Noise(k, 2, 0.01f))),
              0)
        << k;
    f.FillState(times[k], 200000, s);
    ASSERT_TRUE(AllFinite(s));
    if (k >= 6) {
      EXPECT_EQ(s.mode, BallMode::kFlying) << k;
      ASSERT_TRUE(s.flags & kFlagHasBounce) << k;
      EXPECT_NEAR(static_cast<double>(s.t_bounce_us) * 1e-6, touchdown_s, 0.03) << k;
    }
    if (k >= 6 && k + 6 < n) {
      const Eigen::Vector3f pred(s.px_m, s.py_m, s.pz_m);
      EXPECT_LT((pred - truth[k + 6]).norm(), 0.05f) << "frame " << k;
      ++checked;
    }
  }
  EXPECT_GE(checked, 5);
}

class VerticalBounce : public ::testing::TestWithParam<float> {};

TEST_P(VerticalBounce, BounceTimesModeAndRestitution) {
  const float b_true = GetParam();
  // Analytic drop from 1.2 m at (0, 2): contacts and arcs, v_out = b v_in.
  std::vector<double> contacts;
  double t0 = 0, z0 = 1.2, v0 = 0;
  auto height = [&](double t, double& vz) {
    double ts = 0, zs = 1.2, vs = 0;
    for (;;) {
      const double s = (vs + std::sqrt(vs * vs + 2 * kG * (zs - kR))) / kG;
      if (t < ts + s || (ts > 0 && vs < 0.3)) {
        const double u = std::min(t - ts, s);
        vz = vs - kG * u;
        return zs + vs * u - 0.5 * kG * u * u;
      }
      ts += s;
      vs = b_true * std::fabs(vs - kG * s);
      zs = kR;
    }
  };
  (void)t0;
  (void)z0;
  (void)v0;
  {
    double ts = 0, zs = 1.2, vs = 0;
    for (int i = 0; i < 4; ++i) {
      const double s = (vs + std::sqrt(vs * vs + 2 * kG * (zs - kR))) / kG;
      ts += s;
      contacts.push_back(ts);
      vs = b_true * std::fabs(vs - kG * s);
      zs = kR;
    }
  }
  BallFilterConfig cfg;
  cfg.bounce_factor = 0.7f;  // configured guess; estimated from the bounces
  BallFilter f(cfg);
  BallState s;
  bool saw_bouncing = false;
  for (int k = 0; k < 75; ++k) {
    const double t = k / 30.0;
    double vz;
    const double z = height(t, vz);
    ASSERT_EQ(f.Update(Meas(FrameUs(k), Noise(k, 0, 0.005f), 2.f + Noise(k, 1, 0.005f),
                            static_cast<float>(z) + Noise(k, 2, 0.005f))),
              0);
    f.FillState(FrameUs(k), 200000, s);
    ASSERT_TRUE(AllFinite(s));
    if (s.mode == BallMode::kBouncing) saw_bouncing = true;
    // Next-contact prediction, checked from 4 frames after the previous contact.
    for (size_t c = 0; c < contacts.size(); ++c) {
      const double prev = c == 0 ? 0.0 : contacts[c - 1];
      if (t >= prev + 4 / 30.0 && t < contacts[c] - 1e-3) {
        ASSERT_TRUE(s.flags & kFlagHasBounce) << "t=" << t;
        EXPECT_NEAR(static_cast<double>(s.t_bounce_us) * 1e-6, contacts[c], 0.02) << "t=" << t;
        EXPECT_NEAR(s.vz_mps, vz, 0.15) << "t=" << t;
        break;
      }
    }
  }
  EXPECT_TRUE(saw_bouncing);
  EXPECT_NEAR(f.bounce_factor(), b_true, 0.05f);
  // Two seconds later with the same pattern the bounce dies out into rolling.
  for (int k = 75; k < 180; ++k) {
    double vz;
    const double z = height(k / 30.0, vz);
    f.Update(Meas(FrameUs(k), 0, 2.f, static_cast<float>(z)));
  }
  f.FillState(FrameUs(179), 200000, s);
  EXPECT_EQ(s.mode, BallMode::kRolling);
  EXPECT_NEAR(s.z_m, kR, 1e-6f);
}

INSTANTIATE_TEST_SUITE_P(Restitution, VerticalBounce, ::testing::Values(0.6f, 0.7f, 0.8f));

TEST(BallFilter, KickChangesDirectionWithin4Frames) {
  BallFilter f;
  BallState s;
  float x = 0, y = 2;
  int k = 0;
  for (; k < 20; ++k, x += 1.f / 30.f) {
    f.Update(Meas(FrameUs(k), x, y, kR));
  }
  f.FillState(FrameUs(k - 1), 0, s);
  EXPECT_NEAR(s.vx_mps, 1.f, 1e-3f);
  // Kick: from now on (-2, 3) m/s.
  for (int j = 0; j < 4; ++j, ++k) {
    x += -2.f / 30.f;
    y += 3.f / 30.f;
    EXPECT_EQ(f.Update(Meas(FrameUs(k), x, y, kR)), 0);
  }
  f.FillState(FrameUs(k - 1), 0, s);
  EXPECT_NEAR(s.vx_mps, -2.f, 0.1f);
  EXPECT_NEAR(s.vy_mps, 3.f, 0.1f);
  EXPECT_LT(f.window_size(), 5);  // the window was shrunk
}

TEST(BallFilter, StoppingBallReachesZeroVelocity) {
  BallFilter f;
  BallState s;
  int k = 0;
  float y = 1;
  for (; k < 15; ++k, y += 0.05f) f.Update(Meas(FrameUs(k), 0.3f, y, kR));
  for (int j = 0; j < 10; ++j, ++k) f.Update(Meas(FrameUs(k), 0.3f, y, kR));
  f.FillState(FrameUs(k - 1), 200000, s);
  EXPECT_NEAR(s.vx_mps, 0.f, 1e-4f);
  EXPECT_NEAR(s.vy_mps, 0.f, 1e-4f);
  EXPECT_NEAR(s.py_m, y, 1e-4f);
  EXPECT_EQ(s.mode, BallMode::kRolling);
}

TEST(BallFilter, BadInputIsRejectedAndTrackRecovers) {
  BallFilter f;
  BallState s;
  int k = 0;
  auto truth_x = [](int i) { return 0.5f * i / 30.f; };
  for (; k < 10; ++k) ASSERT_EQ(f.Update(Meas(FrameUs(k), truth_x(k), 3, kR)), 0);
  // Repeated and out-of-order timestamps.
  EXPECT_EQ(f.Update(Meas(FrameUs(k - 1), 9, 9, kR)), kFlagBadTimestamp);
  EXPECT_EQ(f.Update(Meas(FrameUs(k - 3), 9, 9, kR)), kFlagBadTimestamp);
  // NaN and a detection 40 m away.
  EXPECT_EQ(f.Update(Meas(FrameUs(k), std::nanf(""), 3, kR)), kFlagOutlierRejected);
  EXPECT_EQ(f.Update(Meas(FrameUs(k), 40, 3, kR)), kFlagOutOfField);
  EXPECT_EQ(f.Update(Meas(FrameUs(k), 0, 3, 50)), kFlagOutOfField);
  // A single outlier 3 m away.
  EXPECT_EQ(f.Update(Meas(FrameUs(k), truth_x(k) + 3.f, 3, kR)), kFlagOutlierRejected);
  ++k;
  EXPECT_EQ(f.Update(Meas(FrameUs(k), truth_x(k), 3, kR)), 0);
  f.FillState(FrameUs(k), 0, s);
  EXPECT_NEAR(s.x_m, truth_x(k), 1e-3f);
  EXPECT_NEAR(s.vx_mps, 0.5f, 1e-3f);
  // Coasting, then lost after 0.5 s without measurements.
  f.FillState(FrameUs(k + 6), 0, s);
  EXPECT_TRUE(s.found);
  EXPECT_TRUE(s.flags & kFlagCoasting);
  EXPECT_NEAR(s.x_m, truth_x(k + 6), 1e-3f);
  f.FillState(FrameUs(k + 20), 0, s);
  EXPECT_FALSE(s.found);
  EXPECT_TRUE(s.flags & kFlagLost);
  // 2 s gap: a new track starts where the ball is now; velocity known after 2 frames.
  k += 60;
  EXPECT_EQ(f.Update(Meas(FrameUs(k), -2, 1, kR)), 0);
  EXPECT_EQ(f.Update(Meas(FrameUs(k + 1), -2.f + 0.1f, 1, kR)), 0);
  f.FillState(FrameUs(k + 1), 0, s);
  EXPECT_TRUE(s.found);
  EXPECT_FALSE(s.flags & (kFlagCoasting | kFlagLost));
  EXPECT_NEAR(s.x_m, -1.9f, 1e-4f);
  EXPECT_NEAR(s.vx_mps, 3.f, 1e-3f);
  ASSERT_TRUE(AllFinite(s));
}

TEST(BallFilter, ConfirmedJumpStartsANewTrack) {
  BallFilter f;
  BallState s;
  int k = 0;
  for (; k < 10; ++k) f.Update(Meas(FrameUs(k), 0, 3, kR));
  EXPECT_EQ(f.Update(Meas(FrameUs(k++), 3, 1, kR)), kFlagOutlierRejected);
  EXPECT_EQ(f.Update(Meas(FrameUs(k), 3, 1, kR)), 0);  // confirmed: it really is there
  f.FillState(FrameUs(k), 0, s);
  EXPECT_NEAR(s.x_m, 3.f, 1e-4f);
  EXPECT_NEAR(s.y_m, 1.f, 1e-4f);
  EXPECT_NEAR(s.vx_mps, 0.f, 1e-3f);
}

TEST(BallFilter, NoTrackMeansNotFound) {
  BallFilter f;
  BallState s;
  f.FillState(1000, 200000, s);
  EXPECT_FALSE(s.found);
  EXPECT_EQ(s.mode, BallMode::kNone);
  Eigen::Vector3f p, v;
  BallMode m;
  EXPECT_FALSE(f.StateAt(0, p, v, m));
}

TEST(BallFilter, ZAssumedMeasurementsOnlyInformXY) {
  BallFilter f;
  BallState s;
  // A flying ball; every other frame only the horizontal position is known.
  for (int k = 0; k < 12; ++k) {
    const float t = k / 30.f;
    BallMeasurement m = Meas(FrameUs(k), t, 2.f, 1.f + 3.f * t - 0.5f * kG * t * t);
    if (k % 2) {
      m.z_valid = false;
      m.p_m.z() = kR;  // wrong on purpose; must be ignored
    }
    EXPECT_EQ(f.Update(m), 0);
  }
  const float t = 11 / 30.f;
  f.FillState(FrameUs(11), 0, s);
  EXPECT_EQ(s.mode, BallMode::kFlying);
  EXPECT_NEAR(s.z_m, 1.f + 3.f * t - 0.5f * kG * t * t, 1e-3f);
  EXPECT_NEAR(s.vz_mps, 3.f - kG * t, 1e-2f);
  EXPECT_NEAR(s.vx_mps, 1.f, 1e-3f);
}

}  // namespace
}  // namespace bv
