#pragma once
// The built-in scene of `ballvision demo`: a calibration of the reference rig made from its
// nominal constants (perspective intrinsics/pose from render/README.md; an ideal single-viewpoint
// mirror map for the omni camera), and frames drawn through the project's own camera models
// (core/calibration): every pixel's viewing ray is tested against the ball sphere.
#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "core/calibration/calibration.h"

namespace bv::cli {

/// Nominal calibration of the reference rig (no data files needed).
RigCalibration MakeDemoCalibration();

class DemoRenderer {
 public:
  /// Precomputes both background images (field, lines, robot body, hall).
  explicit DemoRenderer(const RigCalibration& cal);
  /// Draws the ball (centre in the robot frame) into YUYV images (640x480x2 each).
  /// `noise_seed` adds +-2 DN noise.
  void Render(const Eigen::Vector3f& ball_m, uint32_t noise_seed, std::vector<uint8_t>& omni_yuyv,
              std::vector<uint8_t>& persp_yuyv) const;
  /// The same with several balls (a decoy beside the ball).
  void Render(std::span<const Eigen::Vector3f> balls_m, uint32_t noise_seed,
              std::vector<uint8_t>& omni_yuyv, std::vector<uint8_t>& persp_yuyv) const;

 private:
  void DrawBall(int cam, const Eigen::Vector3f& ball, std::vector<uint8_t>& rgb) const;
  const RigCalibration& cal_;
  std::vector<uint8_t> omni_bg_, persp_bg_;  // RGB
};

/// Ball truth of the demo lob: kicked at t = 0 from (0.2, 5.5) towards the robot, bouncing with
/// restitution `b`, rolling after. Exact piecewise physics (no drag).
struct DemoTruth {
  Eigen::Vector3f p, v;
};
DemoTruth DemoLob(double t_s, double b, std::vector<double>* bounce_times = nullptr);

}  // namespace bv::cli
