#include "core/calibration/calibration.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>
#include <Eigen/LU>

#include "core/common/blob.h"
#include "core/common/bytes.h"
#include "core/common/crc32.h"

// Omni angle convention: sector s covers the image angle phi in [s*8°, (s+1)*8°), with
// phi = atan2(v - center_v, u - center_u) in [0, 2π) (image axes, v down). Its support vectors
// belong to the sector centre (s + 0.5) * 8°; between centres they are interpolated linearly.
// The robot azimuth theta (CCW from +x) follows from phi = sign * theta + offset.
// Along a direction the map is piecewise linear between the support vectors, in the viewing
// angle psi = atan(d / f_O) rather than in d itself: on the reference rig that cuts the
// mid-segment error at 1 m from 2.8 % to 0.8 % with the same 12 support vectors.

namespace bv {
namespace {

constexpr float kPi = 3.14159265358979f;
constexpr float kTwoPi = 2.0f * kPi;
constexpr float kSectorRad = kTwoPi / OmniCalibration::kDirections;
// Newton steps of the radial inverse distortion; 8 reach float precision for |k1 r²| < 0.5.
constexpr int kUndistortIterations = 8;

bool Finite(float v) { return std::isfinite(v); }

float WrapTwoPi(float a) {
  a = std::fmod(a, kTwoPi);
  if (a < 0) a += kTwoPi;
  if (a >= kTwoPi) a = 0;
  return a;
}

// r_d = r (1 + k1 r² + k2 r⁴) and its derivative.
float RadialForward(const PerspCalibration& c, float r) {
  const float r2 = r * r;
  return r * (1 + c.k1 * r2 + c.k2 * r2 * r2);
}

}  // namespace

// --------------------------------------------------------------------------------------------
// Perspective camera.

Result<Ray> PerspPixelToRay(const PerspCalibration& cal, float u_px, float v_px) {
  if (!cal.valid) return Status(StatusCode::kFailedPrecondition, "persp calibration not valid");
  if (!Finite(u_px) || !Finite(v_px)) {
    return Status(StatusCode::kInvalidArgument, "persp pixel is not finite");
  }
  const float yd = (v_px - cal.cy) / cal.fy;
  const float xd = (u_px - cal.cx - cal.skew * yd) / cal.fx;
  const float rd = std::sqrt(xd * xd + yd * yd);
  float scale = 1.0f;  // undistorted / distorted radius
  if (rd > 1e-9f) {
    // Newton on f(r) = r (1 + k1 r² + k2 r⁴) - rd, started at rd (fixed count, no early exit).
    float r = rd;
    for (int i = 0; i < kUndistortIterations; ++i) {
      const float r2 = r * r;
      const float f = r * (1 + cal.k1 * r2 + cal.k2 * r2 * r2) - rd;
      const float df = 1 + 3 * cal.k1 * r2 + 5 * cal.k2 * r2 * r2;
      if (!(df > 1e-3f)) {
        return Status(StatusCode::kOutOfRange, "persp pixel beyond the invertible distortion");
      }
      r -= f / df;
      if (!(r > 0)) r = 0.5f * rd;  // keep the iterate on the valid branch
    }
    // Residual check in pixels: the model must reproduce the input within 0.01 px.
    const float err_px = std::fabs(RadialForward(cal, r) - rd) * cal.fx;
    if (!(err_px < 0.01f)) {
      return Status(StatusCode::kOutOfRange, "persp inverse distortion did not converge");
    }
    scale = r / rd;
  }
  const Eigen::Vector3f d_cam(xd * scale, yd * scale, 1.0f);
  Ray ray;
  ray.origin = cal.t_robot_cam;
  ray.dir = (cal.R_robot_cam * d_cam).normalized();
  return ray;
}

Status PerspProject(const PerspCalibration& cal, const Eigen::Vector3f& p_robot, float& u_px,
                    float& v_px) {
  if (!cal.valid) return Status(StatusCode::kFailedPrecondition, "persp calibration not valid");
  if (!p_robot.allFinite()) return Status(StatusCode::kInvalidArgument, "point is not finite");
  const Eigen::Vector3f p = cal.R_robot_cam.transpose() * (p_robot - cal.t_robot_cam);
  if (!(p.z() > 1e-6f)) return Status(StatusCode::kOutOfRange, "point behind the persp camera");
  const float x = p.x() / p.z();
  const float y = p.y() / p.z();
  const float r2 = x * x + y * y;
  const float g = 1 + cal.k1 * r2 + cal.k2 * r2 * r2;
  const float xd = x * g, yd = y * g;
  u_px = cal.fx * xd + cal.skew * yd + cal.cx;
  v_px = cal.fy * yd + cal.cy;
  return Status::Ok();
}

// --------------------------------------------------------------------------------------------
// Omni camera.

namespace {

// The viewing angle of support vector k, computed; EdgePsi: the prepared one, else computed (a map
// built in code).
float ComputedEdgePsi(const OmniCalibration& cal, int k) {
  return std::atan(cal.edge_ground_m[k] / cal.viewpoint_z_m);
}
float EdgePsi(const OmniCalibration& cal, int k) {
  const float psi = cal.edge_psi_rad[k];
  return psi > 0.0f ? psi : ComputedEdgePsi(cal, k);
}

// Support vectors at image angle phi, interpolated between the two nearest sector centres, each
// on demand: a lookup reads two or three of the twelve.
class SupportAt {
 public:
  SupportAt(const OmniCalibration& cal, float phi) {
    const float pos = WrapTwoPi(phi) / kSectorRad - 0.5f;  // in units of sector centres
    const float fl = std::floor(pos);
    w_ = pos - fl;
    s0_ = static_cast<int>(fl);
    if (s0_ < 0) s0_ += OmniCalibration::kDirections;
    if (s0_ >= OmniCalibration::kDirections) s0_ -= OmniCalibration::kDirections;
    Point(cal);
  }
  // Sector s0's vectors blended with the next one's by w (a direction prepared before).
  SupportAt(const OmniCalibration& cal, int s0, float w) : s0_(s0), w_(w) { Point(cal); }
  float operator[](int k) const { return (1 - w_) * a_[k] + w_ * b_[k]; }
  int sector() const { return s0_; }
  float blend() const { return w_; }

