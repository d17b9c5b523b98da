#pragma once
// Field features from the omni camera's feature rays (paper IV-A: "we use the same scanlines to
// detect all other objects of interest"): the rays are part of the omni scan table
// (OmniScanConfig::features), so this reads pixels the ball front end also reads, in radial
// order, through the same LUT classes.
//   line points: a white (kLine) run between green (kField) samples; its centre as a floor point
//                (robot frame), its width along the ray as a check against the line width;
//   obstacles:   the first dark (kObstacle) run that starts on green; foot point = its inner
//                edge; adjacent rays merge into one obstacle whose angular edges are refined by
//                bisection between rays; centre and radius of the footprint from foot distance
//                and angular width.
// Fixed capacities; what does not fit is counted, never dropped silently.
#include <cstdint>

#include "core/calibration/calibration.h"
#include "core/color_lut/color_lut.h"
#include "core/common/image.h"
#include "core/common/status.h"
#include "core/scanline/scanline.h"

namespace bv {

struct LinePoint {
  float x_m = 0, y_m = 0;  // robot frame, floor
  uint8_t ray = 0;         // feature ray index (neighbourhood for the heading estimate)
};

// Centre and radius only (foot distance and angular width, derivable and never read, went for
// RAM: 192 B).
struct Obstacle {
  float x_m = 0, y_m = 0;  // footprint centre, robot frame
  float radius_m = 0;      // footprint radius
};

/// A goal seen from the field: the mouth (goal line between the posts) as far as the rays saw it.
struct Goal {
  float x_m = 0, y_m = 0;    // centre of the seen part of the mouth, robot frame
  float distance_m = 0;      // hypot(x, y)
  float bearing_rad = 0;     // robot frame, CCW from +x: middle of the angular range
  float half_width_rad = 0;  // the range is bearing +- half_width (edges: half a ray beyond)
  uint8_t rays = 0;          // rays that saw it
  uint8_t post_rays = 0;     // of those, rays that hit a post (a long white run off the field)
  int8_t which = 0;  // from the pose (pipeline): +1 the goal at field +X, -1 at -X, 0 unknown
  bool which_ambiguous = true;  // the pose is ambiguous: `which` may be the other goal
};

struct FieldFeatureConfig {
  float line_width_m = 0.125f;
  float min_width_factor = 0.3f;  // white run length along the ray: [0.3, 4] x line width
  float max_width_factor = 4.0f;
  float max_line_range_m = 6.0f;      // farther line points are too coarse to be useful
  float max_obstacle_range_m = 6.0f;  // foot points beyond are not reported
  int min_obstacle_samples = 3;       // dark samples in a row before it counts
  float obstacle_merge_m = 0.6f;      // adjacent-ray feet closer than this: one obstacle
  // An obstacle that runs into the robot's own mask (a strut) on one side is at least this wide
  // there: MSL robots stand on up to 52 x 52 cm.
  float hidden_obstacle_radius_m = 0.25f;
  // Goals (the pipeline copies them from the calibration's field): the carpet ends at the back
  // of the goal, goal_depth behind the goal line, where elsewhere it runs on past the lines.
  float goal_width_m = 2.0f;
  float goal_depth_m = 0.6f;
  int min_goal_rays = 2;  // a goal seen on fewer rays is not reported
};

struct FieldFeatures {
  static constexpr int kMaxLinePoints = 96;  // 35-51 seen per frame with 64 rays
  static constexpr int kMaxObstacles = 16;
  LinePoint lines[kMaxLinePoints];
  int line_count = 0;
  uint32_t lines_dropped = 0;  // found but over capacity (counted, not kept)
  Obstacle obstacles[kMaxObstacles];
  int obstacle_count = 0;
  uint32_t obstacles_dropped = 0;
  uint32_t obstacles_refused = 0;  // removed by the pipeline: off the field by the pose
  static constexpr int kMaxGoals = 2;
  Goal goals[kMaxGoals];
  int goal_count = 0;
  uint32_t goals_dropped = 0;  // over capacity
  uint32_t goals_refused = 0;  // removed by the pipeline: where the pose puts no goal, or on
                               // fewer than 3 rays while there is no pose to check them
  uint32_t lookups = 0;        // LUT lookups of this pass (the pixels are the scan table's)
};

/// Samples the feature walk hints ahead of the one it reads (a cold frame, one ray at a time).
/// Hosts only: the device's budget is counted in instructions (DESIGN section 5), and the hint's
/// gain there is not measured (core/field/README.md).
inline constexpr int kRayLookAhead = 12;
#if defined(__arm__)
inline constexpr bool kHintRayAhead = false;
#else
inline constexpr bool kHintRayAhead = true;
#endif

/// The feature rays' pixels as frame byte offsets, ray by ray, for one frame stride: built by the
/// extractor once per calibration (and again should the stride change), then only read, so the
/// firmware keeps it in external RAM with the scan tables (PipelineTables, 48 KB). The walk reads
/// an offset where it computed a position: ~10 instructions a sample fewer on the M7.
struct FieldFeatureWalk {
  static constexpr int kRowEntries = OmniFeatureRays::kMaxRadii;
  // Ray i's samples at [i * kRowEntries ...]: the pixel pair's offset, bit 31 set for the pair's
  // second pixel; past a ray's last sample in the frame, its last. Padded for the look-ahead.
  uint32_t at[OmniFeatureRays::kMaxRays * kRowEntries + kRayLookAhead] = {};
  int stride = 0;  // the frame stride the offsets are for
};

class FieldFeatureExtractor {
 public:
  /// `scan` must be the OmniScanConfig the omni scan table was built from (features.rays > 0);
  /// `calibration` and `walk` must outlive the extractor (`walk` is its alone).
  /// Errors: kInvalidArgument (no feature rays or bad ray set), kFailedPrecondition (omni
  /// calibration not valid).
  Status Init(const OmniScanConfig& scan, const OmniCalibration& calibration,
              const FieldFeatureConfig& config, FieldFeatureWalk& walk);
  bool ready() const { return ready_; }
  /// Extracts line points and obstacles. Errors: kFailedPrecondition (not initialised),
  /// kInvalidArgument (image size differs from the calibration's frame size / null data).
  Status Extract(const YuyvImage& omni, const ColorLut& lut, FieldFeatures& out);
  int rays() const { return scan_.features.rays; }
  int radii() const { return n_radii_; }

