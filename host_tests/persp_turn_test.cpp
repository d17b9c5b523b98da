// A turned persp camera told from balls on the floor (core/health/persp_turn.h): synthetic
// floor points seen through a camera turned after calibration, with ray noise and outliers.
#include "core/health/persp_turn.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include "core/pipeline.h"
#include "tools/ballvision/demo_scene.h"
#include "tools/ballvision/run_common.h"

namespace bv {
namespace {

constexpr float kBallRadius = 0.11f;
constexpr float kRad = 3.14159265f / 180.0f;

// The reference rig's persp camera: 0.5 m up, looking along +y, pitched down 8 degrees.
PerspCalibration Camera() {
  PerspCalibration c;
  c.valid = true;
  c.fx = c.fy = 500, c.cx = 320, c.cy = 240;
  // Camera x right, y down, z forward -> robot: x = x_c, forward +y = z_c, up = -y_c.
  Eigen::Matrix3f base;
  base << 1, 0, 0, 0, 0, 1, 0, -1, 0;
  c.R_robot_cam = Eigen::AngleAxisf(-8 * kRad, Eigen::Vector3f::UnitX()).toRotationMatrix() * base;
  c.t_robot_cam = Eigen::Vector3f(0, 0.1f, 0.5f);
  return c;
}

struct Scene {
  float pitch_deg = 0, yaw_deg = 0;  // the true turn since calibration
  float noise_mrad = 1.5f;           // per ray, both cameras
  float outliers = 0;                // share of samples with a wrong omni point (another object)
  float height_m = kBallRadius;      // the ball's centre: above the radius, it is in the air
  float omni_elevation_deg = 0;      // a knocked mirror: the omni rays' elevation error
};

// Feeds n floor samples; returns the watch.
void Feed(PerspTurnWatch& w, const Scene& s, int n, uint32_t seed = 3) {
  const PerspCalibration cal = Camera();
  const Eigen::Vector3f right = cal.R_robot_cam.col(0);
  // Calibrated ray of a true direction: the pixel was made by the turned camera.
  const Eigen::Matrix3f turn = (Eigen::AngleAxisf(s.yaw_deg * kRad, Eigen::Vector3f::UnitZ()) *
                                Eigen::AngleAxisf(s.pitch_deg * kRad, right))
                                   .toRotationMatrix();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> range(1.0f, 5.0f), az(-35.f, 35.f), u01(0.f, 1.f);
  std::normal_distribution<float> noise(0.f, s.noise_mrad * 1e-3f), size_noise(0.f, 0.03f);
  const Eigen::Vector3f mirror(0, 0, 0.78f);
  for (int i = 0; i < n; ++i) {
    const float r = range(rng), a = (90.f + az(rng)) * kRad;
    const Eigen::Vector3f p(r * std::cos(a), r * std::sin(a), s.height_m);
    Ray omni{mirror, (p - mirror).normalized()};
    // An outlier: the omni camera's region is something else beside the ball (same range).
    if (u01(rng) < s.outliers) omni.dir = (p + Eigen::Vector3f(0.3f, 0, 0) - mirror).normalized();
    omni.dir = (omni.dir + Eigen::Vector3f(noise(rng), noise(rng), noise(rng))).normalized();
    if (s.omni_elevation_deg != 0) {
      const Eigen::Vector3f axis = Eigen::Vector3f::UnitZ().cross(omni.dir).normalized();
      omni.dir = Eigen::AngleAxisf(s.omni_elevation_deg * kRad, axis) * omni.dir;
    }
    Ray persp{cal.t_robot_cam, turn.transpose() * (p - cal.t_robot_cam).normalized()};
    persp.dir = (persp.dir + Eigen::Vector3f(noise(rng), noise(rng), noise(rng))).normalized();
    const float size_range = (p - cal.t_robot_cam).norm() * (1.0f + size_noise(rng));
    w.AddFloorSample(omni, persp, size_range, kBallRadius);
  }
}

TEST(PerspTurn, AnUnchangedCameraStaysAsCalibrated) {
  PerspTurnWatch w;
  w.Init(Camera(), PerspTurnConfig{});
  Feed(w, Scene{}, 200);
  EXPECT_EQ(w.state(), CameraState::kAsCalibrated);
  EXPECT_LT(w.change_deg(), 0.15f);
  EXPECT_GT(w.confidence(), 0.9f);
}

TEST(PerspTurn, OneDegreeOfPitchIsEstimatedAndCorrected) {
  PerspTurnWatch w;
  w.Init(Camera(), PerspTurnConfig{});
  Feed(w, Scene{1.0f, 0.0f}, 11);
  EXPECT_EQ(w.state(), CameraState::kAsCalibrated) << "no verdict before 12 samples";
  Feed(w, Scene{1.0f, 0.0f}, 40, 5);
  EXPECT_EQ(w.state(), CameraState::kCorrected);
  EXPECT_NEAR(w.pitch_rad() / kRad, 1.0f, 0.1f);
  EXPECT_NEAR(w.yaw_rad() / kRad, 0.0f, 0.1f);
  EXPECT_NEAR(w.change_deg(), 1.0f, 0.1f);
  // The corrected model is the turned camera.
  const PerspCalibration truth = Camera();
  const Eigen::Matrix3f turned =
      Eigen::AngleAxisf(1.0f * kRad, truth.R_robot_cam.col(0)).toRotationMatrix() *
      truth.R_robot_cam;
  const Eigen::Matrix3f diff = turned.transpose() * w.model().R_robot_cam;
  EXPECT_LT(Eigen::AngleAxisf(diff).angle() / kRad, 0.1f);
}

TEST(PerspTurn, YawAndOutliersTooAndTheSizeDecidesTheState) {
  struct Case {
    Scene scene;
    bool correct;
    CameraState want;
  };
  const Case cases[] = {
      {{0.6f, -0.8f, 1.5f, 0.25f}, true, CameraState::kCorrected},  // a quarter outliers
      {{1.0f, 0.0f}, false, CameraState::kChanged},                 // correction off
      {{4.0f, 0.0f}, true, CameraState::kChanged},                  // beyond correction
      {{10.0f, 0.0f}, true, CameraState::kUnusable},                // the 10 degrees
  };
  for (const Case& c : cases) {
    PerspTurnWatch w;
    PerspTurnConfig config;
    config.correct = c.correct;
    w.Init(Camera(), config);
    Feed(w, c.scene, 64);
    EXPECT_EQ(w.state(), c.want) << c.scene.pitch_deg << " " << c.scene.yaw_deg;
    const float want_deg = std::hypot(c.scene.pitch_deg, c.scene.yaw_deg);
    EXPECT_NEAR(w.change_deg(), want_deg, 0.1f * want_deg + 0.05f);
    if (c.want != CameraState::kCorrected) {
      EXPECT_EQ(w.model().R_robot_cam, Camera().R_robot_cam) << "only a correction turns the model";
    }
  }
}

TEST(PerspTurn, AKnockedMirrorFlagsTheOmniCameraAndDoesNotTurnThePersp) {
  PerspTurnWatch w;
  w.Init(Camera(), PerspTurnConfig{});
  Scene knocked;
  knocked.omni_elevation_deg = 3.0f;  // rays 3 deg up: floor points far too far
  Feed(w, knocked, 64);
  EXPECT_EQ(w.omni_state(), CameraState::kChanged);
  EXPECT_NEAR(w.omni_change_deg(), 3.0f, 0.5f);
  EXPECT_EQ(w.state(), CameraState::kAsCalibrated);
  // A turned persp camera is not a knocked mirror: its size's range does not move.
  PerspTurnWatch turned;
  turned.Init(Camera(), PerspTurnConfig{});
  Feed(turned, Scene{1.0f, 0.0f}, 64);
  EXPECT_EQ(turned.omni_state(), CameraState::kAsCalibrated);
  EXPECT_EQ(turned.state(), CameraState::kCorrected);
}

TEST(PerspTurn, ABallInTheAirIsNoFloorSample) {
  PerspTurnWatch w;
  w.Init(Camera(), PerspTurnConfig{});
  Scene flying;
  flying.height_m = 0.5f;  // the omni ray meets the floor plane far behind it
  Feed(w, flying, 200);
  EXPECT_EQ(w.samples(), 0);
  EXPECT_EQ(w.state(), CameraState::kAsCalibrated);
}

TEST(PerspTurn, WithoutFloorSamplesNothingDriftsAndResetForgets) {
  PerspTurnWatch w;
  w.Init(Camera(), PerspTurnConfig{});
  Feed(w, Scene{1.0f, 0.0f}, 40);
  const float deg = w.change_deg();
  // A ball in the air: the omni ray never comes down to the floor plane; too near, too far.
  const PerspCalibration cal = Camera();
  for (int i = 0; i < 50; ++i) {
    w.AddFloorSample(Ray{{0, 0, 0.78f}, Eigen::Vector3f(0, 1, 0.2f).normalized()},
                     Ray{cal.t_robot_cam, Eigen::Vector3f(0, 1, 0)}, 3.0f, kBallRadius);
    w.AddFloorSample(Ray{{0, 0, 0.78f}, Eigen::Vector3f(0, 0.2f, -1).normalized()},
                     Ray{cal.t_robot_cam, Eigen::Vector3f(0, 1, -1).normalized()}, 0.4f,
                     kBallRadius);
    w.AddFloorSample(Ray{{0, 0, 0.78f}, Eigen::Vector3f(0, 1, -0.01f).normalized()},
                     Ray{cal.t_robot_cam, Eigen::Vector3f(0, 1, 0)}, 3.0f, kBallRadius);
  }
  EXPECT_EQ(w.change_deg(), deg);
  EXPECT_EQ(w.state(), CameraState::kCorrected);
  w.Reset();
  EXPECT_EQ(w.state(), CameraState::kAsCalibrated);
  EXPECT_EQ(w.samples(), 0);
  EXPECT_EQ(w.model().R_robot_cam, Camera().R_robot_cam);
}

// ---- The whole pipeline on frames drawn by the demo rig whose persp camera was turned after
// calibration: the pipeline runs with the calibration, the frames come from the turned rig. ----

struct RollResult {
  int corrected_at = -1;  // first frame in state kCorrected
  float last_deg = 0;
  float median_err_m = 0;  // 3D error over the last third
  bool ever_flagged = false;
};

// A ball rolling at 1.5 m/s across the persp camera's view, 3 s at 30 Hz.
enum class Watch { kOff, kFlagOnly, kCorrect };

RollResult Roll(float pitch_deg, Watch watch) {
  const RigCalibration cal = cli::MakeDemoCalibration();
  RigCalibration turned = cal;
  turned.persp.R_robot_cam =
      Eigen::AngleAxisf(pitch_deg * kRad, cal.persp.R_robot_cam.col(0)).toRotationMatrix() *
      cal.persp.R_robot_cam;
  const cli::DemoRenderer renderer(turned);
  auto lut = std::make_unique<ColorLut>();
  cli::FillBuiltInLut(*lut);
  auto pipeline = std::make_unique<OwnedPipeline>();
  PipelineConfig config;
  config.persp_turn.enabled = watch != Watch::kOff;
  config.persp_turn.correct = watch == Watch::kCorrect;
  EXPECT_TRUE(pipeline->Init(cal, *lut, config).ok());
  std::vector<uint8_t> omni, persp;
  RollResult r;
  std::vector<float> errs;
  constexpr int kFrames = 90;
  for (int k = 0; k < kFrames; ++k) {
    const float t = static_cast<float>(k) / 30.f;
    // Zig-zag across the view, 1.5-4 m ahead: the samples must be spread to fit pitch and yaw.
    const Eigen::Vector3f ball(-1.2f + 2.4f * std::fabs(std::fmod(t * 0.6f, 2.f) - 1.f),
                               1.5f + 0.85f * t, kBallRadius);
    renderer.Render(ball, static_cast<uint32_t>(k + 1), omni, persp);
    FrameInput in;
    in.t_us = 1000000 + static_cast<uint64_t>(k) * 33333;
    in.omni = MakeYuyvImage(omni.data(), 640, 480);
    in.persp = MakeYuyvImage(persp.data(), 640, 480);
    BallState s;
    EXPECT_TRUE(pipeline->Process(in, s).ok());
    r.ever_flagged |= s.persp_check.state != CameraState::kAsCalibrated;
    if (s.persp_check.state == CameraState::kCorrected && r.corrected_at < 0) r.corrected_at = k;
    r.last_deg = s.persp_check.change_deg;
    if (k >= 2 * kFrames / 3 && s.found) {
      errs.push_back((Eigen::Vector3f(s.x_m, s.y_m, s.z_m) - ball).norm());
    }
  }
  EXPECT_GE(errs.size(), 25u);
  std::sort(errs.begin(), errs.end());
  r.median_err_m = errs.empty() ? 1e9f : errs[errs.size() / 2];
  std::printf(
      "persp pitched %.1f deg, watch %s: corrected at frame %d, estimate %.2f deg, "
      "3D error over the last second %.1f cm (median)\n",
      pitch_deg,
      watch == Watch::kOff        ? "off"
      : watch == Watch::kFlagOnly ? "flag only"
                                  : "on",
      r.corrected_at, r.last_deg, 100.f * r.median_err_m);
  return r;
}

TEST(PerspTurnPipeline, AOneDegreePitchIsCorrectedWithinTwoSecondsAndTheBallComesBack) {
  const RollResult unchanged = Roll(0.0f, Watch::kCorrect);
  EXPECT_FALSE(unchanged.ever_flagged);
  EXPECT_LT(unchanged.last_deg, 0.2f);
  const RollResult on = Roll(1.0f, Watch::kCorrect);
  const RollResult flagged = Roll(1.0f, Watch::kFlagOnly);  // down-weighted: the omni carries it
  const RollResult off = Roll(1.0f, Watch::kOff);
  EXPECT_GE(on.corrected_at, 0);
  EXPECT_LE(on.corrected_at, 60);
  EXPECT_NEAR(on.last_deg, 1.0f, 0.2f);
  EXPECT_LT(on.median_err_m, 1.5f * unchanged.median_err_m + 0.005f);
  EXPECT_LT(flagged.median_err_m, 1.5f * unchanged.median_err_m + 0.005f);
  EXPECT_GT(off.median_err_m, 2.0f * on.median_err_m);
}

}  // namespace
}  // namespace bv