 private:
  void Point(const OmniCalibration& cal) {
    a_ = cal.support_px[s0_];
    b_ = cal.support_px[(s0_ + 1) % OmniCalibration::kDirections];
  }
  const float* a_ = nullptr;
  const float* b_ = nullptr;
  int s0_ = 0;
  float w_ = 0;
};

// Inside the first support vector no edge is seen (the robot body hides the carpet start), so
// the first segment is psi = a r + b r² through (0, 0) and the first two support vectors
// (on the reference rig: median error 3 % -> 0.2 % between 0.36 and 0.8 m). False (use the
// linear segment) if that parabola is not increasing up to the first support vector.
bool InnerQuadratic(const OmniCalibration& cal, const SupportAt& sv, float& a, float& b) {
  const float r0 = sv[0], r1 = sv[1];
  const float p0 = EdgePsi(cal, 0);
  const float p1 = EdgePsi(cal, 1);
  b = (p1 / r1 - p0 / r0) / (r1 - r0);
  a = p0 / r0 - b * r0;
  return a > 0 && a + 2 * b * r0 > 0;
}

// h of the direction (cos phi, sin phi): no trigonometry where the pixel gives the direction.
float AzimuthTurn(const OmniCalibration& cal, float c, float s) {
  const float* h = cal.azimuth_harmonics_rad;
  return h[0] * c + h[1] * s + h[2] * (c * c - s * s) + h[3] * (2.0f * s * c);
}
bool HasAzimuthTurn(const OmniCalibration& cal) {
  const float* h = cal.azimuth_harmonics_rad;
  return h[0] != 0.0f || h[1] != 0.0f || h[2] != 0.0f || h[3] != 0.0f;
}
}  // namespace

void PrepareOmniAngles(OmniCalibration& cal) {
  if (!(cal.viewpoint_z_m > 0.0f)) return;  // no map: nothing to prepare
  for (int k = 0; k < OmniCalibration::kEdges; ++k) cal.edge_psi_rad[k] = ComputedEdgePsi(cal, k);
}

float OmniAzimuthCorrection(const OmniCalibration& cal, float phi) {
  return HasAzimuthTurn(cal) ? AzimuthTurn(cal, std::cos(phi), std::sin(phi)) : 0.0f;
}

namespace {
// The direction's terms of the pixel-to-ground map: which support vectors, the inner quadratic
// and the ground bearing. (c, s) is the unit direction, phi its image angle.
void DirectionTerms(const OmniCalibration& cal, float phi, float c, float s, bool turned,
                    OmniGroundDirection& d) {
  const SupportAt sv(cal, phi);
  d.sector = static_cast<int16_t>(sv.sector());
  d.blend = sv.blend();
  d.last_px = sv[OmniCalibration::kEdges - 1];
  d.quadratic = InnerQuadratic(cal, sv, d.quad_a, d.quad_b);
  const float turn = turned && HasAzimuthTurn(cal) ? AzimuthTurn(cal, c, s) : 0.0f;
  const float theta =
      static_cast<float>(cal.image_angle_sign) * (phi - cal.image_angle_offset_rad - turn);
  d.cos_bearing = std::cos(theta);
  d.sin_bearing = std::sin(theta);
}

// Piecewise linear from the image radius to the viewing angle psi = atan(d / f_O), through
// (0 px, 0) (the centre sees the nadir) and the support vectors.
Status RadiusToGround(const OmniCalibration& cal, const OmniGroundDirection& d, float r, float& x_m,
                      float& y_m) {
  if (r > d.last_px + 0.01f) {
    return Status(StatusCode::kOutOfRange, "omni pixel beyond the calibrated distance map");
  }
  r = std::min(r, d.last_px);  // within rounding of the last vector
  const SupportAt sv(cal, d.sector, d.blend);
  int k = 0;
  while (r > sv[k]) ++k;  // r <= the last vector, checked above
  float psi = 0;
  if (k == 0 && d.quadratic) {
    psi = d.quad_a * r + d.quad_b * r * r;
  } else {
    const float r0 = k == 0 ? 0.0f : sv[k - 1];
    const float psi0 = k == 0 ? 0.0f : EdgePsi(cal, k - 1);
    const float psi1 = EdgePsi(cal, k);
    psi = psi0 + (psi1 - psi0) * (r - r0) / (sv[k] - r0);
  }
  const float dist_m = cal.viewpoint_z_m * std::tan(psi);
  x_m = dist_m * d.cos_bearing;
  y_m = dist_m * d.sin_bearing;
  return Status::Ok();
}
}  // namespace

Status OmniPixelToGround(const OmniCalibration& cal, float u_px, float v_px, float& x_m,
                         float& y_m) {
  if (!cal.valid) return Status(StatusCode::kFailedPrecondition, "omni calibration not valid");
  if (!Finite(u_px) || !Finite(v_px)) {
    return Status(StatusCode::kInvalidArgument, "omni pixel is not finite");
  }
  const float du = u_px - cal.center_u, dv = v_px - cal.center_v;
  const float rho = std::sqrt(du * du + dv * dv);
  OmniGroundDirection d;
  const bool turned = rho > 1e-3f;
  DirectionTerms(cal, std::atan2(dv, du), turned ? du / rho : 1.0f, turned ? dv / rho : 0.0f,
                 turned, d);
  return RadiusToGround(cal, d, rho, x_m, y_m);
}

Status OmniPrepareGroundDirection(const OmniCalibration& cal, float du, float dv,
                                  OmniGroundDirection& out) {
  out = OmniGroundDirection{};
  if (!cal.valid) return Status(StatusCode::kFailedPrecondition, "omni calibration not valid");
  const float len = std::sqrt(du * du + dv * dv);
  if (!Finite(du) || !Finite(dv) || !(len > 0.0f)) {
    return Status(StatusCode::kInvalidArgument, "omni direction is not finite and non-zero");
  }
  DirectionTerms(cal, std::atan2(dv, du), du / len, dv / len, true, out);
  out.step_px = len;
  return Status::Ok();
}

Status OmniStepToGround(const OmniCalibration& cal, const OmniGroundDirection& dir, float t,
                        float& x_m, float& y_m) {
  if (!cal.valid || dir.sector < 0) {
    return Status(StatusCode::kFailedPrecondition, "omni direction not prepared");
  }
  if (!Finite(t) || t < 0.0f) return Status(StatusCode::kInvalidArgument, "omni step not finite");
  return RadiusToGround(cal, dir, t * dir.step_px, x_m, y_m);
}

Status OmniGroundToPixel(const OmniCalibration& cal, float x_m, float y_m, float& u_px,
                         float& v_px) {
  if (!cal.valid) return Status(StatusCode::kFailedPrecondition, "omni calibration not valid");
  if (!Finite(x_m) || !Finite(y_m)) {
    return Status(StatusCode::kInvalidArgument, "ground point is not finite");
  }
  const float last_m = cal.edge_ground_m[OmniCalibration::kEdges - 1];
  float dist_m = std::sqrt(x_m * x_m + y_m * y_m);
  if (dist_m > last_m * 1.0001f) {
    return Status(StatusCode::kOutOfRange, "ground point beyond the calibrated distance map");
  }
  dist_m = std::min(dist_m, last_m);
  const float theta = std::atan2(y_m, x_m);
  const float phi0 = static_cast<float>(cal.image_angle_sign) * theta + cal.image_angle_offset_rad;
  // phi = phi0 + h(phi) by fixed-point steps: |h'| <= 0.43 for harmonics within 0.1 rad, so three
  // evaluations leave < 8 % of h; with the reference rig's |h'| ~ 0.01, nothing measurable.
  float phi = phi0;
  if (HasAzimuthTurn(cal)) {
    for (int i = 0; i < 3; ++i) phi = phi0 + AzimuthTurn(cal, std::cos(phi), std::sin(phi));
  }
  const SupportAt sv(cal, phi);
  int k = 0;
  while (dist_m > cal.edge_ground_m[k]) ++k;  // dist_m <= last edge checked above
  const float psi = std::atan(dist_m / cal.viewpoint_z_m);
  float r = 0;
  float qa = 0, qb = 0;
  if (k == 0 && InnerQuadratic(cal, sv, qa, qb)) {
    // root of qb r² + qa r - psi = 0 on the increasing branch (stable form)
    r = 2 * psi / (qa + std::sqrt(std::max(qa * qa + 4 * qb * psi, 0.0f)));
  } else {
    const float r0 = k == 0 ? 0.0f : sv[k - 1];
    const float psi0 = k == 0 ? 0.0f : EdgePsi(cal, k - 1);
    const float psi1 = EdgePsi(cal, k);
    r = r0 + (sv[k] - r0) * (psi - psi0) / (psi1 - psi0);
  }
  u_px = cal.center_u + r * std::cos(phi);
  v_px = cal.center_v + r * std::sin(phi);
  return Status::Ok();
}

Result<Ray> OmniPixelToRay(const OmniCalibration& cal, float u_px, float v_px) {
  float x = 0, y = 0;
  BV_TRY(OmniPixelToGround(cal, u_px, v_px, x, y));
  Ray ray;
  ray.origin = Eigen::Vector3f(0, 0, cal.viewpoint_z_m);
  ray.dir = Eigen::Vector3f(x, y, -cal.viewpoint_z_m).normalized();
  return ray;
}

// Beyond the map the elevation angle, unlike the ground distance, stays smooth up to and past
// the horizon. The unified central-catadioptric model r = k sin(a) / (xi + cos(a)) (a: angle
// from the nadir) is fitted by least squares to the map's support vectors in the pixel's
// direction that lie within kOmniFitBelowHorizonRad of the horizon (r xi - k sin(a) =
// -r cos(a), linear in xi and k), and continued. A fit through the last two knots alone carried
// their noise into the slope: on the reference rig against the true mirror, the least-squares
// fit errs 2-3x less (median 0.2 / 0.55 / 0.65 mrad below the horizon / 0-4 / 4-8 degrees above
// it, tools/python/validate_rays.py). The map's own last knot is met exactly and the fit takes
// over within a few pixels, so the ray does not jump where the map ends.
namespace {
constexpr float kOmniFitBelowHorizonRad = 20.0f * kPi / 180.0f;
constexpr float kOmniJoinPx = 3.0f;  // the map's end offset decays over this many pixels
}  // namespace

Result<Ray> OmniPixelToRayExtended(const OmniCalibration& cal, float u_px, float v_px) {
  auto ray = OmniPixelToRay(cal, u_px, v_px);
  if (ray.ok() || ray.status().code() != StatusCode::kOutOfRange) return ray;
  const float du = u_px - cal.center_u, dv = v_px - cal.center_v;
  const float r = std::hypot(du, dv);
  if (!(r > 20.f) || !(cal.viewpoint_z_m > 0.f)) return ray;
  const SupportAt sv(cal, std::atan2(dv, du));
  constexpr int kLast = OmniCalibration::kEdges - 1;
  const float last = sv[kLast];
  float sxx = 0, sxy = 0, syy = 0, sxb = 0, syb = 0;
  int used = 0;
  for (int k = 0; k <= kLast; ++k) {
    const float ak = EdgePsi(cal, k);
    if (ak < 0.5f * kPi - kOmniFitBelowHorizonRad) continue;
    const float p = sv[k] / last, q = -std::sin(ak), b = -p * std::cos(ak);  // r in units of last
    sxx += p * p;
    sxy += p * q;
    syy += q * q;
    sxb += p * b;
    syb += q * b;
    ++used;
  }
  const float det = sxx * syy - sxy * sxy;
  if (used < 3 || !(det > 1e-9f * sxx * syy)) {
    return Status(StatusCode::kOutOfRange, "omni ray: too few support vectors near the horizon");
  }
  const float xi = (syy * sxb - sxy * syb) / det;
  const float scale = last * (sxx * syb - sxy * sxb) / det;  // the model's k, in pixels
  const auto model = [&](float rr) {
    const float arg = -rr * xi / std::hypot(rr, scale);
    if (!(scale > 0.f) || !(std::fabs(arg) <= 1.f)) return -1.f;
    return std::acos(arg) - std::atan2(scale, rr);
  };
  const float a_last = EdgePsi(cal, kLast);
  const float m_last = model(last);
  float a = model(r);
  if (m_last > 0.f && a > 0.f) a += (a_last - m_last) * std::exp(-(r - last) / kOmniJoinPx);
  if (!(a > 0.f) || a > 1.75f) {  // beyond ~10 degrees above the horizon: not the mirror
    return Status(StatusCode::kOutOfRange, "omni ray: pixel far beyond the distance map");
  }
  float x1, y1;  // the azimuth where the map ends in this direction
  BV_TRY(
      OmniPixelToGround(cal, cal.center_u + last * du / r, cal.center_v + last * dv / r, x1, y1));
  const float theta = std::atan2(y1, x1);
  Ray out;
  out.origin = Eigen::Vector3f(0.f, 0.f, cal.viewpoint_z_m);
  out.dir =
      Eigen::Vector3f(std::sin(a) * std::cos(theta), std::sin(a) * std::sin(theta), -std::cos(a));
  return out;
}

Status OmniProject(const OmniCalibration& cal, const Eigen::Vector3f& p_robot, float& u_px,
                   float& v_px) {
  if (!cal.valid) return Status(StatusCode::kFailedPrecondition, "omni calibration not valid");
  if (!p_robot.allFinite()) return Status(StatusCode::kInvalidArgument, "point is not finite");
  const float h = cal.viewpoint_z_m - p_robot.z();
  if (!(h > 1e-4f)) {
    return Status(StatusCode::kOutOfRange, "point at or above the omni viewpoint");
  }
  const float s = cal.viewpoint_z_m / h;  // scales the horizontal offset down to the floor
  return OmniGroundToPixel(cal, p_robot.x() * s, p_robot.y() * s, u_px, v_px);
}

Status ValidateSelfMask(const OmniSelfMask& m) {
  if (!m.known) {
    bool zero = m.sector_count == 0 && m.inner_radius_px == 0.0f && m.outer_radius_px == 0.0f;
    for (uint8_t b : m.body_px) zero = zero && b == 0;
    return zero ? Status()
                : Status(StatusCode::kInvalidArgument, "self-mask: unknown, yet not empty");
  }
  if (!std::isfinite(m.inner_radius_px) || !std::isfinite(m.outer_radius_px) ||
      !(m.inner_radius_px >= 1.0f) || !(m.outer_radius_px <= 2048.0f) ||
      !(m.outer_radius_px > m.inner_radius_px + 8.0f)) {
    return Status(StatusCode::kInvalidArgument,
                  "self-mask: radii out of range (need 1 <= inner < outer - 8 <= 2040 px)");
  }
  for (uint8_t b : m.body_px) {
    if (b >= m.outer_radius_px)
      return Status(StatusCode::kInvalidArgument,
                    "self-mask: body outline beyond the outer radius");
  }
  if (m.sector_count < 0 || m.sector_count > OmniSelfMask::kMaxSectors) {
    return Status(StatusCode::kInvalidArgument, "self-mask: more than 8 sectors");
  }
  float masked = 0;
  for (int i = 0; i < m.sector_count; ++i) {
    const OmniSelfMask::Sector& c = m.sectors[i];
    if (!(c.angle_deg >= 0.0f && c.angle_deg < 360.0f) ||
        !(c.half_width_deg > 0.0f && c.half_width_deg <= 45.0f)) {
      return Status(StatusCode::kInvalidArgument,
                    "self-mask: sector angle outside [0, 360) or half width outside (0, 45] deg");
    }
    masked += 2.0f * c.half_width_deg;
  }
  if (masked > OmniSelfMask::kMaxMaskedDeg) {
    return Status(StatusCode::kInvalidArgument,
                  "self-mask: sectors cover more than 120 deg of the image (most of it: refused)");
  }
  return Status();
}

// --------------------------------------------------------------------------------------------
// Blob. Payload (little endian): ids, ball radius, persp section, omni section, field section
// (version 2), omni azimuth harmonics (version 3), omni self-mask (version 4); every float
// is checked when parsing. Parsing runs twice over the payload: once to validate (dst null),
// once to store, so `out` is untouched on any error without a second RigCalibration on the
// stack.

namespace {

constexpr uint32_t kPerspTag = 0x50455253u;    // "SREP"
constexpr uint32_t kOmniTag = 0x494E4D4Fu;     // "OMNI"
constexpr uint32_t kFieldTag = 0x444C4946u;    // "FILD", from blob version 2
constexpr uint32_t kAzimuthTag = 0x4D495A41u;  // "AZIM", from blob version 3
constexpr uint32_t kSelfTag = 0x464C4553u;     // "SELF", from blob version 4
constexpr float kMaxHarmonicRad = 0.1f;

// The field section's floats, in blob order.
constexpr int kFieldFloats = 15;
template <typename Config, typename Float>
void FieldFloats(Config& f, Float* (&v)[kFieldFloats]) {
  Float* all[kFieldFloats] = {&f.length_m,
                              &f.width_m,
                              &f.line_width_m,
                              &f.center_circle_radius_m,
                              &f.penalty_area_depth_m,
                              &f.penalty_area_width_m,
                              &f.goal_area_depth_m,
                              &f.goal_area_width_m,
                              &f.penalty_mark_distance_m,
                              &f.corner_arc_radius_m,
                              &f.goal_width_m,
                              &f.goal_height_m,
                              &f.goal_depth_m,
                              &f.border_m,
                              &f.margin_m};
  for (int i = 0; i < kFieldFloats; ++i) v[i] = all[i];
}

void WritePersp(ByteWriter& w, const PerspCalibration& p) {
  w.U32(kPerspTag);
  w.U8(p.valid ? 1 : 0);
  w.U16(static_cast<uint16_t>(p.width_px));
  w.U16(static_cast<uint16_t>(p.height_px));
  for (float f : {p.fx, p.fy, p.cx, p.cy, p.skew, p.k1, p.k2, p.rms_px}) w.F32(f);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) w.F32(p.R_robot_cam(r, c));
  for (int i = 0; i < 3; ++i) w.F32(p.t_robot_cam(i));
}

void WriteOmni(ByteWriter& w, const OmniCalibration& o) {
  w.U32(kOmniTag);
  w.U8(o.valid ? 1 : 0);
  w.U8(static_cast<uint8_t>(o.image_angle_sign));
  w.U16(static_cast<uint16_t>(OmniCalibration::kDirections));
  w.U16(static_cast<uint16_t>(OmniCalibration::kEdges));
  for (float f : {o.center_u, o.center_v, o.viewpoint_z_m, o.image_angle_offset_rad}) w.F32(f);
  for (float f : o.edge_ground_m) w.F32(f);
  for (const auto& row : o.support_px)
    for (float f : row) w.F32(f);
  for (uint8_t f : o.sector_flags) w.U8(f);
}

void WriteAzimuth(ByteWriter& w, const OmniCalibration& o) {
  w.U32(kAzimuthTag);
  for (float f : o.azimuth_harmonics_rad) w.F32(f);
}

void WriteSelfMask(ByteWriter& w, const OmniSelfMask& m) {
  w.U32(kSelfTag);
  w.U8(m.known ? 1 : 0);
  w.F32(m.inner_radius_px);
  w.F32(m.outer_radius_px);
  w.U8(static_cast<uint8_t>(m.sector_count));
  for (int i = 0; i < m.sector_count && i < OmniSelfMask::kMaxSectors; ++i) {
    w.F32(m.sectors[i].angle_deg);
    w.F32(m.sectors[i].half_width_deg);
  }
  for (uint8_t b : m.body_px) w.U8(b);
}

void WriteField(ByteWriter& w, const FieldConfig& f) {
  w.U32(kFieldTag);
  const float* v[kFieldFloats];
  FieldFloats(f, v);
  for (const float* p : v) w.F32(*p);
}

// Reads a float; fails (sticky) unless finite and in [lo, hi].
class CheckedReader {
 public:
  explicit CheckedReader(std::span<const uint8_t> in) : r_(in) {}
  float F(float lo, float hi, const char* what) {
    const float v = r_.F32();
    if (!r_.ok()) Fail(StatusCode::kDataLoss, "calibration blob: payload truncated");
    if (!Finite(v) || v < lo || v > hi) Fail(StatusCode::kInvalidArgument, what);
    return v;
  }
  uint8_t U8() { return Checked(r_.U8()); }
  uint16_t U16() { return Checked(r_.U16()); }
  uint32_t U32() { return Checked(r_.U32()); }
  void Fail(StatusCode code, const char* what) {
    if (status_.ok()) status_ = Status(code, what);
  }
  Status status() const { return status_; }
  size_t remaining() const { return r_.remaining(); }

