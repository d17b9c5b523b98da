#include "core/field/features.h"

#include <algorithm>
#include <cmath>

#include "core/contour/contour.h"

namespace bv {
namespace {

constexpr float kPi = 3.14159265358979f;
constexpr int kEdgeBisections = 4;      // ray spacing / 16 (0.35 deg with 64 rays)
constexpr float kEdgeProbeInsetPx = 3;  // probe this far beyond the foot, inside the obstacle
// Goals: the carpet must end for this many samples (net, back of the goal) ...
constexpr int kGoalTailSamples = 4;
// A robot right behind a line: at most this many samples from the last green to its dark run.
constexpr int kMaxLineFootGap = 6;
// ... between 0.3 and 2 goal depths (+ 0.2 m) behind the last line (the goal line; an oblique
// ray runs longer inside the goal); elsewhere it runs on for the border (1.5 m + in the MSL).
constexpr float kGoalMinDepths = 0.3f, kGoalMaxDepths = 2.0f, kGoalDepthSlackM = 0.2f;
constexpr float kPostMinM = 0.4f;         // a white run off the field this long is a post
constexpr int kCarpetResumes = 8;         // green samples in a row: the carpet went on (not a goal)
constexpr float kGoalStepM = 0.8f;        // neighbouring rays of one goal: goal lines this close
constexpr float kGoalChordSlackM = 0.8f;  // seen mouth at most goal width + this

float WrapPi(float a) { return std::remainder(a, 2.0f * kPi); }

float RayAngle(int ray, int rays) {
  return 2.0f * kPi * static_cast<float>(ray) / static_cast<float>(rays);
}

}  // namespace

void FieldFeatureExtractor::BuildWalk(int stride) {
  FieldFeatureWalk& w = *walk_;
  uint32_t last = 0;
  for (int i = 0; i < OmniFeatureRays::kMaxRays; ++i) {
    uint32_t* const row = w.at + i * FieldFeatureWalk::kRowEntries;
    for (int k = 0; k < FieldFeatureWalk::kRowEntries; ++k) {
      if (i < scan_.features.rays && k < inside_[i]) {
        int u, v;
        OmniRayPixel(rays_[i], radii_q4_[k], u, v);
        last =
            static_cast<uint32_t>(v * stride + (u & ~1) * 2) | (static_cast<uint32_t>(u & 1) << 31);
      }
      row[k] = last;
    }
  }
  for (int k = 0; k < kRayLookAhead; ++k)
    w.at[OmniFeatureRays::kMaxRays * FieldFeatureWalk::kRowEntries + k] = last;
  w.stride = stride;
}

Status FieldFeatureExtractor::Init(const OmniScanConfig& scan, const OmniCalibration& calibration,
                                   const FieldFeatureConfig& config, FieldFeatureWalk& walk) {
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
    // The same direction ScanRay walks (its cs, sn): no trigonometry per line point.
    if (!OmniPrepareGroundDirection(calibration, static_cast<float>(q.cs_q14) * (1.0f / 16384.0f),
                                    static_cast<float>(q.sn_q14) * (1.0f / 16384.0f), ground_[i])
             .ok()) {
      ground_[i] = OmniGroundDirection{};
    }
    angle_[i] = OmniFeatureRayAngle(scan, i);
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
      !(config.obstacle_merge_m > 0.0f) || !(config.hidden_obstacle_radius_m > 0.0f) ||
      !(config.goal_width_m > 0.0f) || !(config.goal_depth_m > 0.0f) || config.min_goal_rays < 1) {
    return Status(StatusCode::kInvalidArgument, "field features: bad configuration");
  }
  scan_ = scan;
  cal_ = &calibration;
  config_ = config;
  walk_ = &walk;
  BuildWalk(2 * kFrameWidth);
  ready_ = true;
  return Status::Ok();
}

bool FieldFeatureExtractor::Ground(float u, float v, float& x, float& y) const {
  return OmniPixelToGround(*cal_, u, v, x, y).ok();
}

