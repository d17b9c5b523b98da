#include "core/health/persp_turn.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

#include "core/common/median.h"

namespace bv {
namespace {

constexpr float kDegPerRad = 57.29578f;
constexpr float kTwoPi = 6.2831853f;

}  // namespace

void PerspTurnWatch::Init(const PerspCalibration& persp, const PerspTurnConfig& config) {
  config_ = config;
  calibrated_ = persp;
  right_ = persp.R_robot_cam.col(0).normalized();
  Reset();
}

void PerspTurnWatch::Reset() {
  count_ = next_ = 0;
  omni_count_ = omni_next_ = 0;
  omni_change_deg_ = omni_confidence_ = 0;
  omni_state_ = CameraState::kAsCalibrated;
  last_point_ = last_omni_point_ = Eigen::Vector3f::Constant(1e9f);
  pitch_rad_ = yaw_rad_ = change_deg_ = confidence_ = 0;
  state_ = CameraState::kAsCalibrated;
  model_ = calibrated_;
}

void PerspTurnWatch::AddFloorSample(const Ray& omni, const Ray& persp, float size_range_m,
                                    float ball_radius_m, bool omni_suspect) {
  if (!config_.enabled || !calibrated_.valid) return;
  if (!(omni.dir.z() < -1e-3f)) return;  // does not come down to the floor plane
  const float t = (ball_radius_m - omni.origin.z()) / omni.dir.z();
  if (!(t > 0.0f)) return;
  const Eigen::Vector3f p = omni.origin + t * omni.dir;
  const Eigen::Vector3f to_p = p - persp.origin;
  const float range = std::hypot(to_p.x(), to_p.y());
  if (!(range >= config_.min_range_m && range <= config_.max_range_m)) return;
  AddOmniSample(omni, persp, p, to_p, size_range_m, ball_radius_m);
  // A knocked mirror moves P: the persp camera is not to be turned after it.
  if (omni_state_ != CameraState::kAsCalibrated || omni_suspect) return;
  if (!(std::fabs(to_p.norm() / size_range_m - 1.0f) <= config_.floor_size_gate)) return;
  const Eigen::Vector3f d = persp.dir.normalized();
  if (!d.allFinite() || (p - last_point_).norm() < config_.min_spacing_m) return;
  last_point_ = p;
  ray_[next_] = d;
  target_[next_] = to_p / to_p.norm();
  next_ = (next_ + 1) % kWindow;
  if (count_ < kWindow) ++count_;
  Decide();
}

// Least squares for the small rotation w = pitch * right + yaw * z that takes each ray d onto
// its target t: t - d = w x d = pitch (right x d) + yaw (z x d), over the samples within
// trim_deg of the given (pitch, yaw).
bool PerspTurnWatch::Fit(float& pitch, float& yaw) const {
  const float trim_rad = config_.trim_deg / kDegPerRad;
  float aa = 0, ab = 0, bb = 0, ae = 0, be = 0;
  int used = 0;
  for (int i = 0; i < count_; ++i) {
    const Eigen::Vector3f a = right_.cross(ray_[i]);
    const Eigen::Vector3f b = Eigen::Vector3f::UnitZ().cross(ray_[i]);
    const Eigen::Vector3f e = target_[i] - ray_[i];
    if ((e - pitch * a - yaw * b).norm() > trim_rad) continue;
    aa += a.dot(a), ab += a.dot(b), bb += b.dot(b);
    ae += a.dot(e), be += b.dot(e);
    ++used;
  }
  const float det = aa * bb - ab * ab;
  if (used < config_.min_samples || !(det > 1e-9f)) return false;
  pitch = (bb * ae - ab * be) / det;
  yaw = (aa * be - ab * ae) / det;
  return std::isfinite(pitch) && std::isfinite(yaw);
}

void PerspTurnWatch::AddOmniSample(const Ray& omni, const Ray& persp, const Eigen::Vector3f& p,
                                   const Eigen::Vector3f& to_p_from_persp, float size_range_m,
                                   float ball_radius_m) {
  if (!(size_range_m > 0.0f)) return;
  const Eigen::Vector3f q = persp.origin + size_range_m * persp.dir.normalized();
  if (!(std::fabs(q.z() - ball_radius_m) <= config_.omni_floor_z_m)) return;
  if ((q - last_omni_point_).norm() < config_.min_spacing_m) return;
  const Eigen::Vector3f& from_c = to_p_from_persp;
  const float azimuth_gap = std::fabs(std::remainder(
      std::atan2(from_c.y(), from_c.x()) - std::atan2(persp.dir.y(), persp.dir.x()), kTwoPi));
  if (!(azimuth_gap * kDegPerRad <= config_.omni_azimuth_gate_deg)) return;
  last_omni_point_ = q;
  const Eigen::Vector3f to_q = q - omni.origin, to_p = p - omni.origin;
  omni_ratio_[omni_next_] = from_c.norm() / size_range_m - 1.0f;
  omni_elev_[omni_next_] = std::atan2(to_p.z(), std::hypot(to_p.x(), to_p.y())) -
                           std::atan2(to_q.z(), std::hypot(to_q.x(), to_q.y()));
  omni_next_ = (omni_next_ + 1) % kWindow;
  if (omni_count_ < kWindow) ++omni_count_;
  if (omni_count_ < config_.min_samples) return;
  float ratios[kWindow] = {}, elevs[kWindow] = {};
  for (int i = 0; i < omni_count_; ++i) ratios[i] = omni_ratio_[i], elevs[i] = omni_elev_[i];
  const float ratio = MedianInPlace(ratios, omni_count_);
  omni_change_deg_ = std::fabs(MedianInPlace(elevs, omni_count_)) * kDegPerRad;
  int agree = 0;
  for (int i = 0; i < omni_count_; ++i) agree += std::fabs(omni_ratio_[i] - ratio) <= 0.05f;
  omni_confidence_ = static_cast<float>(agree) / static_cast<float>(omni_count_);
  // Flagged beyond the gate, cleared below 0.6 of it.
  const float gate = omni_state_ == CameraState::kAsCalibrated ? config_.omni_range_gate
                                                               : 0.6f * config_.omni_range_gate;
  omni_state_ = std::fabs(ratio) > gate ? CameraState::kChanged : CameraState::kAsCalibrated;
}

void PerspTurnWatch::Decide() {
  if (count_ < config_.min_samples) return;
  // A start that outliers cannot move: each sample's own pitch and yaw (the two axes are nearly
  // orthogonal for rays near the horizon), their medians; then least squares over the samples
  // that agree with it. When too few agree (a large turn, where the small-angle model is
  // coarse) the medians stand, with their low confidence.
  float pitches[kWindow] = {}, yaws[kWindow] = {};
  for (int i = 0; i < count_; ++i) {
    const Eigen::Vector3f a = right_.cross(ray_[i]);
    const Eigen::Vector3f b = Eigen::Vector3f::UnitZ().cross(ray_[i]);
    const Eigen::Vector3f e = target_[i] - ray_[i];
    pitches[i] = a.dot(e) / std::max(a.squaredNorm(), 1e-6f);
    yaws[i] = b.dot(e) / std::max(b.squaredNorm(), 1e-6f);
  }
  float pitch = MedianInPlace(pitches, count_), yaw = MedianInPlace(yaws, count_);
  float fit_pitch = pitch, fit_yaw = yaw;
  if (Fit(fit_pitch, fit_yaw)) pitch = fit_pitch, yaw = fit_yaw;
  const float trim_rad = config_.trim_deg / kDegPerRad;
  int agree = 0;
  for (int i = 0; i < count_; ++i) {
    const Eigen::Vector3f e = target_[i] - ray_[i] - pitch * right_.cross(ray_[i]) -
                              yaw * Eigen::Vector3f::UnitZ().cross(ray_[i]);
    agree += e.norm() <= trim_rad;
  }
  pitch_rad_ = pitch;
  yaw_rad_ = yaw;
  change_deg_ = std::hypot(pitch, yaw) * kDegPerRad;
  confidence_ = static_cast<float>(agree) / static_cast<float>(count_);
  // Flagged at flag_deg, cleared below 0.6 of it: no flicker at the threshold.
  const bool was_changed = state_ != CameraState::kAsCalibrated;
  const float flag = was_changed ? 0.6f * config_.flag_deg : config_.flag_deg;
  if (change_deg_ < flag) {
    state_ = CameraState::kAsCalibrated;
  } else if (change_deg_ > config_.unusable_deg) {
    state_ = CameraState::kUnusable;
  } else if (config_.correct && change_deg_ <= config_.correct_max_deg) {
    state_ = CameraState::kCorrected;
  } else {
    state_ = CameraState::kChanged;
  }
  model_ = calibrated_;
  if (state_ == CameraState::kCorrected) {
    model_.R_robot_cam =
        (Eigen::AngleAxisf(yaw, Eigen::Vector3f::UnitZ()) * Eigen::AngleAxisf(pitch, right_))
            .toRotationMatrix() *
        calibrated_.R_robot_cam;
  }
}

}  // namespace bv