 private:
  template <typename T>
  T Checked(T v) {
    if (!r_.ok()) Fail(StatusCode::kDataLoss, "calibration blob: payload truncated");
    return v;
  }
  ByteReader r_;
  Status status_;
};

constexpr float kBig = 1e30f;

void ReadPersp(CheckedReader& r, PerspCalibration* dst) {
  if (r.U32() != kPerspTag) r.Fail(StatusCode::kDataLoss, "calibration blob: persp tag missing");
  PerspCalibration p;
  const uint8_t valid = r.U8();
  if (valid > 1) r.Fail(StatusCode::kInvalidArgument, "calibration blob: persp.valid not 0/1");
  p.valid = valid == 1;
  p.width_px = r.U16();
  p.height_px = r.U16();
  const bool v = p.valid;
  if (v && (p.width_px < 16 || p.width_px > 4096 || p.height_px < 16 || p.height_px > 4096)) {
    r.Fail(StatusCode::kInvalidArgument, "calibration blob: persp image size out of range");
  }
  const float w = static_cast<float>(p.width_px), h = static_cast<float>(p.height_px);
  p.fx = r.F(v ? 1.0f : -kBig, v ? 1e5f : kBig, "calibration blob: persp.fx out of range");
  p.fy = r.F(v ? 1.0f : -kBig, v ? 1e5f : kBig, "calibration blob: persp.fy out of range");
  p.cx = r.F(v ? -w : -kBig, v ? 2 * w : kBig, "calibration blob: persp.cx out of range");
  p.cy = r.F(v ? -h : -kBig, v ? 2 * h : kBig, "calibration blob: persp.cy out of range");
  p.skew = r.F(v ? -1e4f : -kBig, v ? 1e4f : kBig, "calibration blob: persp.skew out of range");
  p.k1 = r.F(v ? -100.0f : -kBig, v ? 100.0f : kBig, "calibration blob: persp.k1 out of range");
  p.k2 = r.F(v ? -1000.0f : -kBig, v ? 1000.0f : kBig, "calibration blob: persp.k2 out of range");
  p.rms_px = r.F(v ? 0.0f : -kBig, v ? 1e3f : kBig, "calibration blob: persp.rms_px out of range");
  for (int i = 0; i < 3; ++i)
    for (int c = 0; c < 3; ++c)
      p.R_robot_cam(i, c) = r.F(-1.001f, 1.001f, "calibration blob: persp.R out of range");
  for (int i = 0; i < 3; ++i) {
    p.t_robot_cam(i) = r.F(-100.0f, 100.0f, "calibration blob: persp.t out of range (100 m)");
  }
  if (v && r.status().ok()) {
    const Eigen::Matrix3f e =
        p.R_robot_cam.transpose() * p.R_robot_cam - Eigen::Matrix3f::Identity();
    if (e.cwiseAbs().maxCoeff() > 1e-3f || p.R_robot_cam.determinant() < 0) {
      r.Fail(StatusCode::kInvalidArgument, "calibration blob: persp.R not a rotation");
    }
  }
  if (dst != nullptr) *dst = p;
}

void ReadOmni(CheckedReader& r, OmniCalibration* dst) {
  if (r.U32() != kOmniTag) r.Fail(StatusCode::kDataLoss, "calibration blob: omni tag missing");
  const uint8_t valid = r.U8();
  if (valid > 1) r.Fail(StatusCode::kInvalidArgument, "calibration blob: omni.valid not 0/1");
  const bool v = valid == 1;
  const auto sign = static_cast<int8_t>(r.U8());
  if (sign != 1 && sign != -1) {
    r.Fail(StatusCode::kInvalidArgument, "calibration blob: omni.image_angle_sign not +-1");
  }
  if (r.U16() != OmniCalibration::kDirections || r.U16() != OmniCalibration::kEdges) {
    r.Fail(StatusCode::kInvalidArgument, "calibration blob: omni map is not 45 x 12");
  }
  const float cu = r.F(v ? 0.0f : -kBig, v ? 4096.0f : kBig, "calibration blob: omni.center_u");
  const float cv = r.F(v ? 0.0f : -kBig, v ? 4096.0f : kBig, "calibration blob: omni.center_v");
  const float vz = r.F(v ? 0.01f : -kBig, v ? 10.0f : kBig,
                       "calibration blob: omni.viewpoint_z_m out of range (0.01..10 m)");
  const float off = r.F(-2 * kTwoPi, 2 * kTwoPi, "calibration blob: omni angle offset");
  if (dst != nullptr) {
    dst->valid = v;
    dst->image_angle_sign = sign;
    dst->center_u = cu;
    dst->center_v = cv;
    dst->viewpoint_z_m = vz;
    dst->image_angle_offset_rad = off;
  }
  float prev = 0;
  for (int k = 0; k < OmniCalibration::kEdges; ++k) {
    const float e =
        r.F(v ? prev : -kBig, v ? 100.0f : kBig, "calibration blob: omni.edge_ground_m");
    if (v && !(e > prev)) {
      r.Fail(StatusCode::kInvalidArgument, "calibration blob: omni edges not increasing");
    }
    prev = e;
    if (dst != nullptr) dst->edge_ground_m[k] = e;
  }
  for (int s = 0; s < OmniCalibration::kDirections; ++s) {
    float prev_px = 0;
    for (int k = 0; k < OmniCalibration::kEdges; ++k) {
      const float px = r.F(v ? 0.0f : -kBig, v ? 4096.0f : kBig,
                           "calibration blob: omni.support_px out of range");
      if (v && !(px > prev_px)) {
        r.Fail(StatusCode::kInvalidArgument,
               "calibration blob: omni support vectors not increasing in a sector");
      }
      prev_px = px;
      if (dst != nullptr) dst->support_px[s][k] = px;
    }
  }
  for (int s = 0; s < OmniCalibration::kDirections; ++s) {
    const uint8_t f = r.U8();
    if (f > 1) r.Fail(StatusCode::kInvalidArgument, "calibration blob: unknown omni sector flag");
    if (dst != nullptr) dst->sector_flags[s] = f;
  }
}

void ReadAzimuth(CheckedReader& r, OmniCalibration* dst) {
  if (r.U32() != kAzimuthTag) {
    r.Fail(StatusCode::kDataLoss, "calibration blob: omni azimuth tag missing");
  }
  for (int i = 0; i < 4; ++i) {
    const float h = r.F(-kMaxHarmonicRad, kMaxHarmonicRad,
                        "calibration blob: omni azimuth harmonic out of range (0.1 rad)");
    if (dst != nullptr) dst->azimuth_harmonics_rad[i] = h;
  }
}

// An unknown mask is all zero; a known one is refused when it masks most of the image.
void ReadSelfMask(CheckedReader& r, OmniSelfMask* dst) {
  if (r.U32() != kSelfTag) r.Fail(StatusCode::kDataLoss, "calibration blob: self-mask tag missing");
  OmniSelfMask m;
  const uint8_t known = r.U8();
  if (known > 1) r.Fail(StatusCode::kInvalidArgument, "calibration blob: self-mask flag not 0/1");
  m.known = known == 1;
  m.inner_radius_px = r.F(-kBig, kBig, "calibration blob: self-mask radius not finite");
  m.outer_radius_px = r.F(-kBig, kBig, "calibration blob: self-mask radius not finite");
  m.sector_count = r.U8();
  if (m.sector_count > OmniSelfMask::kMaxSectors) {
    r.Fail(StatusCode::kInvalidArgument, "calibration blob: more than 8 self-mask sectors");
    m.sector_count = 0;
  }
  for (int i = 0; i < m.sector_count; ++i) {
    m.sectors[i].angle_deg = r.F(-kBig, kBig, "calibration blob: self-mask angle not finite");
    m.sectors[i].half_width_deg = r.F(-kBig, kBig, "calibration blob: self-mask width not finite");
  }
  for (uint8_t& b : m.body_px) b = r.U8();
  if (r.status().ok()) {
    const Status valid = ValidateSelfMask(m);
    if (!valid.ok()) r.Fail(StatusCode::kInvalidArgument, valid.message());
  }
  if (dst != nullptr) *dst = m;
}

// Version 1 blobs have no field section: the MSL defaults.
void ReadField(CheckedReader& r, FieldConfig* dst) {
  if (r.U32() != kFieldTag) r.Fail(StatusCode::kDataLoss, "calibration blob: field tag missing");
  FieldConfig f;
  float* v[kFieldFloats];
  FieldFloats(f, v);
  for (float* p : v) *p = r.F(-kBig, kBig, "calibration blob: field value not finite");
  if (r.status().ok()) {
    const Status s = ValidateFieldConfig(f);
    if (!s.ok()) r.Fail(StatusCode::kInvalidArgument, s.message());
  }
  if (dst != nullptr) *dst = f;
}

void ReadRig(CheckedReader& r, RigCalibration* dst, uint16_t version) {
  const uint32_t id = r.U32();
  const uint32_t lut = r.U32();
  const float ball = r.F(0.01f, 1.0f, "calibration blob: ball_radius_m out of range");
  if (dst != nullptr) {
    dst->calibration_id = id;
    dst->lut_id = lut;
    dst->ball_radius_m = ball;
  }
  ReadPersp(r, dst != nullptr ? &dst->persp : nullptr);
  ReadOmni(r, dst != nullptr ? &dst->omni : nullptr);
  if (version >= 2) {
    ReadField(r, dst != nullptr ? &dst->field : nullptr);
  } else if (dst != nullptr) {
    dst->field = FieldConfig{};
  }
  if (version >= 3) {
    ReadAzimuth(r, dst != nullptr ? &dst->omni : nullptr);
  } else if (dst != nullptr) {
    for (float& h : dst->omni.azimuth_harmonics_rad) h = 0.0f;
  }
  if (version >= 4) {
    ReadSelfMask(r, dst != nullptr ? &dst->omni.self_mask : nullptr);
  } else if (dst != nullptr) {
    dst->omni.self_mask = OmniSelfMask{};
  }
  if (r.status().ok() && r.remaining() != 0) {
    r.Fail(StatusCode::kDataLoss, "calibration blob: trailing bytes in payload");
  }
}

}  // namespace

