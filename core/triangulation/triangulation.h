#pragma once
// 3D ball centre from the viewing rays of the two cameras (the paper's eq. (2)) and the
// single-camera fallbacks. Pure geometry, float, allocation-free.
#include <Eigen/Core>

#include "core/calibration/calibration.h"
#include "core/common/status.h"

namespace bv {

struct TriangulationConfig {
  // Rays whose angle is below this are treated as parallel (the midpoint would be unstable).
  float min_ray_angle_rad = 0.0035f;  // ~0.2 degrees
  // The ball must lie in front of both cameras; a small negative tolerance absorbs noise.
  float min_depth_m = -0.05f;
};

struct Triangulation {
  Eigen::Vector3f point = Eigen::Vector3f::Zero();  // midpoint of the common perpendicular
  float gap_m = 0;          // closest-approach distance of the two rays (quality)
  float depth_persp_m = 0;  // ray parameter along the perspective ray (dir is unit)
  float depth_omni_m = 0;   // ray parameter along the omni ray
};

/// Paper eq. (2): c_S = (f_P + s r_P + f_O + t r_O) / 2 with (s, t) minimising |f_P + s r_P -
/// f_O - t r_O|. Errors: kInvalidArgument (NaN/zero direction), kOutOfRange (rays parallel
/// within min_ray_angle_rad: one far object, or two), kNotFound (the closest point lies behind a
/// camera: the rays diverge, two objects).
Result<Triangulation> TriangulateRays(const Ray& persp, const Ray& omni,
                                      const TriangulationConfig& config = {});

/// Omni only: the ball is assumed on the floor, centre at z = ball_radius_m: the omni viewing
/// ray (from the mirror viewpoint) intersected with that plane. Also used with another plane
/// height (e.g. a predicted height). kOutOfRange if the ray does not descend to the plane.
Result<Eigen::Vector3f> IntersectRayWithPlaneZ(const Ray& ray, float plane_z_m);

/// Perspective only: distance from the apparent size. `angular_radius_rad` is the half angle the
/// ball subtends (angle between the centre ray and a ray through its rim); the centre lies at
/// ball_radius_m / sin(angular_radius_rad) along the ray. kOutOfRange for angles outside
/// (0, 80 deg), kInvalidArgument for NaN.
Result<Eigen::Vector3f> PointFromApparentSize(const Ray& ray, float angular_radius_rad,
                                              float ball_radius_m);

/// Distance along `ray` of the point on it closest to `p` (may be negative).
float ClosestDepthOnRay(const Ray& ray, const Eigen::Vector3f& p);

}  // namespace bv