bool FieldFeatureExtractor::RayGround(int ray, float r, float cs, float sn, float& x,
                                      float& y) const {
  // The prepared direction holds while the model's centre is the rays' (re-centring moves it).
  if (ground_[ray].sector >= 0 && cal_->center_u == scan_.center_u &&
      cal_->center_v == scan_.center_v) {
    return OmniStepToGround(*cal_, ground_[ray], r, x, y).ok();
  }
  return Ground(scan_.center_u + r * cs, scan_.center_v + r * sn, x, y);
}

float FieldFeatureExtractor::GroundDistance(int ray, float r, float cs, float sn) const {
  float x, y;
  if (!RayGround(ray, r, cs, sn, x, y)) return -1.0f;
  return std::hypot(x, y);
}

void FieldFeatureExtractor::AddLinePoint(float r_in, float r_out, float cs, float sn, int ray,
                                         FieldFeatures& out) {
  float x0, y0, x1, y1;
  if (!RayGround(ray, r_in, cs, sn, x0, y0) || !RayGround(ray, r_out, cs, sn, x1, y1)) {
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
  p.ray = static_cast<uint8_t>(ray);
}

// After a ray's walk (no obstacle on it): where the carpet ended (the first run of off-carpet
// samples it did not resume after). Inside a goal it ends at the back, a goal depth behind the goal
// line; a post is a long white run right off the carpet (vertical: the mirror stretches it
// radially). Elsewhere the carpet runs on for the border.
void FieldFeatureExtractor::GoalEvidence(int ray, const GoalWalk& g, float cs, float sn) {
  if (g.end < 0) return;
  const float end_m = GroundDistance(ray, Mid(g.end, g.end + 1), cs, sn);
  if (!(end_m > 0.0f) || end_m > config_.max_line_range_m) return;
  float goal_m = -1.0f;
  bool post = false;
  if (g.post_w0 >= 0) {
    const float w1 =
        GroundDistance(ray, Mid(g.post_w1, std::min(g.post_w1 + 1, inside_[ray] - 1)), cs, sn);
    if (w1 < 0.0f || w1 - end_m >= kPostMinM) {
      goal_m = end_m;
      post = true;
    }
  }
  const float depth = config_.goal_depth_m;
  const float line_m = !post && g.break_r > 0.0f ? GroundDistance(ray, g.break_r, cs, sn) : -1.0f;
  if (!post && line_m > 0.0f && end_m - line_m >= kGoalMinDepths * depth &&
      end_m - line_m <= kGoalMaxDepths * depth + kGoalDepthSlackM) {
    goal_m = line_m;
  }
  if (goal_m > 0.0f) {
    hits_[ray].goal_cm = static_cast<uint16_t>(std::clamp(goal_m * 100.0f, 1.0f, 65535.0f));
    hits_[ray].post = post;
  }
}

// The carpet has been off for kGoalTailSamples after last_green (the first such run on the ray):
// where a goal's back would be, with the line break before it.
inline void FieldFeatureExtractor::GoalWalk::NoteCarpetEnd(int k, int last_green,
                                                           float break_r_px) {
  if (end < 0 && k - last_green == kGoalTailSamples && last_green >= 0) {
    end = last_green;
    break_r = break_r_px;
  }
}

// The white run [w0, w1] right after the carpet's end is the post's, unless one was noted.
inline void FieldFeatureExtractor::GoalWalk::NotePost(int w0, int w1) {
  if (post_w0 < 0 && w0 >= 0 && w0 - end <= 2) {
    post_w0 = w0;
    post_w1 = w1;
  }
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
  int dark_start = -1, dark_count = 0;
  bool line_foot = false;
  float line_foot_r = -1.0f;  // a dark run right behind a line: foot, unless this ray sees a goal
  int tail_w0 = -1, tail_w1 = -1;  // first white run after the last green sample
  bool tail_closed = false;
  float break_r = -1.0f;  // image radius of the last short break in the carpet (a line)
  GoalWalk goal;
  int green_run = 0;
  const int n = inside_[ray];
  out.lookups += static_cast<uint32_t>(n);
  // Locals: the writes to `out` below may alias anything the compiler cannot see through, so
  // members read in the loop would be reloaded every sample (the hot loop of the feature pass).
  const uint8_t* const data = img.data;
  const uint32_t* const at = walk_->at + ray * FieldFeatureWalk::kRowEntries;
  for (int k = 0; k < n; ++k) {
    if constexpr (kHintRayAhead) {
      // A cold frame: hint the sample kRayLookAhead further out (a hint never faults).
      __builtin_prefetch(data + (at[k + kRayLookAhead] & 0x7fffffffu));
    }
    const uint32_t w = at[k];
    const uint8_t* pair = data + (w & 0x7fffffffu);
    const ColorClass c = lut.Classify(pair[(w >> 31) * 2], pair[1], pair[3]);
    if (c == ColorClass::kField) {
      if (k == last_green + 1) {  // the carpet goes on (most samples): nothing else changes
        last_green = k;
        if (goal.end >= 0 && ++green_run >= kCarpetResumes) goal = GoalWalk{};
        continue;
      }
      if (white_start >= 0 && k - last_white <= 2 && white_start - green_before_white <= 2 &&
          line_foot_r < 0.0f) {
        AddLinePoint(Mid(green_before_white, white_start), Mid(last_white, k), cs, sn, ray, out);
      }
      // A line, or one in shadow (unclassified): 1-3 samples off the carpet between green.
      if (k - last_green >= 2 && k - last_green <= 4 && last_green >= 0)
        break_r = Mid(last_green, k);
      if (goal.end >= 0) {
        goal.NotePost(tail_w0, tail_w1);
        green_run = 1;  // counted on by the fast path above: 8 in a row, the carpet resumed
      }
      white_start = -1;
      tail_w0 = -1;
      tail_closed = false;
      dark_start = -1;
      dark_count = 0;
      last_green = k;
    } else if (c == ColorClass::kLine) {
      goal.NoteCarpetEnd(k, last_green, break_r);
      if (white_start < 0) {
        white_start = k;
        green_before_white = last_green;
      }
      last_white = k;
      dark_start = -1;
      dark_count = 0;
      if (tail_w0 < 0) {
        tail_w0 = tail_w1 = k;
      } else if (!tail_closed && k - tail_w1 <= 2) {
        tail_w1 = k;
      }
    } else if (c == ColorClass::kObstacle) {
      goal.NoteCarpetEnd(k, last_green, break_r);
      if (dark_start < 0) {
        dark_start = k;
        // A dark run right behind a line (green, a few white samples, dark): a robot standing
        // there, or a goal's net behind its line. Kept aside until the ray's goal evidence is in.
        line_foot = white_start >= 0 && white_start - last_green <= 2 && k - last_white <= 2 &&
                    k - last_green <= kMaxLineFootGap && last_green >= 0;
        dark_count = 0;
      }
      white_start = -1;
      if (tail_w0 >= 0 && k - tail_w1 > 2) tail_closed = true;
      ++dark_count;
      if (dark_count < config_.min_obstacle_samples) continue;
      if (line_foot) {
        if (line_foot_r < 0.0f) line_foot_r = Mid(last_white, dark_start);
        continue;
      }
      if (dark_start - last_green <= 2 && last_green >= 0) {
        // The nearest foot on this ray; nothing beyond it is trusted (it hides the floor).
        SetFoot(ray, line_foot_r >= 0.0f ? line_foot_r : Mid(last_green, dark_start), cs, sn);
        return;
      }
    } else {
      goal.NoteCarpetEnd(k, last_green, break_r);
      if (k - last_white > 2 && k - last_green > 2) white_start = -1;  // no line here
      if (tail_w0 >= 0 && k - tail_w1 > 2) tail_closed = true;
    }
  }
  if (goal.end >= 0) goal.NotePost(tail_w0, tail_w1);
  GoalEvidence(ray, goal, cs, sn);
  if (line_foot_r >= 0.0f && hits_[ray].goal_cm == 0) SetFoot(ray, line_foot_r, cs, sn);
}

void FieldFeatureExtractor::HintRay(const uint8_t* data, int ray) const {
  if (Blocked(ray)) return;
  const uint32_t* const at = walk_->at + ray * FieldFeatureWalk::kRowEntries;
  for (int k = 0; k < std::min<int>(inside_[ray], kRayLookAhead); ++k)
    __builtin_prefetch(data + (at[k] & 0x7fffffffu));
}

void FieldFeatureExtractor::SetFoot(int ray, float r, float cs, float sn) {
  float x, y;
  if (RayGround(ray, r, cs, sn, x, y) && std::hypot(x, y) <= config_.max_obstacle_range_m) {
    hits_[ray].foot_r = r;
    hits_[ray].foot_m = std::hypot(x, y);
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

float FieldFeatureExtractor::ClearOf(float a, float b) const {
  const float dir = b >= a ? 1.0f : -1.0f;
  float best = b;
  for (int s = 0; s < scan_.strut_count; ++s) {
    const float c = scan_.struts[s].angle_deg * (kPi / 180.0f);
    const float h = scan_.struts[s].half_width_deg * (kPi / 180.0f);
    // The sector's near edge, seen from a, along the direction of travel.
    const float edge = a + WrapPi(c - dir * h - a);
    if (dir * (edge - a) >= 0.0f && dir * (edge - best) < 0.0f) best = edge;
  }
  return best;
}

float FieldFeatureExtractor::AngleNear(int ray, float near) const {
  return near + WrapPi(angle_[ray] - near);
}

// Bisection between an angle inside the obstacle and one outside: the edge angle.
float FieldFeatureExtractor::RefineEdge(const YuyvImage& img, const ColorLut& lut, float in_angle,
                                        float out_angle, float r, FieldFeatures& out,
                                        bool& hidden) {
  const float clear = ClearOf(in_angle, out_angle);
  hidden = clear != out_angle && DarkAt(img, lut, clear, r, out);
  if (hidden) return clear;
  out_angle = clear;
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
    // The group may bridge a masked ray: its angular span is from first to last, not its count.
    const float a_first = angle_[i0];
    const float a_last = a_first + std::fmod(angle_[last] - a_first + 4.0f * kPi, 2.0f * kPi);
    // An edge behind the robot's own strut cannot be seen (the strut is dark too): that side is
    // taken from a typical obstacle's width when the other side is seen.
    bool lo_hidden = false, hi_hidden = false;
    float lo = RefineEdge(img, lut, a_first, AngleNear((i0 + n - 1) % n, a_first - step), probe_r,
                          out, lo_hidden);
    float hi = RefineEdge(img, lut, a_last, AngleNear((last + 1) % n, a_last + step), probe_r, out,
                          hi_hidden);
    if (lo_hidden != hi_hidden) {
      const float rh = config_.hidden_obstacle_radius_m;
      const float width = 2.0f * std::asin(std::min(1.0f, rh / (foot_m + rh)));
      if (lo_hidden) {
        lo = std::min(lo, hi - width);
      } else {
        hi = std::max(hi, lo + width);
      }
    }
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
  }
}

// Adjacent rays with goal evidence at similar distances (a strut ray or one ray that missed is
// bridged) form one goal, if the mouth they saw is no wider than a goal.
void FieldFeatureExtractor::MergeGoals(FieldFeatures& out) {
  const int n = scan_.features.rays;
  const float step = RayAngle(1, n);
  int start = -1;
  for (int i = 0; i < n && start < 0; ++i) {
    if (hits_[i].goal_cm == 0 && !Blocked(i)) start = i;
  }
  if (start < 0) return;
  const auto dir = [&](int i, float& dx, float& dy) {  // robot-frame unit vector of ray i
    const float r = Mid(inside_[i] / 2, inside_[i] / 2);
    const float a = angle_[i];
    float x, y;
    if (!Ground(scan_.center_u + r * std::cos(a), scan_.center_v + r * std::sin(a), x, y)) {
      return false;
    }
    const float d = std::hypot(x, y);
    if (!(d > 1e-3f)) return false;
    dx = x / d;
    dy = y / d;
    return true;
  };
  for (int off = 1; off <= n; ++off) {
    const int i0 = (start + off) % n;
    if (hits_[i0].goal_cm == 0) continue;
    int first = i0, last = i0, count = 1, posts = hits_[i0].post ? 1 : 0, misses = 0;
    int j = off + 1;
    for (; j <= n; ++j) {
      const int i = (start + j) % n;
      if (hits_[i].goal_cm == 0) {
        if (Blocked(i)) continue;
        if (++misses > 1) break;
        continue;
      }
      if (std::fabs(static_cast<float>(hits_[i].goal_cm) -
                    static_cast<float>(hits_[last].goal_cm)) > kGoalStepM * 100.0f) {
        break;
      }
      misses = 0;
      last = i;
      ++count;
      posts += hits_[i].post ? 1 : 0;
    }
    off = j - 1;
    if (count < config_.min_goal_rays) continue;
    float sx = 0, sy = 0, fx = 0, fy = 0, lx = 0, ly = 0;
    int used = 0;
    bool ok = true;
    for (int i = first; ok; i = (i + 1) % n) {
      if (hits_[i].goal_cm != 0) {
        float dx, dy;
        if (!dir(i, dx, dy)) {
          ok = false;
          break;
        }
        const float d = static_cast<float>(hits_[i].goal_cm) * 0.01f;
        sx += d * dx;
        sy += d * dy;
        if (i == first) {
          fx = dx;
          fy = dy;
        }
        if (i == last) {
          lx = dx;
          ly = dy;
        }
        ++used;
      }
      if (i == last) break;
    }
    if (!ok || used == 0) continue;
    const float df = static_cast<float>(hits_[first].goal_cm) * 0.01f;
    const float dl = static_cast<float>(hits_[last].goal_cm) * 0.01f;
    if (std::hypot(df * fx - dl * lx, df * fy - dl * ly) >
        config_.goal_width_m + kGoalChordSlackM) {
      continue;  // wider than a goal: the hall or the boards, not a goal
    }
    if (out.goal_count >= FieldFeatures::kMaxGoals) {
      ++out.goals_dropped;
      continue;
    }
    const float b0 = std::atan2(fy, fx), span = WrapPi(std::atan2(ly, lx) - b0);
    Goal& g = out.goals[out.goal_count++];
    g.x_m = sx / static_cast<float>(used);
    g.y_m = sy / static_cast<float>(used);
    g.distance_m = std::hypot(g.x_m, g.y_m);
    g.bearing_rad = WrapPi(b0 + 0.5f * span);
    g.half_width_rad = 0.5f * (std::fabs(span) + step);
    g.rays = static_cast<uint8_t>(count);
    g.post_rays = static_cast<uint8_t>(posts);
    g.which = 0;
    g.which_ambiguous = true;
  }
}

Status FieldFeatureExtractor::Extract(const YuyvImage& omni, const ColorLut& lut,
                                      FieldFeatures& out) {
  out.line_count = out.obstacle_count = out.goal_count = 0;
  out.lines_dropped = out.obstacles_dropped = out.obstacles_refused = out.goals_dropped =
      out.goals_refused = 0;
  out.lookups = 0;
  if (!ready_) return Status(StatusCode::kFailedPrecondition, "field features: not initialised");
  if (omni.data == nullptr || omni.width != kFrameWidth || omni.height != kFrameHeight ||
      omni.stride_bytes < 2 * omni.width ||
      static_cast<int64_t>(omni.stride_bytes) * omni.height >= (int64_t{1} << 31)) {
    return Status(StatusCode::kInvalidArgument, "field features: omni frame size or stride wrong");
  }
  if (omni.stride_bytes != walk_->stride) BuildWalk(omni.stride_bytes);
  const int rays = scan_.features.rays;
  if constexpr (kHintRayAhead) HintRay(omni.data, 0);
  for (int i = 0; i < rays; ++i) {
    hits_[i] = RayHit{};
    if constexpr (kHintRayAhead) {
      if (i + 1 < rays) HintRay(omni.data, i + 1);
    }
    if (!Blocked(i)) ScanRay(omni, lut, i, out);
  }
  MergeObstacles(omni, lut, out);
  MergeGoals(out);
  return Status::Ok();
}

}  // namespace bv