 private:
  struct RayHit {
    float foot_r = -1;  // image radius of the obstacle foot, < 0: none on this ray
    float foot_m = 0;
    // Goal evidence: the goal line's ground distance on this ray (cm, 0: none) and whether the
    // ray hit a post.
    uint16_t goal_cm = 0;
    bool post = false;
  };
  void ScanRay(const YuyvImage& img, const ColorLut& lut, int ray, FieldFeatures& out);
  void AddLinePoint(float r_in, float r_out, float cs, float sn, int ray, FieldFeatures& out);
  // Hosts: hints the first kRayLookAhead samples of `ray` (its walk hints the rest as it goes).
  void HintRay(const uint8_t* data, int ray) const;
  // Foot point of an obstacle at image radius r on this ray (within the obstacle range).
  void SetFoot(int ray, float r, float cs, float sn);
  struct GoalWalk {                  // one ray's goal evidence (ScanRay)
    int end = -1;                    // last carpet sample before the first run off it that lasted
    float break_r = -1;              // image radius of the last short break (a line) before it
    int post_w0 = -1, post_w1 = -1;  // white run right after it
    void NoteCarpetEnd(int k, int last_green, float break_r_px);
    void NotePost(int w0, int w1);  // call with end >= 0
  };
  void GoalEvidence(int ray, const GoalWalk& g, float cs, float sn);
  void MergeGoals(FieldFeatures& out);
  float GroundDistance(int ray, float r, float cs, float sn) const;
  void MergeObstacles(const YuyvImage& img, const ColorLut& lut, FieldFeatures& out);
  bool DarkAt(const YuyvImage& img, const ColorLut& lut, float angle, float r, FieldFeatures& out);
  void Pixel(float angle, float r, int& u, int& v) const;
  // The edge angle between in_angle (dark) and out_angle; `hidden` when a mask sector in between
  // stops the search still dark (the edge lies behind the robot's own strut).
  float RefineEdge(const YuyvImage& img, const ColorLut& lut, float in_angle, float out_angle,
                   float r, FieldFeatures& out, bool& hidden);
  // The first mask sector edge met going from angle a to b (radians, |b - a| < pi), else b.
  float ClearOf(float a, float b) const;
  // Ray i's angle unwrapped to lie within pi of `near`.
  float AngleNear(int ray, float near) const;
  bool Ground(float u, float v, float& x, float& y) const;
  // Ground of the pixel at image radius r on ray `ray` (direction cs, sn): its prepared direction
  // while the model's centre is the rays', else Ground.
  bool RayGround(int ray, float r, float cs, float sn, float& x, float& y) const;

  OmniScanConfig scan_;
  const OmniCalibration* cal_ = nullptr;
  FieldFeatureConfig config_;
  bool ready_ = false;
  int32_t radii_q4_[OmniFeatureRays::kMaxRadii] = {};
  FieldFeatureWalk* walk_ = nullptr;
  void BuildWalk(int stride);
  uint8_t inside_[OmniFeatureRays::kMaxRays] = {};  // leading samples of each ray in the frame
  OmniRayQ rays_[OmniFeatureRays::kMaxRays] = {};
  OmniGroundDirection ground_[OmniFeatureRays::kMaxRays] = {};  // each ray's map terms (RayGround)
  float angle_[OmniFeatureRays::kMaxRays] = {};  // each ray's image angle (OmniFeatureRayAngle)
  uint64_t blocked_ = 0;                         // rays that cannot be moved out of a mask sector
  static_assert(OmniFeatureRays::kMaxRays <= 64);
  bool Blocked(int ray) const { return (blocked_ >> ray) & 1u; }
  // Radius (px) halfway between samples a and b.
  float Mid(int a, int b) const {
    return static_cast<float>(radii_q4_[a] + radii_q4_[b]) * (1.0f / 32.0f);
  }
  int n_radii_ = 0;
  RayHit hits_[OmniFeatureRays::kMaxRays] = {};
};

}  // namespace bv