Result<size_t> SerializeCalibration(const RigCalibration& cal, std::span<uint8_t> out) {
  if (out.size() < kBlobHeaderBytes) {
    return Status(StatusCode::kResourceExhausted, "calibration blob: output buffer too small");
  }
  ByteWriter w(out.subspan(kBlobHeaderBytes));
  w.U32(cal.calibration_id);
  w.U32(cal.lut_id);
  w.F32(cal.ball_radius_m);
  WritePersp(w, cal.persp);
  WriteOmni(w, cal.omni);
  WriteField(w, cal.field);
  WriteAzimuth(w, cal.omni);
  WriteSelfMask(w, cal.omni.self_mask);
  if (!w.ok()) {
    return Status(StatusCode::kResourceExhausted, "calibration blob: output buffer too small");
  }
  const size_t payload_len = w.size();
  // Validate what we wrote: never produce a blob the device would reject.
  {
    CheckedReader check(out.subspan(kBlobHeaderBytes, payload_len));
    ReadRig(check, nullptr, kCalibrationBlobVersion);
    BV_TRY(check.status());
  }
  // Header in core/common/blob.h's layout, written after the payload so no copy is needed.
  ByteWriter hw(out.first(kBlobHeaderBytes));
  hw.U32(kBlobMagic);
  hw.U16(static_cast<uint16_t>(BlobKind::kCalibration));
  hw.U16(kCalibrationBlobVersion);
  hw.U32(static_cast<uint32_t>(payload_len));
  hw.U32(Crc32(out.subspan(kBlobHeaderBytes, payload_len)));
  return kBlobHeaderBytes + payload_len;
}

Status ParseCalibration(std::span<const uint8_t> blob, RigCalibration& out) {
  BV_TRY_ASSIGN(const BlobView view,
                ReadBlob(blob, BlobKind::kCalibration, kCalibrationBlobVersion));
  CheckedReader check(view.payload);
  ReadRig(check, nullptr, view.version);
  BV_TRY(check.status());
  CheckedReader store(view.payload);
  ReadRig(store, &out, view.version);
  BV_TRY(store.status());
  PrepareOmniAngles(out.omni);
  return Status::Ok();
}

}  // namespace bv
