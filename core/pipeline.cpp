#include "core/pipeline.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/color_lut/color_lut.h"

namespace bv {
namespace {

constexpr float kRimMarginPx = 3.f;  // a ball this close to the mirror rim may be cut by it
constexpr float kMaxApparentSizeRatio = 1.25f;  // persp radius / a ball's at the stereo range
constexpr float kStereoGapM = 0.08f, kStereoGapPerM = 0.02f;
constexpr size_t kStereoCandidates = 4;  // per camera, in the acquisition choice
// A track outside the field is kept only while it moves at least this fast (a ball rolling out;
// the distractors behind a line stand still).
constexpr float kMinRollOutSpeedMps = 0.3f;
constexpr float kMaxCandidateRangeM = 6.f;
constexpr float kPi = 3.14159265358979f;
constexpr float kOnFloorM = 0.05f;  // a ball at rest lies on the floor  // farther, the omni floor
                                    // point is too coarse to track
constexpr float kAdaptMaxGapM = 0.02f;  // rays of a confirmed ball meet this close
constexpr int kMinGoalRaysWithoutPose = 3;
// A dark region inside a goal, behind its line by more than an obstacle centre's error, is the
// goal's own (its net, the shade under the crossbar); the mouth is widened by a robot's radius.
constexpr float kObstacleInGoalM = 0.1f, kObstacleGoalSideM = 0.3f;
// Obstacles are what stands on the field: a footprint whose near edge stays farther than this
// outside the field of play is a person, a wall or a chair in the border, where referees and team
// members walk (a robot that overshoots a line after the ball stays within reach of it).
constexpr float kObstacleOutsideM = 0.25f;

// Robot frame to field frame for a pose (x, y) with heading h given as s = sin h, c = cos h:
// robot +x is (sin h, -cos h) in the field, robot +y is (cos h, sin h).
void RobotToField(float px, float py, float s, float c, float x, float y, float& fx, float& fy) {
  fx = px + x * s + y * c;
  fy = py - x * c + y * s;
}

float AngleBetween(const Eigen::Vector3f& a, const Eigen::Vector3f& b) {
  const float c = a.normalized().dot(b.normalized());
  return std::acos(std::clamp(c, -1.f, 1.f));
}

// A sphere's outline is the cone of rays tangent to it, about the direction to its centre. Near
// the wide-angle lens's edge the image of that cone is no circle (the distortion squeezes it, the
// perspective stretches it off axis), so a cut ball's image circle misses the centre by pixels
// there. Gauss-Newton on the outline rays' angles to the axis: the axis and the half-angle, from
// the circle's; false (the circle kept) when fewer than 12 rays or the fit is poor.
constexpr int kConePoints = 64;
float Det3(const Eigen::Matrix3f& m) {  // written out: no Eigen LU on the device
  return m(0, 0) * (m(1, 1) * m(2, 2) - m(1, 2) * m(2, 1)) -
         m(0, 1) * (m(1, 0) * m(2, 2) - m(1, 2) * m(2, 0)) +
         m(0, 2) * (m(1, 0) * m(2, 1) - m(1, 1) * m(2, 0));
}
bool FitSphereCone(const PerspCalibration& cal, const int16_t* u, const int16_t* v, size_t n,
                   Eigen::Vector3f& axis, float& half_angle) {
  Eigen::Vector3f d[kConePoints];
  size_t m = 0;
  for (size_t i = 0; i < n && m < kConePoints; ++i) {
    auto r = PerspPixelToRay(cal, static_cast<float>(u[i]), static_cast<float>(v[i]));
    if (r.ok()) d[m++] = r->dir;
  }
  if (m < 12) return false;
  float rms = 0;
  for (int it = 0; it < 6; ++it) {
    Eigen::Vector3f e1 =
        std::fabs(axis.x()) < 0.9f ? Eigen::Vector3f::UnitX() : Eigen::Vector3f::UnitY();
    e1 = (e1 - axis * axis.dot(e1)).normalized();
    const Eigen::Vector3f e2(axis.y() * e1.z() - axis.z() * e1.y(),
                             axis.z() * e1.x() - axis.x() * e1.z(),
                             axis.x() * e1.y() - axis.y() * e1.x());
    Eigen::Matrix3f h = Eigen::Matrix3f::Zero();
    Eigen::Vector3f g = Eigen::Vector3f::Zero();
    float ss = 0;
    for (size_t i = 0; i < m; ++i) {
      const float c = std::clamp(d[i].dot(axis), -1.f, 1.f);
      const float s = std::max(std::sqrt(1.f - c * c), 1e-6f);
      const float res = std::acos(c) - half_angle;
      const Eigen::Vector3f j(-d[i].dot(e1) / s, -d[i].dot(e2) / s, -1.f);
      h += j * j.transpose();
      g += j * res;
      ss += res * res;
    }
    rms = std::sqrt(ss / static_cast<float>(m));
    // h step = -g by Cramer's rule.
    const float det = Det3(h);
    if (!(std::fabs(det) > 1e-12f)) return false;
    Eigen::Vector3f step;
    for (int k = 0; k < 3; ++k) {
      Eigen::Matrix3f hk = h;
      hk.col(k) = -g;
      step(k) = Det3(hk) / det;
    }
    axis = (axis + step(0) * e1 + step(1) * e2).normalized();
    half_angle += step(2);
    if (!axis.allFinite() || !(half_angle > 1e-3f && half_angle < 1.2f)) return false;
  }
  // The outline within ~1 px of a cone: a ball, not a blob the circle happened to fit.
  return rms < 2.f / std::max(cal.fx, 1.f);
}

// Feature rays out to the line range (max_line_range_m; a 12.5 cm line is under a pixel wide
// beyond ~5 m on the reference mirror) or where the distance map ends, in the direction where
// that comes first; 3 px steps near the robot (a line is >= 8 px wide there) down to 1 px at the
// far end. 64 rays keep the pair under 5 % of its pixels (bench_frontend prints it).
float RadiusAtGround(const OmniCalibration& cal, int direction, float ground_m) {
  const float* sv = cal.support_px[direction];
  for (int k = 1; k < OmniCalibration::kEdges; ++k) {
    if (cal.edge_ground_m[k] >= ground_m) {
      const float t =
          (ground_m - cal.edge_ground_m[k - 1]) / (cal.edge_ground_m[k] - cal.edge_ground_m[k - 1]);
      return sv[k - 1] + std::clamp(t, 0.0f, 1.0f) * (sv[k] - sv[k - 1]);
    }
  }
  return sv[OmniCalibration::kEdges - 1];
}

OmniFeatureRays FeatureRays(const OmniCalibration& cal, const OmniScanConfig& scan,
                            const PipelineConfig& config) {
  float end = scan.outer_radius_px;
  for (int d = 0; d < OmniCalibration::kDirections; ++d) {
    end = std::min(end, RadiusAtGround(cal, d, config.features.max_line_range_m));
    end = std::min(end, cal.support_px[d][OmniCalibration::kEdges - 1] - 1.0f);
  }
  OmniFeatureRays f;
  f.rays = config.feature_rays;
  f.end_radius_px = std::max(end, scan.inner_radius_px + 2.0f);
  f.step_inner_px = 4.0f;
  f.step_outer_px = 1.0f;
  return f;
}

// The image of a sphere in the omni camera is not centred on the image of its centre: the mirror
// maps elevation e to image radius rho(e), stretching the ball radially where rho'' > 0, and the
// ring of azimuths widens outward. To second order in the ball's angular radius a, its centroid
// lies outward by (a^2 / 4) (1.5 rho'' + rho'^2 / rho - rho / (2 cos^2 e)): 0.2 px at 2 m and
// 0.3-0.6 px within 1 m on the reference rig (renderer: 0.19 and 0.33-1.15 px). rho' and rho''
// come from the calibration's rays either side of the centroid (+-6 px along the radius: the
// distance map is piecewise linear, so its curvature is taken over a span, not at a knot).
void OmniSphereCentre(const OmniCalibration& cal, float radius_px, float& u, float& v) {
  constexpr float kStepPx = 6.f;
  const float du = u - cal.center_u, dv = v - cal.center_v;
  const float rho = std::hypot(du, dv);
  if (!(rho > 4.f * kStepPx) || !(radius_px > 0.f)) return;
  const float ex = du / rho, ey = dv / rho;
  float e[3];
  for (int i = 0; i < 3; ++i) {
    const float s = static_cast<float>(i - 1) * kStepPx;
    const auto ray = OmniPixelToRayExtended(cal, u + s * ex, v + s * ey);
    if (!ray.ok()) return;
    e[i] = std::atan2(ray->dir.z(), std::hypot(ray->dir.x(), ray->dir.y()));
  }
  const float e1 = (e[2] - e[0]) / (2.f * kStepPx);                   // de / drho
  const float e2 = (e[2] - 2.f * e[1] + e[0]) / (kStepPx * kStepPx);  // d2e / drho2
  if (!(std::fabs(e1) > 1e-6f)) return;
  const float r1 = 1.f / e1, r2 = -e2 / (e1 * e1 * e1);  // drho / de, d2rho / de2
  const float c2 = std::max(std::cos(e[1]) * std::cos(e[1]), 0.05f);
  // The ball's area pi a^2 |rho'| rho / cos e in the image is pi radius_px^2.
  const float a2 = radius_px * radius_px * std::sqrt(c2) / (std::fabs(r1) * rho);
  const float shift = std::clamp(0.25f * a2 * (1.5f * r2 + r1 * r1 / rho - 0.5f * rho / c2),
                                 -0.5f * radius_px, 0.5f * radius_px);
  u -= shift * ex;
  v -= shift * ey;
}

// The lit ball's shaded lower side is partly lost to the colour table: in the omni image the side
// towards the image centre. n pixels lost there move a disc's centroid outward by n / (pi r).
void ShadedSideCentre(const OmniCalibration& cal, float radius_px, float lost_px, float& u,
                      float& v) {
  const float du = u - cal.center_u, dv = v - cal.center_v;
  const float rho = std::hypot(du, dv);
  if (!(rho > 1.f) || !(radius_px > 1.f) || !(lost_px > 0.f)) return;
  const float shift = std::min(lost_px / (kPi * radius_px), 0.25f * radius_px);
  u -= shift * du / rho;
  v -= shift * dv / rho;
}

// A disc cut by a straight edge: its visible part's centroid is off the centre by 1.2-1.75 times
// the radius its area lacks (1.45 at half visible, 1.75 with a tenth hidden). The fit's weights
// take the missing radius; the shared error, the frames' common offset, the geometry's, up to the
// ray's whole sigma (the filter's cap): it binds where the hidden part is most of that sigma, as
// in the omni elevation, which has no calibration term beside it.
constexpr float kHiddenCentroidPerMissingRadius = 1.5f;
// A track this young that no stereo frame confirmed yields to a pair of candidates that is one
// ball (DetectBalls): a start on one camera's decoy is undone within its first frames.
constexpr uint64_t kYoungTrackUs = 500000;

// How far a detection lies from its camera's prediction, in ball radii there; unknown: +inf.
float PredictionMisfit(const ImagePrediction& pred, const BallDetection& det, float radius_px) {
  if (!pred.valid || !(radius_px > 0.f)) return std::numeric_limits<float>::infinity();
  return std::hypot(det.u_px - pred.u_px, det.v_px - pred.v_px) / radius_px;
}

}  // namespace

// How far a region's centroid may be off when its size disagrees with the predicted silhouette.
// Smaller: the visible part of a partly hidden ball, off by about the missing radius; within
// `small_rel` (the apparent size's own relative 1-sigma) it is not evidence of that. A region in
// full view loses part of its rim to partial classification: lobs at 4-6 m measured 2-4 % small
// in the persp image, and counted as hidden that put 1-2 mrad of shared error on the persp ray,
// 7 cm of range sigma at 4.5 m where the ball was within 4. Larger (past the ~10 % that blur and a
// prediction's range error give): the ball merged with something ball-coloured beside it (a
// spare ball, a cone behind it), whose area pulls the centroid by about twice the radius it adds
// (areas r_b^2 and r_t^2 - r_b^2, centres ~r_b + r_o apart).
float SizeMisfitPx(const ImagePrediction& pred, float radius_px, float small_rel) {
  if (!pred.valid) return 0.f;
  const float r = pred.silhouette_radius_px;
  return std::max(0.f, (1.f - small_rel) * r - radius_px) +
         2.f * std::max(0.f, radius_px - 1.1f * r);
}

// Angular noise of an omni ray: the centroid noise (grown with the region) converted by the
// mirror's local scale, radially (elevation, from the neighbouring pixel's ray) and tangentially
// (azimuth: one pixel is 1/rho of a turn, scaled by the ray's horizontal extent).
void OmniRaySigma(const OmniCalibration& cal, const BallDetection& det, const Ray& ray,
                  float extra_px, float shared_extra_px, const PipelineConfig& config,
                  BallRay& out) {
  const float du = det.u_px - cal.center_u, dv = det.v_px - cal.center_v;
  const float rho = std::max(std::hypot(du, dv), 1.0f);
  const float s_px = config.omni_sigma_px + config.omni_sigma_per_radius * det.radius_px + extra_px;
  const float horiz = std::hypot(ray.dir.x(), ray.dir.y());
  const float az_per_px = std::max(horiz, 0.05f) / rho;
  float per_px = 0.01f;  // fallback: ~0.6 deg per pixel
  for (const float step : {-1.0f, 1.0f}) {
    auto n = OmniPixelToRayExtended(cal, det.u_px + step * du / rho, det.v_px + step * dv / rho);
    if (n.ok()) {
      per_px = AngleBetween(ray.dir, n->dir);
      break;
    }
  }
  const float el_per_px = std::clamp(per_px, 1e-4f, 0.05f);
  out.sigma_h_rad = std::hypot(s_px * az_per_px, config.omni_azimuth_sigma_rad * horiz);
  out.sigma_v_rad = s_px * el_per_px;
  const float b_px = config.omni_bias_px + shared_extra_px;
  out.bias_h_rad = std::hypot(b_px * az_per_px, config.omni_azimuth_bias_rad * horiz);
  // What the shaded side's lost pixels leave after ShadedSideCentre (their count varies with the
  // light), radially only.
  const float shade_px = config.omni_shade_spread_px / (kPi * std::max(det.radius_px, 1.f));
  const float bv_px = std::max(config.omni_bias_px, shade_px) + shared_extra_px;
  // The distance map's range error, relative, as an elevation: d = h / tan(el), so
  // dd / d = del / (sin el cos el).
  out.bias_v_rad =
      std::hypot(bv_px * el_per_px, config.omni_range_bias_rel * std::fabs(ray.dir.z()) * horiz);
}

OmniScanConfig PipelineOmniScan(const OmniCalibration& cal, const PipelineConfig& config) {
  OmniScanConfig scan = ReferenceOmniScanConfig(cal.center_u, cal.center_v);
  const OmniSelfMask& self = cal.self_mask;
  static_assert(OmniSelfMask::kMaxSectors <= OmniScanConfig::kMaxStruts);
  if (self.known) {  // this robot's own body, struts and rim, not the reference rig's
    scan.inner_radius_px = self.inner_radius_px;
    scan.outer_radius_px = self.outer_radius_px;
    scan.strut_count = self.sector_count;
    for (int i = 0; i < self.sector_count; ++i) {
      scan.struts[i] = {self.sectors[i].angle_deg, self.sectors[i].half_width_deg};
    }
  }
  if (config.field_features) scan.features = FeatureRays(cal, scan, config);
  return scan;
}

Status Pipeline::SetRobotPose(const RobotPose& pose) {
  if (!std::isfinite(pose.x_m) || !std::isfinite(pose.y_m) || !std::isfinite(pose.heading_rad)) {
    return Status(StatusCode::kInvalidArgument, "pipeline: robot pose not finite");
  }
  pose_ = pose;
  if (pose.known && features_ready_) {
    PoseHint hint;
    hint.has_pose = true;
    hint.x_m = pose.x_m;
    hint.y_m = pose.y_m;
    hint.heading_rad = pose.heading_rad;
    BV_TRY(localiser_.SetHint(hint));
  }
  RefreshFieldRule();
  return Status();
}

Status Pipeline::SetFieldHalf(int8_t half) {
  PoseHint hint;
  hint.half = half;
  BV_TRY(localiser_.SetHint(hint));
  RefreshFieldRule();
  return Status();
}

Status Pipeline::SetOdometry(float dx_m, float dy_m, float dheading_rad) {
  if (!std::isfinite(dx_m) || !std::isfinite(dy_m) || !std::isfinite(dheading_rad) ||
      std::fabs(dx_m) > 2.0f || std::fabs(dy_m) > 2.0f || std::fabs(dheading_rad) > 3.2f) {
    return Status(StatusCode::kInvalidArgument, "pipeline: odometry not finite or > 2 m / frame");
  }
  odometry_[0] = dx_m;
  odometry_[1] = dy_m;
  odometry_[2] = dheading_rad;
  odometry_pending_ = true;
  return Status();
}

bool Pipeline::OwnPoseTrusted() const {
  const PoseEstimate& e = localiser_.pose();
  return features_ready_ && e.usable() &&
         std::max(e.sigma_x_m, e.sigma_y_m) <= config_.localiser.usable_sigma_m;
}

bool Pipeline::FieldPose(RobotPose& pose, float& sigma_m) const {
  const PoseEstimate& e = localiser_.pose();
  if (OwnPoseTrusted()) {
    pose.known = true;
    pose.x_m = e.x_m;
    pose.y_m = e.y_m;
    pose.heading_rad = e.heading_rad;
    sigma_m = std::max(e.sigma_x_m, e.sigma_y_m);
    return true;
  }
  pose = pose_;
  sigma_m = 0.0f;
  return pose_.known;
}

// Which goal each seen goal is, from the pose; one the pose puts far from both goals is something
// else behind a line (a person, a box) and is removed. The two goals look the same (the rendered
// venue's are both white), so a goal cannot break the field's symmetry: an ambiguous pose leaves
// `which` open too.
void Pipeline::NameGoals() {
  const PoseEstimate& e = localiser_.pose();
  if (!OwnPoseTrusted()) {
    // Nothing to check against: only goals seen on several rays (a goal 2 m wide covers >= 4
    // of 64 rays up to 5 m; a person behind a line 1-2).
    int kept = 0;
    for (int i = 0; i < features_.goal_count; ++i) {
      if (features_.goals[i].rays >= kMinGoalRaysWithoutPose) {
        features_.goals[kept++] = features_.goals[i];
      } else {
        ++features_.goals_refused;
      }
    }
    features_.goal_count = kept;
    return;
  }
  const FieldConfig& f = field_model_.config();
  const float s = std::sin(e.heading_rad), c = std::cos(e.heading_rad);
  int kept = 0;
  for (int i = 0; i < features_.goal_count; ++i) {
    Goal g = features_.goals[i];
    float fx, fy;
    RobotToField(e.x_m, e.y_m, s, c, g.x_m, g.y_m, fx, fy);
    if (std::fabs(std::fabs(fx) - 0.5f * f.length_m) > 0.5f * f.goal_width_m ||
        std::fabs(fy) > f.goal_width_m) {
      ++features_.goals_refused;
      continue;
    }
    g.which = fx < 0.0f ? -1 : 1;
    g.which_ambiguous = e.ambiguous;
    features_.goals[kept++] = g;
  }
  features_.goal_count = kept;
}

// The stands and people in the border, the inside of a goal: dark on green, but where the pose
// says no robot in play stands (kObstacleOutsideM beyond the field of play, at most the border).
// Without a trusted pose every obstacle is kept.
void Pipeline::RefuseOffFieldObstacles() {
  if (!OwnPoseTrusted()) return;
  const PoseEstimate& e = localiser_.pose();
  const float sigma = std::max(e.sigma_x_m, e.sigma_y_m);
  const FieldConfig& f = field_model_.config();
  const float s = std::sin(e.heading_rad), c = std::cos(e.heading_rad);
  int kept = 0;
  for (int i = 0; i < features_.obstacle_count; ++i) {
    const Obstacle& o = features_.obstacles[i];
    float fx, fy;
    RobotToField(e.x_m, e.y_m, s, c, o.x_m, o.y_m, fx, fy);
    const bool in_goal = std::fabs(fx) > 0.5f * f.length_m + kObstacleInGoalM &&
                         std::fabs(fy) < 0.5f * f.goal_width_m + kObstacleGoalSideM;
    const float margin = std::min(f.border_m, o.radius_m + kObstacleOutsideM) + sigma;
    if (in_goal || !field_model_.Inside(fx, fy, margin)) {
      ++features_.obstacles_refused;
      continue;
    }
    features_.obstacles[kept++] = o;
  }
  features_.obstacle_count = kept;
}

// The in-field rule runs for every ball candidate of both cameras: the pose, its sine and cosine
// and the field's half sizes are worked out once per change, not once per candidate.
void Pipeline::RefreshFieldRule() {
  RobotPose pose;
  float sigma = 0;
  field_rule_.active = FieldPose(pose, sigma);
  if (!field_rule_.active) return;
  field_rule_.x = pose.x_m;
  field_rule_.y = pose.y_m;
  field_rule_.s = std::sin(pose.heading_rad);
  field_rule_.c = std::cos(pose.heading_rad);
  const FieldConfig& f = field_model_.config();
  const float margin = f.margin_m + 2.0f * sigma;
  field_rule_.half_x = 0.5f * f.length_m + margin;
  field_rule_.half_y = 0.5f * f.width_m + margin;
}

bool Pipeline::InField(float x_m, float y_m) const {
  const FieldRule& r = field_rule_;
  if (!r.active) return true;
  float fx, fy;
  RobotToField(r.x, r.y, r.s, r.c, x_m, y_m, fx, fy);
  return std::fabs(fx) <= r.half_x && std::fabs(fy) <= r.half_y;
}

// The ray meets the floor beyond the ball; a ball on the floor has its centre at height r, so
// the floor point scales by (f_O - r) / f_O. (A ball in the air is nearer still; its apparent
// size does not tell it apart reliably in the mirror image, measured on the rendered sets: a
// floor ball's equivalent radius is 1.1-4x a simple model's.)
bool Pipeline::OmniField::Inside(float u_px, float v_px, float) const {
  const RigCalibration& cal = *p->calibration_;
  float x = 0, y = 0;
  // Beyond the distance map the floor point is unknown: no verdict, not "outside".
  if (!OmniPixelToGround(p->omni_model_, u_px, v_px, x, y).ok()) return true;
  const float f_o = p->omni_model_.viewpoint_z_m, r = cal.ball_radius_m;
  const float k = f_o > r ? (f_o - r) / f_o : 1.0f;
  return p->InField(x * k, y * k);
}

// Persp: two estimates of where the ball is: the ray on the plane of a floor ball's centre (too
// far for a ball in the air) and the range from the apparent size (too far for a ball partly
// hidden). The ball is at or before both, so it counts as outside only when both are outside.
bool Pipeline::PerspField::Inside(float u_px, float v_px, float radius_px) const {
  const RigCalibration& cal = *p->calibration_;
  // A ball cut by the image border looks smaller, hence farther: no verdict.
  if (u_px - radius_px < 1.0f || v_px - radius_px < 1.0f ||
      u_px + radius_px > static_cast<float>(cal.persp.width_px) - 2.0f ||
      v_px + radius_px > static_cast<float>(cal.persp.height_px) - 2.0f) {
    return true;
  }
  const Result<Ray> ray = PerspPixelToRay(p->persp_turn_.model(), u_px, v_px);
  const Result<Ray> rim = PerspPixelToRay(p->persp_turn_.model(), u_px + radius_px, v_px);
  if (!ray.ok() || !rim.ok() || !(radius_px > 1.0f)) return true;
  const auto q = PointFromApparentSize(*ray, AngleBetween(ray->dir, rim->dir), cal.ball_radius_m);
  if (!q.ok() || p->InField(q->x(), q->y())) return true;
  const float dz = ray->dir.z();
  if (dz > -1e-3f) return true;  // at or above the camera: never meets the floor-ball plane
  const float t = (cal.ball_radius_m - ray->origin.z()) / dz;
  return p->InField(ray->origin.x() + t * ray->dir.x(), ray->origin.y() + t * ray->dir.y());
}

namespace {
// The place check of the rig's own ball.
void GeometryConfigFor(const RigCalibration& cal, BallGeometryConfig& g) {
  g.ball_radius_m = cal.ball_radius_m;
}
}  // namespace

Status Pipeline::Init(const RigCalibration& calibration, const ColorLut& lut,
                      const PipelineConfig& config) {
  initialised_ = false;
  if (!calibration.persp.valid && !calibration.omni.valid) {
    return Status(StatusCode::kFailedPrecondition, "pipeline: calibration valid for no camera");
  }
  calibration_ = &calibration;
  lut_ = &lut;
  config_ = config;
  config_.filter.ball_radius_m = calibration.ball_radius_m;
  config_.finder.ball_box = lut.Bounds(ColorClass::kBall);
  features_ready_ = false;
  omni_watch_.Clear();  // a camera without calibration is not watched
  persp_watch_.Clear();
  mirror_rim_.Clear();
  omni_model_ = calibration.omni;
  persp_turn_.Init(calibration.persp, config_.persp_turn);
  BV_TRY(field_model_.Init(calibration.field));
  if (calibration.omni.valid) {
    const OmniScanConfig scan = PipelineOmniScan(calibration.omni, config_);
    omni_outer_radius_px_ = scan.outer_radius_px;
    mirror_rim_.Init(calibration.omni, scan.outer_radius_px, config_.mirror_rim);
    BV_TRY(tables_.omni.BuildOmni(scan, kFrameWidth, kFrameHeight));
    BV_TRY(omni_watch_.Build(tables_.omni, config_.watch));
    if (config_.field_features) {
      BV_TRY(extractor_.Init(scan, omni_model_, FeatureConfig(), tables_.feature_walk));
      features_centre_u_ = omni_model_.center_u;
      features_centre_v_ = omni_model_.center_v;
      BV_TRY(localiser_.Init(&field_model_, config_.localiser));
      features_ready_ = true;
    }
    BallFinderConfig finder = config_.finder;
    finder.fit_circles = false;
    finder.check = nullptr;
    omni_field_.p = this;
    if (finder.field == nullptr) finder.field = &omni_field_;
    BV_TRY(omni_finder_.Init(tables_.omni, finder));
  }
  if (calibration.persp.valid) {
    BV_TRY(tables_.persp.BuildPersp(ReferencePerspScanConfig(), calibration.persp.width_px,
                                    calibration.persp.height_px));
    BV_TRY(persp_watch_.Build(tables_.persp, config_.watch));
    BallFinderConfig finder = config_.finder;
    finder.fit_circles = config_.persp_circles;
    finder.check = nullptr;
    if (config_.persp_checks) {
      GeometryConfigFor(calibration, config_.geometry);
      BV_TRY(persp_geometry_.SetPersp(calibration.persp, config_.geometry));
      persp_check_.Init(&persp_geometry_, config_.classifier, config_.check);
      finder.check = &persp_check_;
    }
    persp_field_.p = this;
    if (finder.field == nullptr) finder.field = &persp_field_;
    BV_TRY(persp_finder_.Init(tables_.persp, finder));
  }
  filter_.Configure(config_.filter);
  candidates_.Configure(config_.candidates);
  candidates_.Reset();
  handover_ = Handover{};
  track_confirmed_ = track_found_ = false;
  stats_ = PipelineStats{};
  pred_omni_ = pred_persp_ = ImagePrediction{};
  RefreshFieldRule();
  initialised_ = true;
  return Status();
}

// Projects the filter's position at t into both images (paper IV-A c and the Monte-Carlo
// attention): the image centre and the apparent ball radius there.
void Pipeline::Predict(uint64_t t_us) {
  pred_omni_ = pred_persp_ = ImagePrediction{};
  Eigen::Vector3f p, v;
  BallMode mode;
  if (filter_.HasStateAt(t_us) && filter_.StateAt(t_us, p, v, mode)) {
    handover_.valid = false;
    PredictAt(p);
    return;
  }
  // A moving candidate handed over by ReviewCandidates: the front end looks for it first.
  constexpr uint64_t kHandoverUs = 300000;
  if (!handover_.valid || t_us < handover_.t_us || t_us - handover_.t_us > kHandoverUs) {
    handover_.valid = false;
    return;
  }
  const float dt = static_cast<float>(t_us - handover_.t_us) * 1e-6f;
  PredictAt(Eigen::Vector3f(handover_.x + handover_.vx * dt, handover_.y + handover_.vy * dt,
                            calibration_->ball_radius_m));
}

bool Pipeline::PredictAt(const Eigen::Vector3f& p) {
  const float r = calibration_->ball_radius_m;
  float u, w;
  if (omni_model_.valid && OmniProject(omni_model_, p, u, w).ok()) {
    pred_omni_.valid = true;
    pred_omni_.u_px = u;
    pred_omni_.v_px = w;
    // Radius: project a point one ball radius further out horizontally.
    const float d = std::hypot(p.x(), p.y());
    float u2, w2;
    if (d > 1e-3f) {
      const Eigen::Vector3f q = p + Eigen::Vector3f(p.x() / d * r, p.y() / d * r, 0.f);
      if (OmniProject(omni_model_, q, u2, w2).ok()) {
        pred_omni_.radius_px = std::hypot(u2 - u, w2 - w);
      }
      // The silhouette: the ball's angular radius from the mirror viewpoint, across the image
      // radius (azimuth) and along it (elevation, offset downwards to stay below the horizon).
      const Eigen::Vector3f los = p - Eigen::Vector3f(0.f, 0.f, omni_model_.viewpoint_z_m);
      const Eigen::Vector3f e_t(-p.y() / d, p.x() / d, 0.f);
      // e_t x los, written out (Eigen's cross lives in Eigen/Geometry, not used on the device).
      Eigen::Vector3f e_v(e_t.y() * los.z(), -e_t.x() * los.z(),
                          e_t.x() * los.y() - e_t.y() * los.x());
      e_v.normalize();
      if (e_v.z() > 0.f) e_v = -e_v;
      float ut, wt, uv, wv;
      if (OmniProject(omni_model_, p + e_t * r, ut, wt).ok() &&
          OmniProject(omni_model_, p + e_v * r, uv, wv).ok()) {
        pred_omni_.silhouette_radius_px =
            std::sqrt(std::hypot(ut - u, wt - w) * std::hypot(uv - u, wv - w));
      }
    }
  }
  const PerspCalibration& persp = persp_turn_.model();
  if (persp.valid && PerspProject(persp, p, u, w).ok()) {
    pred_persp_.valid = true;
    pred_persp_.u_px = u;
    pred_persp_.v_px = w;
    const float range = (p - persp.t_robot_cam).norm();
    pred_persp_.radius_px = range > r ? persp.fx * r / range : 0.f;
    pred_persp_.silhouette_radius_px = pred_persp_.radius_px;
  }
  return pred_omni_.valid || pred_persp_.valid;
}

// Front end of one camera (core/detect), fed with the projected prediction.
BallDetection Pipeline::Detect(BallFinder& finder, const YuyvImage& img,
                               const ImagePrediction& pred) {
  BallDetection det;
  FrontEndStats fs;
  Prediction p;
  p.u_px = pred.u_px;
  p.v_px = pred.v_px;
  p.sigma_px = std::max(2.f * pred.radius_px, 6.f);
  p.radius_px = pred.radius_px;
  const Status st = finder.Find(img, *lut_, pred.valid ? &p : nullptr, det, fs);
  stats_.pixels_read += fs.pixels_read;
  stats_.regions_traced += fs.regions;
  stats_.overflows += fs.overflows;
  stats_.out_of_field_rejected += fs.outside_field;
  if (!st.ok()) {
    ++stats_.frame_errors;
    det = BallDetection{};
  }
  return det;
}

// Two detections are one ball when their rays meet and the persp region is no larger than a
// ball at the range they meet at; `point`, when given, gets where they meet.
bool Pipeline::StereoConsistent(const BallDetection& omni, const BallDetection& persp,
                                Eigen::Vector3f* point) const {
  const RigCalibration& cal = *calibration_;
  const Result<Ray> ro = OmniPixelToRayExtended(omni_model_, omni.u_px, omni.v_px);
  const Result<Ray> rp = PerspPixelToRay(persp_turn_.model(), persp.u_px, persp.v_px);
  if (!ro.ok() || !rp.ok()) return false;
  const Result<Triangulation> tri = TriangulateRays(*rp, *ro, config_.triangulation);
  if (!tri.ok() || tri->point.z() < -cal.ball_radius_m) return false;
  const float range = (tri->point - rp->origin).norm();
  // The calibrated rays of one ball meet within ~1 cm (tools/python/validate_rays.py); this
  // gate is looser for the centroids of partly classified or cut balls, and far tighter than
  // the tracking gate (max_ray_gap_m), which would pair unrelated regions.
  if (tri->gap_m > kStereoGapM + kStereoGapPerM * range) return false;
  if (point != nullptr) *point = tri->point;
  return !LargerThanABall(persp.radius_px, range);
}

// A ball never looks bigger than it is: a persp region much larger than a ball at `range_m` is
// something else, or the ball merged with a same-coloured object behind it. Partly hidden balls
// look smaller, so the test is one-sided.
bool Pipeline::LargerThanABall(float persp_radius_px, float range_m) const {
  const RigCalibration& cal = *calibration_;
  const float expected_px = cal.persp.fx * cal.ball_radius_m / std::max(range_m, 0.05f);
  return persp_radius_px > kMaxApparentSizeRatio * expected_px + 1.0f;
}

// Acquisition (no track yet): if the two cameras' choices are not one ball, the pair of
// candidates that is, the larger in the persp image first. When no pair is and the persp choice
// passed the look check, the omni's (which has none: a yellow shirt or banner at the mirror's rim,
// while the ball is above its horizon) is left out rather than paired with it.
void Pipeline::ChooseStereoPair(BallDetection& omni, BallDetection& persp) const {
  if (StereoConsistent(omni, persp) || FindStereoPair(omni, persp, false)) return;
  if (PerspLooked(persp)) omni = BallDetection{};
}

// The first pair of candidates that is one ball, the larger in the persp image first (inside the
// field only, when asked and the pose is known); false, and nothing changed, when none is.
bool Pipeline::FindStereoPair(BallDetection& omni, BallDetection& persp, bool in_field_only) const {
  BallDetection co[kStereoCandidates], cp[kStereoCandidates];
  const size_t no = omni_finder_.Candidates(co), np = persp_finder_.Candidates(cp);
  for (size_t j = 0; j < np; ++j) {  // persp candidates come largest first
    for (size_t i = 0; i < no; ++i) {
      Eigen::Vector3f p;
      if (!StereoConsistent(co[i], cp[j], &p)) continue;
      if (in_field_only && field_rule_.active && !InField(p.x(), p.y())) continue;
      omni = co[i];
      persp = cp[j];
      return true;
    }
  }
  return false;
}

// The persp choice passed the look check (a classifier ran on it: its centre lies in the image).
bool Pipeline::PerspLooked(const BallDetection& persp) const {
  const RigCalibration& cal = *calibration_;
  return persp.found && config_.persp_checks && persp_check_.looks() && persp.u_px >= 0.0f &&
         persp.v_px >= 0.0f && persp.u_px < static_cast<float>(cal.persp.width_px) &&
         persp.v_px < static_cast<float>(cal.persp.height_px);
}

Status Pipeline::Process(const FrameInput& delivered, BallState& out) {
  out = BallState{};
  out.t_us = delivered.t_us;
  stats_.pixels_read = stats_.regions_traced = stats_.overflows = 0;
  stats_.frame_errors = 0;
  if (!initialised_) return Status(StatusCode::kFailedPrecondition, "pipeline: Init() not called");
  meas_ = MeasurementInfo{};
  if (stage_clock_ != nullptr) {
    for (uint32_t& t : stats_.stage_ticks) t = 0;
    stage_mark_ = stage_clock_();
  }
  // 0. A repeated, blind or missing frame is not used; one that lasts flags its camera.
  used_ = delivered;  // a member, not a stack copy: the device's stack budget is tight
  if (!omni_watch_.Observe(used_.omni, used_.omni_t_us)) used_.omni = YuyvImage{};
  if (!persp_watch_.Observe(used_.persp, used_.persp_t_us)) used_.persp = YuyvImage{};
  mirror_rim_.Observe(used_.omni);
  CorrectOmni();
  // A mirror moved beyond correction: its rays are wrong everywhere, the frame is not used.
  if (mirror_rim_.state() == CameraState::kUnusable) used_.omni = YuyvImage{};
  // Turned beyond correction: not used either.
  if (persp_turn_.state() == CameraState::kUnusable) used_.persp = YuyvImage{};
  const FrameInput& in = used_;
  out.omni_check = omni_watch_.check();
  out.persp_check = persp_watch_.check();

  // 1. Prediction for this exposure -> image positions (attention, ball choice).
  Predict(in.t_us);
  Lap(PipelineStage::kPredict);
  // 2. Field features and the robot's pose first: this frame's ball choice uses them.
  const bool have_field_pose = LocaliseAndSetFieldRule(in);
  Lap(PipelineStage::kLocalise);
  // 3. Front end per camera present.
  DetectBalls(in, out);
  Lap(PipelineStage::kFrontEnd);
  // 4. Rays of the detections.
  const CameraRays rays = DetectionRays(in, out);
  // 5. What this frame contributes to the filter.
  BallObservation obs;
  obs.t_us = in.t_us;
  BuildObservation(rays, out, obs);
  Lap(PipelineStage::kRays);
  // 6. Filter, then the state at the exposure time and the prediction.
  if (obs.n_rays > 0) {
    const uint16_t f = filter_.Update(obs);
    meas_.filter_flags = f;
    if (f & (kFlagOutlierRejected | kFlagOutOfField | kFlagBadTimestamp)) {
      ++stats_.rejected_measurements;
    }
    out.flags |= f;
  }
  Lap(PipelineStage::kFilter);
  filter_.FillState(in.t_us, config_.predict_ahead_us, out);
  if (!out.found) {
    track_confirmed_ = track_found_ = false;
  } else {
    if (!track_found_) track_since_us_ = in.t_us;
    track_found_ = true;
    if ((out.flags & kFlagTriangulated) && !(meas_.filter_flags & kFlagOutlierRejected)) {
      track_confirmed_ = true;
    }
  }
  WatchPerspTurn(rays, out);
  Lap(PipelineStage::kState);
  // 7. Colour adaptation from what both cameras agree on.
  AdaptColours(in, out);
  // 8. A track the pose puts outside the field.
  CheckTrackInField(have_field_pose, out);
  // 9. The other candidates: a ball at rest is given up for one that moves like a ball.
  ReviewCandidates(in, out);
  Lap(PipelineStage::kReview);
  return Status();
}

// A confirmed ball on the floor, seen by both cameras, is a sample of the persp camera's turn
// (core/health/persp_turn.h); its state joins the frame watch's in the persp check.
void Pipeline::WatchPerspTurn(const CameraRays& rays, BallState& out) {
  // Not the filter's verdict (rolling or flying): a turned camera's rays make a rolling ball fly.
  // Whether it is on the floor is the watch's to tell, from the persp size's range.
  if (rays.have_omni && rays.have_persp && !rays.omni_cut && !rays.persp_cut &&
      out.persp.radius_px > 2.0f) {
    // The calibrated rays, not the corrected ones the filter got: the estimate is of the whole
    // turn.
    const PerspCalibration& cal = calibration_->persp;
    const Result<Ray> raw = PerspPixelToRay(cal, out.persp.u_px, out.persp.v_px);
    const Result<Ray> rim =
        PerspPixelToRay(cal, out.persp.u_px + out.persp.radius_px, out.persp.v_px);
    if (raw.ok() && rim.ok()) {
      const float angular = out.persp.angular_radius_rad > 0.f ? out.persp.angular_radius_rad
                                                               : AngleBetween(raw->dir, rim->dir);
      const float size_range = calibration_->ball_radius_m / std::sin(std::max(angular, 1e-4f));
      // While the rim says the mirror moved, the omni floor point would turn an intact persp
      // camera: the sample measures the omni camera only.
      persp_turn_.AddFloorSample(rays.omni, *raw, size_range, calibration_->ball_radius_m,
                                 mirror_rim_.state() != CameraState::kAsCalibrated);
    }
  }
  // The worse of the frame watch's state and the geometry's.
  auto join = [](CameraCheck& c, CameraState state, float change_deg, float confidence) {
    if (static_cast<uint8_t>(state) > static_cast<uint8_t>(c.state)) c.state = state;
    c.change_deg = change_deg;
    c.confidence = confidence;
  };
  join(out.persp_check, persp_turn_.state(), persp_turn_.change_deg(), persp_turn_.confidence());
  // The omni camera: the worse of the balls' verdict and the rim's; the balls' figures while
  // they flag it (they measure the rays themselves), unless the rim puts it beyond correction.
  const CameraState balls = persp_turn_.omni_state(), rim = mirror_rim_.state();
  const CameraState worse = static_cast<uint8_t>(rim) > static_cast<uint8_t>(balls) ? rim : balls;
  if (rim == CameraState::kAsCalibrated ||
      (balls != CameraState::kAsCalibrated && rim != CameraState::kUnusable)) {
    join(out.omni_check, worse, persp_turn_.omni_change_deg(), persp_turn_.omni_confidence());
  } else {
    join(out.omni_check, worse, mirror_rim_.change_deg(),
         static_cast<float>(mirror_rim_.last_points()) / MirrorRimWatch::kDirections);
  }
}

// Re-centring is what `calibrate omni` does (the image centre is the rim circle's centre); it
// takes out the mirror's offset whole and most of a tilt's error (core/health/README.md).
void Pipeline::CorrectOmni() {
  if (calibration_ == nullptr) return;
  const OmniCalibration& cal = calibration_->omni;
  const bool moved = OmniCorrected();
  omni_model_.center_u = cal.center_u + (moved ? mirror_rim_.offset_u_px() : 0.f);
  omni_model_.center_v = cal.center_v + (moved ? mirror_rim_.offset_v_px() : 0.f);
  // The feature rays follow the centre: radial about the old one, a side of them would stop
  // short of the rim, where the far lines are (seed 904 knocked: 23 line points a frame instead of
  // 27). Rebuilt only when the centre moved a pixel.
  if (!features_ready_ || (std::fabs(omni_model_.center_u - features_centre_u_) < 1.f &&
                           std::fabs(omni_model_.center_v - features_centre_v_) < 1.f)) {
    return;
  }
  const OmniScanConfig scan = PipelineOmniScan(omni_model_, config_);
  if (extractor_.Init(scan, omni_model_, FeatureConfig(), tables_.feature_walk).ok()) {
    features_centre_u_ = omni_model_.center_u;
    features_centre_v_ = omni_model_.center_v;
  } else {
    features_ready_ = false;  // cannot happen for a centre the calibration's rays fit around
  }
}

FieldFeatureConfig Pipeline::FeatureConfig() const {
  FieldFeatureConfig fc = config_.features;
  fc.line_width_m = calibration_->field.line_width_m;
  fc.goal_width_m = calibration_->field.goal_width_m;
  fc.goal_depth_m = calibration_->field.goal_depth_m;
  return fc;
}

float Pipeline::OmniKnockedRad() const {
  // The balls measure the rays' own error; the rim's is a proxy, used until they do.
  float deg = 0.f;
  if (persp_turn_.omni_state() == CameraState::kChanged) {
    deg = persp_turn_.omni_change_deg();
  } else if (mirror_rim_.state() == CameraState::kChanged) {
    deg = mirror_rim_.change_deg();
  }
  return deg * kPi / 180.0f;
}

void Pipeline::Lap(PipelineStage done) {
  if (stage_clock_ == nullptr) return;
  const uint32_t now = stage_clock_();
  stats_.stage_ticks[static_cast<int>(done)] += now - stage_mark_;  // wraps like the counter
  stage_mark_ = now;
}

const char* PipelineStageName(PipelineStage stage) {
  switch (stage) {
    case PipelineStage::kPredict:
      return "predict";
    case PipelineStage::kFieldFeatures:
      return "field features";
    case PipelineStage::kLocalise:
      return "localise";
    case PipelineStage::kFrontEnd:
      return "front end";
    case PipelineStage::kRays:
      return "rays";
    case PipelineStage::kFilter:
      return "filter";
    case PipelineStage::kState:
      return "state, sigma";
    case PipelineStage::kReview:
      return "adapt, review";
    case PipelineStage::kCount:
      break;
  }
  return "?";
}

bool Pipeline::LocaliseAndSetFieldRule(const FrameInput& in) {
  stats_.feature_lookups = stats_.out_of_field_rejected = 0;
  if (features_ready_ && in.omni.valid()) {
    const bool extracted = extractor_.Extract(in.omni, *lut_, features_).ok();
    Lap(PipelineStage::kFieldFeatures);
    if (extracted) {
      localiser_.Update(features_, in.t_us, odometry_pending_ ? odometry_ : nullptr);
      NameGoals();
      RefuseOffFieldObstacles();
    } else {
      ++stats_.frame_errors;
    }
    odometry_pending_ = false;
    stats_.feature_lookups = features_.lookups;
  }
  RefreshFieldRule();
  const bool have_field_pose = field_rule_.active;
  // Outside the field a ball is only acquired never: a tracked one may roll out over a line.
  omni_finder_.set_reject_outside(have_field_pose && !pred_omni_.valid);
  persp_finder_.set_reject_outside(have_field_pose && !pred_persp_.valid);
  return have_field_pose;
}

void Pipeline::DetectBalls(const FrameInput& in, BallState& out) {
  const RigCalibration& cal = *calibration_;
  if (in.omni.valid() && cal.omni.valid) out.omni = Detect(omni_finder_, in.omni, pred_omni_);
  if (in.persp.valid() && cal.persp.valid) out.persp = Detect(persp_finder_, in.persp, pred_persp_);
  if (out.omni.found && out.persp.found && !pred_omni_.valid && !pred_persp_.valid) {
    ChooseStereoPair(out.omni, out.persp);
  } else if (out.omni.found && out.persp.found && !track_confirmed_ &&
             in.t_us <= track_since_us_ + kYoungTrackUs && !StereoConsistent(out.omni, out.persp) &&
             FindStereoPair(out.omni, out.persp, true)) {
    // A young track no frame of both cameras confirmed (started on one camera's decoy) yields to
    // a pair that is one ball: the filter's gate then takes it as a jump, confirmed by the next.
    // An older one is left to ReviewCandidates (a ball seen by one camera for long is still one).
  } else if (out.omni.found && out.persp.found && !pred_omni_.valid && pred_persp_.valid &&
             PerspLooked(out.persp) && !StereoConsistent(out.omni, out.persp)) {
    // A track the omni cannot see (above its horizon, behind a strut): an omni choice the
    // looked-at persp ball does not meet is something else.
    out.omni = BallDetection{};
  }
}

// A ball cut by the mirror rim or the image border has a biased centroid and size: its ray still
// goes to the filter, with half its radius more of centroid noise and no size cue (a raised ball
// at 4-5 m is seen at the rim; a ball within 1 m is cut by the persp border).
Pipeline::CameraRays Pipeline::DetectionRays(const FrameInput& in, BallState& out) const {
  CameraRays rays;
  rays.omni_cut = out.omni.found && std::hypot(out.omni.u_px - omni_model_.center_u,
                                               out.omni.v_px - omni_model_.center_v) +
                                            out.omni.radius_px >
                                        omni_outer_radius_px_ - kRimMarginPx;
  const float pr = out.persp.radius_px;
  rays.persp_cut =
      out.persp.found && (out.persp.u_px - pr < 0.5f || out.persp.v_px - pr < 0.5f ||
                          out.persp.u_px + pr > static_cast<float>(in.persp.width) - 1.5f ||
                          out.persp.v_px + pr > static_cast<float>(in.persp.height) - 1.5f);
  if (out.omni.found) {
    out.flags |= kFlagSeenOmni;
    float cu = out.omni.u_px, cv = out.omni.v_px;
    if (!rays.omni_cut) {
      ShadedSideCentre(omni_model_, out.omni.radius_px, config_.omni_shade_lost_px, cu, cv);
      OmniSphereCentre(omni_model_, out.omni.radius_px, cu, cv);
    }
    auto ray = OmniPixelToRayExtended(omni_model_, cu, cv);
    if (ray.ok()) {
      rays.omni = *ray;
      rays.have_omni = true;
    }
  }
  // Tracking: a persp region much larger than the predicted ball has merged with a same-coloured
  // object behind it (a red box): its centroid is not the ball's, this frame uses the omni only.
  const bool persp_merged =
      out.persp.found && !rays.persp_cut && pred_persp_.valid && pred_persp_.radius_px > 0.f &&
      out.persp.radius_px > kMaxApparentSizeRatio * pred_persp_.radius_px + 1.0f;
  if (persp_merged) out.persp = BallDetection{};  // not the ball: not reported as seen
  if (out.persp.found && rays.persp_cut && out.persp.arc_sectors > 0) {
    RefineCutBall(in.persp, out.persp);
  }
  if (out.persp.found) {
    out.flags |= kFlagSeenPersp;
    auto ray = PerspPixelToRay(persp_turn_.model(), out.persp.u_px, out.persp.v_px);
    if (ray.ok()) {
      rays.persp = *ray;
      rays.have_persp = true;
    }
  }
  return rays;
}

// The persp ray's angular noise and its apparent-size range, a weak cue.
void Pipeline::PerspRayNoiseAndRange(const BallDetection& det, const Ray& ray, bool cut,
                                     BallRay& out) const {
  const RigCalibration& cal = *calibration_;
  // A region smaller than the predicted ball is the visible part of a partly hidden ball: its
  // centroid is off towards that part by up to the missing radius.
  // A fitted circle has the whole radius; its centre is as good as the arc it spans.
  const bool circle = det.arc_sectors > 0;
  const float hidden_px =
      !circle ? SizeMisfitPx(pred_persp_, det.radius_px, config_.size_range_rel) : 0.f;
  // The arc a circle misses, like a hidden or cut part, is the same frame after frame: shared.
  const float missing_arc_px = circle ? 0.25f * det.radius_px *
                                            static_cast<float>(kCircleSectors - det.arc_sectors) /
                                            static_cast<float>(kCircleSectors)
                                      : 0.f;
  // A ball cut by the image border whose arc gave a circle has that circle's centre and size.
  const bool cut_centroid = cut && !circle;
  const float shape_px = (cut_centroid ? 0.5f * det.radius_px : 0.f) + hidden_px + missing_arc_px;
  const float fx = std::max(cal.persp.fx, 1.0f);
  out.sigma_h_rad = out.sigma_v_rad =
      (config_.persp_sigma_px + config_.persp_sigma_per_radius * det.radius_px +
       (circle ? 0.5f : 0.f) + shape_px) /
      fx;
  out.bias_h_rad = out.bias_v_rad =
      (config_.persp_bias_px + shape_px + (kHiddenCentroidPerMissingRadius - 1.f) * hidden_px) / fx;
  if (persp_turn_.state() == CameraState::kChanged) {  // turned, not corrected: down-weighted
    const float turn_rad = persp_turn_.change_deg() * kPi / 180.0f;
    out.sigma_h_rad = out.sigma_v_rad = std::hypot(out.sigma_h_rad, turn_rad);
    out.bias_h_rad = out.bias_v_rad = std::hypot(out.bias_h_rad, turn_rad);
  }
  if (det.radius_px > 0.5f && !cut_centroid) {
    auto rim = PerspPixelToRay(persp_turn_.model(), det.u_px + det.radius_px, det.v_px);
    if (rim.ok()) {
      const float angular =
          det.angular_radius_rad > 0.f ? det.angular_radius_rad : AngleBetween(ray.dir, rim->dir);
      auto q = PointFromApparentSize(ray, angular, cal.ball_radius_m);
      if (q.ok()) {
        out.range_m = ClosestDepthOnRay(ray, *q);
        // A cut ball's radius is as good as the part of its arc inside the image that was seen.
        const float arc = cut ? static_cast<float>(kCircleSectors) /
                                    static_cast<float>(std::max<int>(det.arc_sectors, 1))
                              : 1.f;
        out.range_sigma_m = out.range_m * (config_.size_range_rel + 0.7f / det.radius_px) * arc;
      }
    }
  }
}

// A cut ball's circle refined by the camera model (FitSphereCone): the centre pixel is the cone
// axis's, the apparent size its half-angle.
void Pipeline::RefineCutBall(const YuyvImage& img, BallDetection& det) const {
  const PerspCalibration& cal = persp_turn_.model();
  const auto regions = persp_finder_.regions().regions();
  size_t i = 0;
  while (i < regions.size() && !(regions[i].cu_px == det.u_px && regions[i].cv_px == det.v_px)) ++i;
  if (i == regions.size()) return;
  int16_t u[kConePoints], v[kConePoints];
  const size_t n = persp_finder_.regions().CirclePoints(i, img.width, img.height, u, v);
  auto centre = PerspPixelToRay(cal, det.u_px, det.v_px);
  auto rim = PerspPixelToRay(cal, det.u_px + det.radius_px, det.v_px);
  if (!centre.ok() || !rim.ok()) return;
  Eigen::Vector3f axis = centre->dir;
  float half_angle = AngleBetween(centre->dir, rim->dir);
  if (!FitSphereCone(cal, u, v, n, axis, half_angle)) return;
  float cu, cv;
  if (!PerspProject(cal, centre->origin + axis, cu, cv).ok()) return;
  det.u_px = cu;
  det.v_px = cv;
  det.angular_radius_rad = half_angle;
}

// The two-ray midpoint (the paper's eq. 2) and its gap decide whether the two detections are the
// same ball; false when they are not.
bool Pipeline::TriangulateSameBall(const CameraRays& rays, BallState& out) {
  auto tri = TriangulateRays(rays.persp, rays.omni, config_.triangulation);
  if (tri.ok()) {
    out.ray_gap_m = tri->gap_m;
    const float range = (tri->point - rays.persp.origin).norm();
    if (tri->gap_m <= std::min(config_.max_ray_gap_m, kStereoGapM + kStereoGapPerM * range)) {
      out.flags |= kFlagTriangulated;
      meas_.valid = true;
      meas_.p_m = tri->point;
    } else {
      return false;
    }
  } else if (tri.status().code() == StatusCode::kOutOfRange) {
    out.flags |= kFlagRaysParallel;  // both rays still go to the filter: it weighs them
  } else if (tri.status().code() == StatusCode::kNotFound) {
    return false;  // they meet behind a camera: two objects in different directions
  }
  return true;
}

// Every usable ray with its angular noise (the centroid's, grown with the region: partial
// classification moves it by a fraction of the radius), the persp ray with its apparent-size
// range; the measurement for evaluation, from the triangulation or a one-camera fallback.
void Pipeline::BuildObservation(const CameraRays& rays, BallState& out, BallObservation& obs) {
  const RigCalibration& cal = *calibration_;
  const bool have_o = rays.have_omni, have_p = rays.have_persp;
  BallRay omni_ray, persp_ray;
  if (have_o) {
    omni_ray.origin = rays.omni.origin;
    omni_ray.dir = rays.omni.dir;
    omni_ray.camera = 0;
    const float hidden_px = SizeMisfitPx(pred_omni_, out.omni.radius_px, config_.size_range_rel);
    const float cut_px = rays.omni_cut ? 0.5f * out.omni.radius_px : 0.f;
    OmniRaySigma(omni_model_, out.omni, rays.omni, cut_px + hidden_px,
                 cut_px + kHiddenCentroidPerMissingRadius * hidden_px, config_, omni_ray);
    if (const float change_rad = OmniKnockedRad(); change_rad > 0.f) {  // down-weighted
      omni_ray.sigma_v_rad = std::hypot(omni_ray.sigma_v_rad, change_rad);
      omni_ray.bias_v_rad = std::hypot(omni_ray.bias_v_rad, change_rad);
    }
  }
  if (have_p) {
    persp_ray.origin = rays.persp.origin;
    persp_ray.dir = rays.persp.dir;
    persp_ray.camera = 1;
    PerspRayNoiseAndRange(out.persp, rays.persp, rays.persp_cut, persp_ray);
  }
  const bool same_ball = !(have_o && have_p) || TriangulateSameBall(rays, out);
  if (have_o) {
    auto g = IntersectRayWithPlaneZ(rays.omni, cal.ball_radius_m);
    if (g.ok()) {
      meas_.omni_ground_valid = true;
      meas_.omni_ground_m = *g;
    }
  }
  if (same_ball) {
    if (have_o) obs.rays[obs.n_rays++] = omni_ray;
    if (have_p) obs.rays[obs.n_rays++] = persp_ray;
  } else {
    // Two different objects: the one nearer its camera's prediction (in ball radii there) goes
    // in, the omni one without a prediction (it sees the whole field); the filter's gate has the
    // final word.
    const bool persp_nearer =
        PredictionMisfit(pred_persp_, out.persp, pred_persp_.radius_px) <
        PredictionMisfit(pred_omni_, out.omni, pred_omni_.silhouette_radius_px);
    obs.rays[obs.n_rays++] = persp_nearer ? persp_ray : omni_ray;
  }
  if (obs.n_rays == 1) {
    out.flags |= obs.rays[0].camera == 0 ? kFlagOmniGroundFallback : kFlagPerspSizeFallback;
  }
  if (!meas_.valid && obs.n_rays == 1 && obs.rays[0].camera == 0 && meas_.omni_ground_valid) {
    meas_.valid = true;
    meas_.p_m = meas_.omni_ground_m;
    meas_.z_valid = false;
  } else if (!meas_.valid && obs.n_rays == 1 && persp_ray.range_m > 0.f) {
    meas_.valid = true;
    meas_.p_m = persp_ray.origin + persp_ray.dir * persp_ray.range_m;
  }
}

// Only what both cameras agree on is the ball (rays within 2 cm, the filter took the
// measurement); a rebuilt table's chroma box goes to the finders.
void Pipeline::AdaptColours(const FrameInput& in, const BallState& out) {
  if (adapter_ == nullptr || !adapter_->active()) return;
  const bool confirmed = out.found && out.omni.found && out.persp.found &&
                         (out.flags & kFlagTriangulated) && out.ray_gap_m <= kAdaptMaxGapM &&
                         !(meas_.filter_flags & (kFlagOutlierRejected | kFlagOutOfField));
  if (confirmed) {
    adapter_->Observe(in.omni, out.omni);
    adapter_->Observe(in.persp, out.persp);
  }
  const uint32_t rebuilt = adapter_->stats().rebuilds_done;
  adapter_->Step();
  if (adapter_->stats().rebuilds_done != rebuilt) {
    omni_finder_.set_ball_box(adapter_->ball_box());
    persp_finder_.set_ball_box(adapter_->ball_box());
  }
}

// A track that the pose puts outside the field was locked on something else (a spare ball behind
// the goal line, a red box): drop it, so the next frame chooses afresh. Unless it was inside and
// is rolling out: then it stays tracked, flagged out of the field, while it moves.
void Pipeline::CheckTrackInField(bool have_field_pose, BallState& out) {
  if (!out.found) {
    track_seen_in_field_ = false;
  } else if (have_field_pose) {
    if (InField(out.x_m, out.y_m)) {
      track_seen_in_field_ = true;
    } else if (track_seen_in_field_ && std::hypot(out.vx_mps, out.vy_mps) >= kMinRollOutSpeedMps) {
      out.flags |= kFlagOutOfField;
    } else {
      filter_.Reset();
      track_confirmed_ = track_found_ = false;
      ++stats_.tracks_dropped_out_of_field;
      out.found = false;
      out.flags |= kFlagOutOfField | kFlagLost;
    }
  }
}

// The omni candidates on the floor, tracked beside the filter (core/ball_filter/candidate_tracks):
// when the filter's ball has rested a while and another candidate moves like a ball, in the
// field, the filter lets go and the next frame looks for that one first. In the field frame when
// the pose is known, so a driving robot does not see a decoy at rest move.
void Pipeline::ReviewCandidates(const FrameInput& in, const BallState& out) {
  const RigCalibration& cal = *calibration_;
  if (!cal.omni.valid) return;
  RobotPose pose;
  float sigma_m = 0;
  const bool field = FieldPose(pose, sigma_m);
  if (field != candidates_in_field_frame_) candidates_.Reset();
  candidates_in_field_frame_ = field;
  const float s = field ? std::sin(pose.heading_rad) : 0.f,
              c = field ? std::cos(pose.heading_rad) : 1.f;
  const auto to_frame = [&](float x, float y) {  // robot frame -> the tracks' frame
    return field ? FloorPoint{pose.x_m + x * s + y * c, pose.y_m - x * c + y * s}
                 : FloorPoint{x, y};
  };
  FloorPoint seen[kStereoCandidates];
  size_t n = 0;
  if (in.omni.valid()) {
    BallDetection co[kStereoCandidates];
    const size_t nc = omni_finder_.Candidates(co);
    for (size_t i = 0; i < nc; ++i) {
      // The filter's own ball (in the air its floor point lies far beyond it) is not a rival.
      if (out.omni.found && std::hypot(co[i].u_px - out.omni.u_px, co[i].v_px - out.omni.v_px) <
                                std::max(out.omni.radius_px, 3.f)) {
        continue;
      }
      const Result<Ray> ray = OmniPixelToRayExtended(omni_model_, co[i].u_px, co[i].v_px);
      if (!ray.ok() || ray->dir.z() > -1e-3f) continue;
      const float k = (cal.ball_radius_m - ray->origin.z()) / ray->dir.z();
      const Eigen::Vector3f q = ray->origin + k * ray->dir;
      if (q.head<2>().norm() > kMaxCandidateRangeM || !InField(q.x(), q.y())) continue;
      seen[n++] = to_frame(q.x(), q.y());
    }
  }
  const FloorPoint main = to_frame(out.x_m, out.y_m);
  const CandidateTracks::Track* t = candidates_.Update(
      in.t_us, std::span<const FloorPoint>(seen, n),
      out.found && out.z_m < cal.ball_radius_m + kOnFloorM, main.x_m, main.y_m,
      std::sqrt(out.vx_mps * out.vx_mps + out.vy_mps * out.vy_mps + out.vz_mps * out.vz_mps));
  if (t == nullptr) return;
  // Back to the robot frame for the prediction.
  const float dx = t->x - (field ? pose.x_m : 0.f), dy = t->y - (field ? pose.y_m : 0.f);
  handover_ = Handover{true,
                       field ? dx * s - dy * c : dx,
                       field ? dx * c + dy * s : dy,
                       field ? t->vx * s - t->vy * c : t->vx,
                       field ? t->vx * c + t->vy * s : t->vy,
                       in.t_us};
  filter_.Reset();
  track_confirmed_ = track_found_ = false;
  candidates_.Reset();
  ++stats_.track_handovers;
}

}  // namespace bv
