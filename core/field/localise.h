#pragma once
// Self-localisation from line points (Lauer, Lange, Riedmiller 2006): the pose minimises
// sum_i rho(d_i), d_i the distance of observed line point i (mapped into the field by the pose)
// to the nearest line, rho(d) = 1 - c^2 / (c^2 + d^2) (robust: far points stop pulling).
// Solved by iteratively reweighted Gauss-Newton on (x, y, heading), a few iterations a frame.
//   tracking:  from the previous pose (moved by odometry when the main computer sends it);
//   global:    from an unknown start or after a kidnap: the heading modulo 90 deg comes from the
//              directions of the observed lines (field lines are axis-parallel), then a coarse
//              position grid for the two headings that remain (the field is point-symmetric),
//              spread over several frames (a bounded number of evaluations each), and the best
//              candidates refined;
//   symmetry:  (x, y, h) and (-x, -y, h + pi) fit equally; which one is reported is kept from
//              frame to frame, and the packet says "ambiguous" until a hint (a pose or a half from
//              the main computer) has chosen. The in-field test is the same for both.
// The covariance comes from the Gauss-Newton normal matrix and the residual scatter, and grows
// while no lines are seen; past a limit the pose is unusable and the in-field rule switches off.
#include <cstdint>

#include "core/common/status.h"
#include "core/field/features.h"
#include "core/field/field_model.h"

namespace bv {

struct LocaliserConfig {
  float c_m = 0.25f;                   // error function scale (the paper's 250 mm)
  int track_iterations = 6;            // Gauss-Newton steps per frame while tracking
  int min_points = 8;                  // fewer line points: no update (coast)
  float inlier_m = 0.2f;               // a point this close to a line is an inlier
  float good_inlier_ratio = 0.5f;      // tracking: a fit this good keeps the pose
  float global_inlier_ratio = 0.75f;   // a global search result must fit this well
  int lost_after_bad_frames = 20;      // bad fits in a row: relocalise globally
  int evals_per_frame = 250;           // global search: at most this many poses per frame ...
  int search_points_per_frame = 2000;  // ... and this many line points scored (~125 instr each;
                                       // 3000 put a search frame over 1.5 M a pair)
  float grid_m = 1.0f;                 // global search position grid
  float coast_pos_mps = 0.5f;          // sigma growth while coasting without odometry
  float coast_heading_radps = 0.2f;
  float usable_sigma_m = 0.5f;      // beyond: pose not used for the in-field rule
  float max_fit_sigma_m = 0.15f;    // a fit less certain than this (lines in one direction) or
  float max_fit_sigma_rad = 0.05f;  // ... does not update the pose
};

/// Pose estimate. Field frame (core/field/field_model.h); heading = field angle of robot +y.
struct PoseEstimate {
  enum State : uint8_t { kUnknown = 0, kSearching = 1, kTracking = 2, kCoasting = 3 };
  State state = kUnknown;
  float x_m = 0, y_m = 0, heading_rad = 0;
  float sigma_x_m = 0, sigma_y_m = 0, sigma_heading_rad = 0;
  float quality = 0;           // 0..1: inlier ratio x min(1, inliers / 20)
  bool ambiguous = true;       // the point-symmetric twin fits as well and no hint chose
  bool hint_rejected = false;  // last hint contradicted the observations
  uint16_t points_used = 0;
  uint16_t inliers = 0;
  uint32_t evaluations = 0;  // pose evaluations this frame (cost)
  bool usable() const { return (state == kTracking || state == kCoasting) && sigma_x_m > 0; }
};

/// Hint from the main computer: a pose (seeds tracking when it fits) and/or which half
/// (sign of field x of the robot: +1, -1, 0 = none) to resolve the symmetry.
struct PoseHint {
  bool has_pose = false;
  float x_m = 0, y_m = 0, heading_rad = 0;
  int8_t half = 0;
};

class Localiser {
 public:
  static constexpr int kMaxCandidates = 12;

  /// Errors: kFailedPrecondition if `field` is not ready, kInvalidArgument for a bad config.
  Status Init(const FieldModel* field, const LocaliserConfig& config);
  /// One frame's line points (robot frame). `odometry` (robot motion since the previous frame,
  /// robot frame of the previous pose: dx, dy, dheading) may be null.
  void Update(const FieldFeatures& features, uint64_t t_us, const float* odometry);
  /// Applies a hint; the pose in it is checked against the next frame's line points.
  Status SetHint(const PoseHint& hint);
  void Reset();
  const PoseEstimate& pose() const { return pose_; }

  // Exposed for tests: error of a pose over the last frame's points, and one refinement.
  float Score(const FieldFeatures& f, float x, float y, float h, int max_points) const;

 private:
  // `give_up`: stop once the mean cannot stay below it (the global search's pruning); `scored`
  // (if given) counts the points scored.
  float Score(const FieldFeatures& f, float x, float y, float s, float co, int stride, int points,
              float give_up, int* scored = nullptr) const;
  static int FinitePoints(const FieldFeatures& f, int stride);

  struct Candidate {
    float x, y, h, score;
  };
  struct FitResult {
    float x, y, h;
    int inliers, used;
    float h00, h11, h22, s2;
  };
  FitResult Refine(const FieldFeatures& f, float x, float y, float h, int iterations, float c,
                   int stride = 1, bool covariance = true) const;
  bool EstimateHeading(const FieldFeatures& f, float& h0) const;
  void StartSearch(const FieldFeatures& f);
  void Keep(const Candidate& c);
  static bool SamePose(const FitResult& a, const FitResult& b);
  bool Constrained(const FitResult& r) const;
  void ContinueSearch(const FieldFeatures& f);
  void Accept(const FitResult& r);
  void Coast(uint64_t t_us);
  void ApplyHalf();

  const FieldModel* field_ = nullptr;
  LocaliserConfig config_;
  PoseEstimate pose_;
  PoseHint hint_;
  bool hint_pending_ = false;
  uint64_t last_t_us_ = 0;
  int bad_frames_ = 0;
  // Global search state.
  bool searching_ = false;
  float search_h_[2] = {};
  int search_next_ = 0, search_total_ = 0, search_nx_ = 0, search_ny_ = 0;
  Candidate best_[kMaxCandidates] = {};  // after refinement: the refined pose, score = inlier ratio
  int best_count_ = 0;
  int refine_next_ = 0;
  uint8_t refined_inliers_[kMaxCandidates] = {};
};

}  // namespace bv
