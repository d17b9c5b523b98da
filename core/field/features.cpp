#include "core/field/features.h"

#include <algorithm>
#include <cmath>

#include "core/contour/contour.h"

namespace bv {
namespace {

constexpr float kPi = 3.14159265358979f;
constexpr int kEdgeBisections = 4;      // ray spacing / 16 (0.35 deg with 64 rays)
constexpr float kEdgeProbeInsetPx = 3;  // probe this far beyond the foot, inside the obstacle

float RayAngle(int ray, int rays) {
  return 2.0f * kPi * static_cast<float>(ray) / static_cast<float>(rays);
}

}  // namespace

Status FieldFeatureExtractor::Init(const OmniScanConfig& scan, const OmniCalibration& calibration,
                                   const FieldFeatureConfig& config) {
  ready_ = false;
  if (!calibration.valid) {
    return Status(StatusCode::kFailedPrecondition, "field features: omni calibration not valid");
  }
  if (scan.features.rays <= 0) {
    return Status(StatusCode::kInvalidArgument, "field features: the scan table has no rays");
  }
  float radii[OmniFeatureRays::kMaxRadii];  // start-up only; Q4 copies are kept
  n_radii_ = OmniFeatureRadii(scan, radii, OmniFeatureRays::kMaxRadii);
  if (n_radii_ <= 1) {
    return Status(StatusCode::kInvalidArgument, "field features: bad feature ray set");
  }
  for (int k = 0; k < n_radii_; ++k) radii_q4_[k] = RadiusQ4(radii[k]);
  static_assert(OmniFeatureRays::kMaxRadii <= 255);
  blocked_ = 0;
  for (int i = 0; i < scan.features.rays; ++i) {
    const OmniRayQ q = MakeOmniRay(scan, i);
    rays_[i] = q;
    if (OmniFeatureRayBlocked(scan, i)) blocked_ |= uint64_t{1} << i;
    int k = 0;
    for (; k < n_radii_; ++k) {
      int u, v;
      OmniRayPixel(q, radii_q4_[k], u, v);
      if (u < 0 || v < 0 || u >= kFrameWidth || v >= kFrameHeight) break;
    }
    inside_[i] = static_cast<uint8_t>(k);
  }
  if (!(config.line_width_m > 0.0f) || !(config.min_width_factor > 0.0f) ||
      !(config.max_width_factor > config.min_width_factor) || config.min_obstacle_samples < 1 ||
      !(config.max_line_range_m > 0.0f) || !(config.max_obstacle_range_m > 0.0f) ||
      !(config.obstacle_merge_m > 0.0f)) {
    return Status(StatusCode::kInvalidArgument, "field features: bad configuration");
  }
  scan_ = scan;
  cal_ = &calibration;
  config_ = config;
  ready_ = true;
  return Status::Ok();
}

bool FieldFeatureExtractor::Ground(float u, float v, float& x, float& y) const {
  return OmniPixelToGround(*cal_, u, v, x, y).ok();
}

void FieldFeatureExtractor::AddLinePoint(float r_in, float r_out, float cs, float sn, int ray,
                                         FieldFeatures& out) {
  float x0, y0, x1, y1;
  const float cu = scan_.center_u, cv = scan_.center_v;
  if (!Ground(cu + r_in * cs, cv + r_in * sn, x0, y0) ||
      !Ground(cu + r_out * cs, cv + r_out * sn, x1, y1)) {
    return;
  }
  const float width = std::hypot(x1 - x0, y1 - y0);
  const float x = 0.5f * (x0 + x1), y = 0.5f * (y0 + y1);
  if (width < config_.min_width_factor * config_.line_width_m ||
      width > config_.max_width_factor * config_.line_width_m ||
      std::hypot(x, y) > config_.max_line_range_m) {
    return;
  }
  if (out.line_count >= FieldFeatures::kMaxLinePoints) {
    ++out.lines_dropped;
    return;
  }
  LinePoint& p = out.lines[out.line_count++];
  p.x_m = x;
  p.y_m = y;
  p.width_m = width;
  p.ray = static_cast<uint8_t>(ray);
}

// One ray, inside out. A white run counts when green lies on both sides (at most one unclassified
// sample between, the blend of an edge); the first dark run that starts on green is an obstacle,
// and nothing beyond it on this ray is trusted (it hides the floor).
void FieldFeatureExtractor::ScanRay(const YuyvImage& img, const ColorLut& lut, int ray,
                                    FieldFeatures& out) {
  const OmniRayQ& q = rays_[ray];
  const float cs = static_cast<float>(q.cs_q14) * (1.0f / 16384.0f);  // no trigonometry per frame
  const float sn = static_cast<float>(q.sn_q14) * (1.0f / 16384.0f);
  int last_green = -10, white_start = -1, last_white = -10, green_before_white = -10;
  int dark_start = -1, dark_count = 0, green_before_dark = -10;
  const int n = inside_[ray];
  out.lookups += static_cast<uint32_t>(n);
  for (int k = 0; k < n; ++k) {
    int u, v;
    OmniRayPixel(q, radii_q4_[k], u, v);
    // Inside the frame by construction (inside_), so no bounds test in this loop.
    const uint8_t* pair = img.data + v * img.stride_bytes + (u & ~1) * 2;
    const ColorClass c = lut.Classify(pair[(u & 1) * 2], pair[1], pair[3]);
    if (c == ColorClass::kField) {
      if (white_start >= 0 && k - last_white <= 2 && white_start - green_before_white <= 2) {
        AddLinePoint(Mid(green_before_white, white_start), Mid(last_white, k), cs, sn, ray, out);
      }
      white_start = -1;
      dark_start = -1;
      dark_count = 0;
      last_green = k;
    } else if (c == ColorClass::kLine) {
      if (white_start < 0) {
        white_start = k;
        green_before_white = last_green;
      }
      last_white = k;
      dark_start = -1;
      dark_count = 0;
    } else if (c == ColorClass::kObstacle) {
      white_start = -1;
      if (dark_start < 0) {
        dark_start = k;
        green_before_dark = last_green;
        dark_count = 0;
      }
      ++dark_count;
      if (dark_count >= config_.min_obstacle_samples && dark_start - green_before_dark <= 2 &&
          green_before_dark >= 0) {
        const float r = Mid(green_before_dark, dark_start);
        float x, y;
        if (Ground(scan_.center_u + r * cs, scan_.center_v + r * sn, x, y) &&
            std::hypot(x, y) <= config_.max_obstacle_range_m) {
          hits_[ray].foot_r = r;
          hits_[ray].foot_m = std::hypot(x, y);
        }
        return;
      }
    } else if (k - last_white > 2 && k - last_green > 2) {
      white_start = -1;  // a long unclassified gap: no line here
    }
  }
}

// Between rays (edge bisection): the same rounding as a ray's samples.
void FieldFeatureExtractor::Pixel(float angle, float r, int& u, int& v) const {
  u = static_cast<int>(std::floor(scan_.center_u + 0.5f + r * std::cos(angle)));
  v = static_cast<int>(std::floor(scan_.center_v + 0.5f + r * std::sin(angle)));
}

bool FieldFeatureExtractor::DarkAt(const YuyvImage& img, const ColorLut& lut, float angle, float r,
                                   FieldFeatures& out) {
  int u, v;
  Pixel(angle, r, u, v);
  ++out.lookups;
  return ClassAt(img, lut, u, v) == ColorClass::kObstacle;
}

// Bisection between an angle inside the obstacle and one outside: the edge angle.
float FieldFeatureExtractor::RefineEdge(const YuyvImage& img, const ColorLut& lut, float in_angle,
                                        float out_angle, float r, FieldFeatures& out) {
  for (int i = 0; i < kEdgeBisections; ++i) {
    const float mid = 0.5f * (in_angle + out_angle);
    if (DarkAt(img, lut, mid, r, out)) {
      in_angle = mid;
    } else {
      out_angle = mid;
    }
  }
  return 0.5f * (in_angle + out_angle);
}

void FieldFeatureExtractor::MergeObstacles(const YuyvImage& img, const ColorLut& lut,
                                           FieldFeatures& out) {
  const int n = scan_.features.rays;
  const float step = RayAngle(1, n);
  int start = -1;  // a ray with no hit, so no group wraps around it
  for (int i = 0; i < n && start < 0; ++i) {
    if (hits_[i].foot_r < 0 && !Blocked(i)) start = i;
  }
  if (start < 0) return;  // surrounded: no free ray to tell obstacles apart
  for (int off = 1; off <= n; ++off) {
    const int i0 = (start + off) % n;
    if (hits_[i0].foot_r < 0) continue;
    // Grow the group over rays with a hit at a similar distance (a strut ray is bridged).
    int last = i0, count = 1;
    float foot_r = hits_[i0].foot_r, foot_m = hits_[i0].foot_m;
    int j = off + 1;
    for (; j <= n; ++j) {
      const int i = (start + j) % n;
      if (Blocked(i) && hits_[i].foot_r < 0) continue;
      if (hits_[i].foot_r < 0 ||
          std::fabs(hits_[i].foot_m - hits_[last].foot_m) > config_.obstacle_merge_m) {
        break;
      }
      last = i;
      ++count;
      if (hits_[i].foot_m < foot_m) {
        foot_m = hits_[i].foot_m;
        foot_r = hits_[i].foot_r;
      }
    }
    off = j - 1;
    const float probe_r = foot_r + kEdgeProbeInsetPx;
    const float a_first = RayAngle(i0, n), a_last = a_first + step * static_cast<float>(count - 1);
    const float lo = RefineEdge(img, lut, a_first, a_first - step, probe_r, out);
    const float hi = RefineEdge(img, lut, a_last, a_last + step, probe_r, out);
    const float mid = 0.5f * (lo + hi), half = 0.5f * (hi - lo);
    float x, y;
    if (!Ground(scan_.center_u + foot_r * std::cos(mid), scan_.center_v + foot_r * std::sin(mid), x,
                y)) {
      continue;
    }
    const float d = std::hypot(x, y);
    if (!(d > 0.05f)) continue;
    const float s = std::sin(std::min(half, 1.2f));
    const float radius = std::clamp(foot_m * s / std::max(1e-3f, 1.0f - s), 0.05f, 1.0f);
    if (out.obstacle_count >= FieldFeatures::kMaxObstacles) {
      ++out.obstacles_dropped;
      continue;
    }
    Obstacle& o = out.obstacles[out.obstacle_count++];
    o.x_m = x * (d + radius) / d;
    o.y_m = y * (d + radius) / d;
    o.radius_m = radius;
    o.foot_m = foot_m;
    o.bearing_rad = std::atan2(y, x);
    o.half_width_rad = half;
  }
}

Status FieldFeatureExtractor::Extract(const YuyvImage& omni, const ColorLut& lut,
                                      FieldFeatures& out) {
  out.line_count = out.obstacle_count = 0;
  out.lines_dropped = out.obstacles_dropped = 0;
  out.lookups = 0;
  if (!ready_) return Status(StatusCode::kFailedPrecondition, "field features: not initialised");
  if (omni.data == nullptr || omni.width != kFrameWidth || omni.height != kFrameHeight ||
      omni.stride_bytes < 2 * omni.width) {
    return Status(StatusCode::kInvalidArgument, "field features: omni frame size or stride wrong");
  }
  for (int i = 0; i < scan_.features.rays; ++i) {
    hits_[i] = RayHit{};
    if (!Blocked(i)) ScanRay(omni, lut, i, out);
  }
  MergeObstacles(omni, lut, out);
  return Status::Ok();
}

}  // namespace bv
