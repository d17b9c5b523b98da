#include "core/triangulation/triangulation.h"

#include <cmath>

namespace bv {
namespace {

bool Finite(const Eigen::Vector3f& v) {
  return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z());
}

}  // namespace

Result<Triangulation> TriangulateRays(const Ray& persp, const Ray& omni,
                                      const TriangulationConfig& config) {
  if (!Finite(persp.origin) || !Finite(persp.dir) || !Finite(omni.origin) || !Finite(omni.dir)) {
    return Status(StatusCode::kInvalidArgument, "triangulation: ray with NaN/inf component");
  }
  const Eigen::Vector3f& r_p = persp.dir;
  const Eigen::Vector3f& r_o = omni.dir;
  const Eigen::Vector3f d = persp.origin - omni.origin;  // the paper's d = f_P - f_O
  const float pp = r_p.dot(r_p);
  const float oo = r_o.dot(r_o);
  const float po = r_p.dot(r_o);
  if (pp < 1e-12f || oo < 1e-12f) {
    return Status(StatusCode::kInvalidArgument, "triangulation: zero-length ray direction");
  }
  const float denom = pp * oo - po * po;  // = |r_p|^2 |r_o|^2 sin^2(angle)
  const float sin_min = std::sin(config.min_ray_angle_rad);
  if (!(denom > pp * oo * sin_min * sin_min)) {
    return Status(StatusCode::kOutOfRange, "triangulation: rays nearly parallel");
  }
  const float od = r_o.dot(d);
  const float pd = r_p.dot(d);
  // Eq. (2): coefficients of r_P and r_O, measured from f_P and f_O respectively.
  const float s = (po * od - oo * pd) / denom;
  const float t = (pp * od - po * pd) / denom;
  Triangulation out;
  const Eigen::Vector3f on_p = persp.origin + s * r_p;
  const Eigen::Vector3f on_o = omni.origin + t * r_o;
  out.point = 0.5f * (on_p + on_o);
  out.gap_m = (on_p - on_o).norm();
  out.depth_persp_m = s * std::sqrt(pp);
  out.depth_omni_m = t * std::sqrt(oo);
  if (out.depth_persp_m < config.min_depth_m || out.depth_omni_m < config.min_depth_m) {
    return Status(StatusCode::kNotFound, "triangulation: the rays meet behind a camera");
  }
  if (!Finite(out.point) || !std::isfinite(out.gap_m)) {
    return Status(StatusCode::kInternal, "triangulation: non-finite result");
  }
  return out;
}

Result<Eigen::Vector3f> IntersectRayWithPlaneZ(const Ray& ray, float plane_z_m) {
  if (!Finite(ray.origin) || !Finite(ray.dir) || !std::isfinite(plane_z_m)) {
    return Status(StatusCode::kInvalidArgument, "plane intersection: NaN input");
  }
  const float dz = plane_z_m - ray.origin.z();
  // The ray must head towards the plane at a usable angle (not grazing, not away from it).
  if (!(ray.dir.z() * dz > 0.f) || std::fabs(ray.dir.z()) < 1e-4f * ray.dir.norm()) {
    return Status(StatusCode::kOutOfRange, "plane intersection: ray does not reach the plane");
  }
  const float t = dz / ray.dir.z();
  if (t > 1000.f) {
    return Status(StatusCode::kOutOfRange, "plane intersection: beyond 1 km");
  }
  return Eigen::Vector3f(ray.origin + t * ray.dir);
}

Result<Eigen::Vector3f> PointFromApparentSize(const Ray& ray, float angular_radius_rad,
                                              float ball_radius_m) {
  if (!Finite(ray.origin) || !Finite(ray.dir) || !std::isfinite(angular_radius_rad) ||
      !std::isfinite(ball_radius_m)) {
    return Status(StatusCode::kInvalidArgument, "apparent size: NaN input");
  }
  const float n = ray.dir.norm();
  if (n < 1e-6f) return Status(StatusCode::kInvalidArgument, "apparent size: zero direction");
  if (!(angular_radius_rad > 1e-5f && angular_radius_rad < 1.396f) || !(ball_radius_m > 0.f)) {
    return Status(StatusCode::kOutOfRange, "apparent size: angular radius out of (0, 80 deg)");
  }
  const float range_m = ball_radius_m / std::sin(angular_radius_rad);
  return Eigen::Vector3f(ray.origin + (range_m / n) * ray.dir);
}

float ClosestDepthOnRay(const Ray& ray, const Eigen::Vector3f& p) {
  const float n2 = ray.dir.squaredNorm();
  if (!(n2 > 0.f)) return 0.f;
  return (p - ray.origin).dot(ray.dir) / std::sqrt(n2);
}

}  // namespace bv
