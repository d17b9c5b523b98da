#pragma once
// A perspective camera turned on the robot (issue 40 B4/B5), told from a ball on the floor: the
// omni camera's ray to it meets the floor plane (z = ball radius) at P, and the persp camera's
// ray should point at P. Both cameras look out at the ball from the robot's axis, so their rays
// lie nearly in one vertical plane: a persp camera pitched by 1 degree moves where they cross
// along the omni ray and hardly opens the ray gap, but it turns the persp ray away from P by
// that degree. A fixed window of such floor samples gives the camera's pitch (about its own
// right axis) and yaw (about the robot's vertical) by least squares, trimmed of outliers; a
// bounded change is corrected by rotating the camera model, a larger one flags the camera.
#include <cstdint>

#include <Eigen/Core>

#include "core/calibration/calibration.h"
#include "core/common/ball_state.h"

namespace bv {

struct PerspTurnConfig {
  bool enabled = true;
  bool correct = true;  // false: flag only (state kChanged), the model stays as calibrated
  int min_samples = 12;
  float min_range_m = 0.6f, max_range_m = 6.0f;  // floor samples, horizontal range from the persp
  float flag_deg = 0.4f;                         // a change at least this large is reported
  float correct_max_deg = 3.0f;  // corrected up to this; beyond, kChanged (not corrected)
  float unusable_deg = 6.0f;     // beyond: kUnusable (the camera is not used)
  float trim_deg = 0.5f;         // samples this far from the robust start are left out of the fit
  // A new sample only this far from the last one's floor point: a ball at rest is one sample,
  // not a window full of the same (possibly half-hidden) view.
  float min_spacing_m = 0.1f;
  // The ball is on the floor when the persp camera's range from its apparent size agrees with
  // the omni floor point's this well: a ball 5 cm up at 3 m passes (its sample errs by 0.2 deg,
  // within trim_deg), one 20 cm up lands 40 % farther. Pitch does not move the size's range.
  float floor_size_gate = 0.08f;
  // The omni camera's side of the same comparison (a knocked mirror): a ball the persp camera
  // alone puts on the floor (its ray at its size's range, within omni_floor_z_m of the radius)
  // whose omni floor point's range is off by more than omni_range_gate in the median of the
  // window flags the omni camera kChanged. A persp turn does not move the size's range.
  float omni_floor_z_m = 0.1f;
  float omni_range_gate = 0.12f;
  // The same ball, not a decoy elsewhere: its omni floor point near the persp ray's azimuth (a
  // wrong floor range moves it by a few degrees: the persp camera sits 0.1 m ahead of the axis).
  float omni_azimuth_gate_deg = 6.0f;
};

class PerspTurnWatch {
 public:
  static constexpr int kWindow = 32;

  /// `persp` is the calibrated camera (its right axis is the pitch axis). Forgets every sample.
  void Init(const PerspCalibration& persp, const PerspTurnConfig& config);
  void Reset();
  /// A ball seen by both cameras: the omni ray, the calibrated (uncorrected) persp ray and the
  /// persp camera's range to it from its apparent size. Ignored unless the omni ray comes down
  /// to the floor plane at a point whose range agrees with the size's (floor_size_gate), within
  /// the config's ranges and min_spacing_m from the last sample. Re-estimates the turn.
  /// `omni_suspect`: other evidence says the mirror moved (its rim): the sample feeds the omni
  /// side only.
  void AddFloorSample(const Ray& omni, const Ray& persp, float size_range_m, float ball_radius_m,
                      bool omni_suspect = false);
  /// kAsCalibrated, kCorrected, kChanged or kUnusable (from the samples so far).
  CameraState state() const { return state_; }
  /// Estimated turn: pitch about the camera's right axis, yaw about the robot's vertical (rad,
  /// the rotation that takes the calibrated rays onto the true ones), and its size in degrees.
  float pitch_rad() const { return pitch_rad_; }
  float yaw_rad() const { return yaw_rad_; }
  float change_deg() const { return change_deg_; }
  /// 0..1: the fraction of the window's samples within trim_deg of the fit.
  float confidence() const { return confidence_; }
  int samples() const { return count_; }
  /// The omni camera, from the same samples: kAsCalibrated or kChanged (its floor ranges disagree
  /// with the persp sizes'), the median elevation error of its rays (degrees), its confidence.
  CameraState omni_state() const { return omni_state_; }
  float omni_change_deg() const { return omni_change_deg_; }
  float omni_confidence() const { return omni_confidence_; }
  /// The camera model the pipeline should use: the calibrated one turned by the estimate while
  /// the state is kCorrected, else the calibrated one.
  const PerspCalibration& model() const { return model_; }

 private:
  bool Fit(float& pitch, float& yaw) const;  // least squares near (pitch, yaw), in place
  void Decide();

  PerspTurnConfig config_;
  PerspCalibration calibrated_, model_;
  Eigen::Vector3f right_ = Eigen::Vector3f::UnitX();  // the camera's x axis, robot frame
  // Ring of samples: the calibrated ray's direction and the direction to P.
  Eigen::Vector3f ray_[kWindow], target_[kWindow];
  int count_ = 0, next_ = 0;
  Eigen::Vector3f last_point_ = Eigen::Vector3f::Constant(1e9f);
  Eigen::Vector3f last_omni_point_ = Eigen::Vector3f::Constant(1e9f);
  float pitch_rad_ = 0, yaw_rad_ = 0, change_deg_ = 0, confidence_ = 0;
  CameraState state_ = CameraState::kAsCalibrated;
  // The omni side: ring of (floor range / size range - 1) and elevation errors (rad).
  float omni_ratio_[kWindow] = {}, omni_elev_[kWindow] = {};
  int omni_count_ = 0, omni_next_ = 0;
  float omni_change_deg_ = 0, omni_confidence_ = 0;
  CameraState omni_state_ = CameraState::kAsCalibrated;
  void AddOmniSample(const Ray& omni, const Ray& persp, const Eigen::Vector3f& p,
                     const Eigen::Vector3f& to_p_from_persp, float size_range_m,
                     float ball_radius_m);
};

}  // namespace bv
