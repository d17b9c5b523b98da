#pragma once
// The stage order, written once: LUT on scanlines + attention -> regions -> ball choice ->
// rays -> triangulation (or a one-camera fallback) -> ball filter -> BallState. The filter's
// prediction is projected back into both images for the next frame's attention and ball
// choice. Statically sized; Process() never allocates.
#include <cstdint>

#include "core/ball_check/ball_check.h"
#include "core/ball_filter/ball_filter.h"
#include "core/ball_filter/candidate_tracks.h"
#include "core/calibration/calibration.h"
#include "core/color_lut/color_adapt.h"
#include "core/common/ball_state.h"
#include "core/common/image.h"
#include "core/common/status.h"
#include "core/detect/detect.h"
#include "core/field/features.h"
#include "core/field/field_model.h"
#include "core/field/localise.h"
#include "core/health/camera_watch.h"
#include "core/health/mirror_rim.h"
#include "core/health/persp_turn.h"
#include "core/scanline/scanline.h"
#include "core/triangulation/triangulation.h"

namespace bv {

class ColorLut;

/// A pose sent by the main computer (its own localisation). Field frame: origin at the centre
/// spot, metres; heading = field angle (CCW from +X) of the robot's +y. It seeds the
/// coprocessor's own localisation, and is used directly while that has no usable pose.
struct RobotPose {
  bool known = false;  // without a pose there is no field test
  float x_m = 0, y_m = 0, heading_rad = 0;
};

struct PipelineConfig {
  uint32_t predict_ahead_us = 200000;  // actuation latency covered by px/py/pz
  BallFilterConfig filter;
  TriangulationConfig triangulation;
  float max_ray_gap_m = 0.4f;  // larger: the two detections are not the same ball
  // Ray noise for the filter: centroid 1-sigma in pixels plus a fraction of the region's radius
  // (partial classification of a shaded or sunlit side), the omni azimuth's calibration error,
  // and the persp apparent-size range cue's relative 1-sigma (plus 0.7 px of radius error).
  // Measured on the shared renders (seed 1; ray angle against truth): persp 0.2-0.9 mrad rms,
  // omni 1-3 mrad in elevation, size range +2 % +-3 %. The defaults are 1.5-2x those, for other
  // light and other balls. The omni azimuth's calibration error was 5-8 mrad before the
  // calibration fitted the mirror tilt's harmonics, 1-2 mrad now; its sigma stays 6 mrad: 3 mrad
  // made no difference on the shared sets, and an occluded or half-shaded ball's centroid moves
  // sideways by more than the centroid term says.
  float omni_sigma_px = 0.3f, omni_sigma_per_radius = 0.02f;
  float omni_azimuth_sigma_rad = 0.006f;
  float persp_sigma_px = 0.3f, persp_sigma_per_radius = 0.01f;
  // The part of a ray's error that neighbouring frames share, which the filter's window cannot
  // average away (reported sigma only): a base centroid bias, the occlusion, cut and misfit terms
  // above in full, the omni azimuth's calibration error (1-2 mrad, fixed per direction) and the
  // omni distance map's range error (relative). Measured apart on renders (2026-12-04):
  // - the omni region's centroid lies outward of the true silhouette's (the lit ball's shaded
  //   lower side is lost): median 0.02 px at radius 11 px, 0.08 at 7.5, 0.12-0.14 at 4-5 (4-7 m)
  //   over 6 sets, as if 1.5 pixels were lost (n / (pi r)), 1.5 +- 1 from set to set. At the
  //   mirror's ~10 mrad/px 0.13 px is ~1 mrad of elevation, and triangulated its range error grows
  //   as R^2: a lob's first second at 4-6 m was 6-12 cm long. The ray is corrected for the 1.5
  //   pixels; the spread stays in the sigma;
  // - the map itself, scored against the true ground map (tools/python/score_omni_calib.py):
  //   0.40 % rms up to 5 m, where the calibration's residual (rms_ground_rel, 0.58 % on the
  //   reference rig) also holds the carpet points' own noise.
  // The persp centroid sits ~0.1 px high at 4-7 m, but with a sign that changes with the light
  // nearer: corrected like the omni's, lobs came out worse; its base stays 0.05 px.
  float omni_bias_px = 0.05f, persp_bias_px = 0.05f;
  float omni_shade_lost_px = 1.5f, omni_shade_spread_px = 1.0f;
  float omni_range_bias_rel = 0.004f;
  float omni_azimuth_bias_rad = 0.0015f;
  float size_range_rel = 0.05f;  // also how much smaller than predicted a region in view may be
  BallFinderConfig finder;       // ball choice and attention (core/detect), both cameras
  // Size, place and look of the persp camera's candidates (core/ball_check): the calibrated
  // camera's place check, and the appearance classifier when `classifier` is given (loaded; it
  // must outlive the pipeline).
  bool persp_checks = true;
  const BallClassifier* classifier = nullptr;
  BallGeometryConfig geometry;
  BallCheckConfig check;
  // Circles fitted to persp outlines that are not clean discs (a ball merged with a red box or
  // cone behind it, partly hidden by a robot). Off for the omni image: the mirror bends the ball.
  bool persp_circles = true;
  // The field itself is the calibration's (RigCalibration::field): the in-field rule and the
  // self-localisation from the omni camera's line points (core/field) use it.
  bool field_features = true;  // line points, obstacles, localisation
  int feature_rays = 64;       // power of two; part of the omni scan table
  FieldFeatureConfig features;
  LocaliserConfig localiser;
  CandidateTracksConfig candidates;  // the other ball candidates, tracked beside the filter
  CameraWatchConfig watch;           // frozen, blind and missing cameras (core/health)
  PerspTurnConfig persp_turn;        // a turned persp camera, from balls on the floor (core/health)
  MirrorRimConfig mirror_rim;        // a knocked mirror, from its rim in the omni image
};

struct FrameInput {
  YuyvImage omni;  // !valid() when that camera delivered no frame
  YuyvImage persp;
  uint64_t t_us = 0;  // exposure time of the pair
  // Each camera's own exposure time, when the source knows it (0: unknown): one that stands
  // still is a frozen camera even when its pixels change (core/health).
  uint64_t omni_t_us = 0, persp_t_us = 0;
};

/// Stages of Pipeline::Process(), in its order; timed when a stage clock is set.
enum class PipelineStage : uint8_t {
  kPredict,        // the track's prediction into both images
  kFieldFeatures,  // omni scanlines -> line points, obstacles, goals
  kLocalise,       // the pose from them, the in-field rule
  kFrontEnd,       // both cameras: scan and classify, regions, checks, the ball choice
  kRays,           // viewing rays, triangulation, the observation
  kFilter,         // the trajectory fit
  kState,          // the state at the exposure, its sigma, the prediction ahead
  kReview,         // colour adaptation, the in-field check of the track, other candidates
  kCount
};
inline constexpr int kPipelineStageCount = static_cast<int>(PipelineStage::kCount);
const char* PipelineStageName(PipelineStage stage);
/// A free-running tick counter (host: a steady clock; device: the cycle counter).
using StageClock = uint32_t (*)();

/// Per-frame counters of the front end (pixels read, regions, overflows) for benches and status.
struct PipelineStats {
  uint32_t pixels_read = 0;
  uint32_t regions_traced = 0;
  uint32_t overflows = 0;
  uint32_t frame_errors = 0;           // images the front end refused (size, stride)
  uint32_t rejected_measurements = 0;  // cumulative: filter rejections (outlier, field, time)
  uint32_t feature_lookups = 0;        // LUT lookups of the field-feature pass (scan-table pixels)
  uint32_t out_of_field_rejected = 0;  // ball candidates refused by the pose (this frame)
  uint32_t tracks_dropped_out_of_field = 0;  // cumulative
  uint32_t track_handovers = 0;  // cumulative: a ball at rest given up for a moving candidate
  uint32_t stage_ticks[kPipelineStageCount] = {};  // last frame; all 0 without a stage clock
};

/// Where the prediction for the current frame falls in each image (attention, ball choice).
struct ImagePrediction {
  bool valid = false;
  float u_px = 0, v_px = 0, radius_px = 0;
  // Radius of a disc with the silhouette's area (what BallDetection::radius_px measures); 0 when
  // unknown. The omni radius_px above is the ball's footprint along the image radius, smaller.
  float silhouette_radius_px = 0;
};

/// What went into the filter for the last frame (evaluation, annotation).
struct MeasurementInfo {
  bool valid = false;  // a 3D measurement was formed (it may still have been rejected)
  Eigen::Vector3f p_m = Eigen::Vector3f::Zero();
  bool z_valid = true;
  uint16_t filter_flags = 0;  // what the filter did with it (0 = accepted)
  // The omni-only estimate (ray on the floor plane z = r), whenever the omni camera saw the
  // ball: the "2D" comparison of the paper's Fig. 4.
  bool omni_ground_valid = false;
  Eigen::Vector3f omni_ground_m = Eigen::Vector3f::Zero();
};

/// The omni scan pattern the pipeline builds for a calibration: the reference ball profile plus
/// the field-feature rays (when config.field_features), out to where the distance map ends.
OmniScanConfig PipelineOmniScan(const OmniCalibration& cal, const PipelineConfig& config);

/// An omni detection's ray noise for the filter (out's sigma_h/v and bias_h/v): the centroid's
/// noise and shared bias, by the mirror's local scale at the detection, the shaded side's lost
/// pixels, the azimuth's and the distance map's calibration errors. extra_px / shared_extra_px:
/// what occlusion, a cut or a size misfit add to the noise / to the bias.
void OmniRaySigma(const OmniCalibration& cal, const BallDetection& det, const Ray& ray,
                  float extra_px, float shared_extra_px, const PipelineConfig& config,
                  BallRay& out);

/// How far a region's centroid may be off, in pixels, when its radius disagrees with the predicted
/// silhouette's (0 without a prediction): a partly hidden ball's visible part, or the ball merged
/// with something beside it. A region smaller by less than `small_rel` is a ball in full view.
float SizeMisfitPx(const ImagePrediction& pred, float radius_px, float small_rel);

/// The tables Init builds for a calibration (105 KB on the device): written only by Init and read
/// in order every frame, so the firmware keeps them in external RAM (firmware/main_loop.h).
struct PipelineTables {
  ScanlineTable<kOmniScanPixels> omni;
  ScanlineTable<kPerspScanPixels> persp;
  FieldFeatureWalk feature_walk;
};

class Pipeline {
 public:
  /// `tables` outlive the pipeline and serve no other.
  explicit Pipeline(PipelineTables& tables) : tables_(tables) {}
  Pipeline(const Pipeline&) = delete;
  Pipeline& operator=(const Pipeline&) = delete;

  /// Errors: kFailedPrecondition when the calibration is not valid for any camera,
  /// kInvalidArgument / kResourceExhausted from building the scan tables.
  Status Init(const RigCalibration& calibration, const ColorLut& lut, const PipelineConfig& config);
  /// The calibration given to Init (nullptr before).
  const RigCalibration* calibration() const { return calibration_; }
  /// Runs one frame pair. Always fills `out` (found=false and flags when nothing was seen).
  /// proc_us is left 0: the caller owns the clock.
  Status Process(const FrameInput& in, BallState& out);
  const PipelineStats& last_stats() const { return stats_; }
  /// Times each PipelineStage of Process() into last_stats().stage_ticks; null (the default)
  /// turns it off.
  void SetStageClock(StageClock clock) { stage_clock_ = clock; }
  const BallFilter& filter() const { return filter_; }
  /// The persp camera's turn estimate; its model() is the camera model the pipeline uses.
  const PerspTurnWatch& persp_turn() const { return persp_turn_; }
  /// The knocked-mirror watch on the omni image's rim.
  const MirrorRimWatch& mirror_rim() const { return mirror_rim_; }
  /// The omni camera model the pipeline uses: the calibration's, re-centred on the mirror rim
  /// while the rim watch says the mirror moved.
  const OmniCalibration& omni_model() const { return omni_model_; }
  bool OmniCorrected() const {
    return config_.mirror_rim.recentre && mirror_rim_.state() == CameraState::kChanged;
  }
  /// The calibration given to Init with the corrections in use folded in (the persp camera
  /// turned by its estimate), for storing on the main computer's command; the calibration id
  /// is left for the caller to renew. False (and `out` untouched) when nothing is corrected. The
  /// omni re-centring is not stored: it leaves a few % of range error (core/health/README.md),
  /// which a calibration would pass off as none.
  bool CorrectedCalibration(RigCalibration& out) const {
    if (calibration_ == nullptr || persp_turn_.state() != CameraState::kCorrected) return false;
    out = *calibration_;
    out.persp = persp_turn_.model();
    return true;
  }
  const MeasurementInfo& last_measurement() const { return meas_; }
  /// Forgets the track (e.g. between unrelated stills); calibration and tables stay.
  void ResetTrack() {
    filter_.Reset();
    track_confirmed_ = track_found_ = false;
    candidates_.Reset();
    handover_ = Handover{};
    omni_watch_.Reset();
    persp_watch_.Reset();
    persp_turn_.Reset();
    mirror_rim_.Reset();
    CorrectOmni();
  }
  /// Online colour adaptation (core/color_lut/color_adapt.h), fed with the detections both
  /// cameras confirm; null turns it off. The adapter must outlive the pipeline's use of it.
  void SetColorAdapter(ColorAdapter* adapter) { adapter_ = adapter; }
  const ScanlineTableBase& omni_scan() const { return tables_.omni; }
  const ScanlineTableBase& persp_scan() const { return tables_.persp; }
  const ColorLut* lut() const { return lut_; }
  const BallFinder& omni_finder() const { return omni_finder_; }
  const BallFinder& persp_finder() const { return persp_finder_; }
  /// The predicted image positions used for the last frame (annotation, tests).
  const ImagePrediction& omni_prediction() const { return pred_omni_; }
  const ImagePrediction& persp_prediction() const { return pred_persp_; }
  /// A pose from the main computer (takes effect from the next frame): seeds the localiser and is
  /// used while the localiser has no usable pose. Non-finite values are refused with
  /// kInvalidArgument and the old pose kept.
  Status SetRobotPose(const RobotPose& pose);
  const RobotPose& robot_pose() const { return pose_; }
  /// Which half the robot is in (sign of its field x; 0 = unknown): resolves the field's symmetry.
  Status SetFieldHalf(int8_t half);
  /// Odometry for the next frame (robot motion since the last frame: dx, dy in the old robot
  /// frame, dheading); used once.
  Status SetOdometry(float dx_m, float dy_m, float dheading_rad);
  /// True if the robot-frame floor point is inside the field, or if that cannot be told (no
  /// usable pose: the rule switches itself off rather than reject the real ball).
  bool InField(float x_m, float y_m) const;
  /// The pose the in-field rule uses (own localisation, else the main computer's), if any.
  bool FieldPose(RobotPose& pose, float& sigma_m) const;
  const FieldFeatures& features() const { return features_; }
  const PoseEstimate& localisation() const { return localiser_.pose(); }
  const FieldModel& field_model() const { return field_model_; }
  bool features_enabled() const { return features_ready_; }

 private:
  BallDetection Detect(BallFinder& finder, const YuyvImage& img, const ImagePrediction& pred);
  bool LargerThanABall(float persp_radius_px, float range_m) const;
  bool StereoConsistent(const BallDetection& omni, const BallDetection& persp,
                        Eigen::Vector3f* point = nullptr) const;
  void ChooseStereoPair(BallDetection& omni, BallDetection& persp) const;
  bool FindStereoPair(BallDetection& omni, BallDetection& persp, bool in_field_only) const;
  bool PerspLooked(const BallDetection& persp) const;
  // BallFinder field predicates: image region -> the nearest ball position it can be -> field
  // test (no verdict when the ball may be in the air above a point inside).
  struct OmniField final : FieldPredicate {
    const Pipeline* p = nullptr;
    bool Inside(float u_px, float v_px, float radius_px) const override;
  };
  struct PerspField final : FieldPredicate {
    const Pipeline* p = nullptr;
    bool Inside(float u_px, float v_px, float radius_px) const override;
  };
  OmniField omni_field_;
  PerspField persp_field_;
  void Predict(uint64_t t_us);
  void Lap(PipelineStage done);  // charges the ticks since the last lap to `done`
  // Process()'s stages, in its order.
  struct CameraRays {  // the detections' rays, and whether the rim or border cut the ball
    Ray omni, persp;
    bool have_omni = false, have_persp = false, omni_cut = false, persp_cut = false;
  };
  bool LocaliseAndSetFieldRule(const FrameInput& in);  // true: the in-field rule is active
  void DetectBalls(const FrameInput& in, BallState& out);
  CameraRays DetectionRays(const FrameInput& in, BallState& out) const;
  void PerspRayNoiseAndRange(const BallDetection& det, const Ray& ray, bool cut,
                             BallRay& out) const;
  bool TriangulateSameBall(const CameraRays& rays, BallState& out);
  void BuildObservation(const CameraRays& rays, BallState& out, BallObservation& obs);
  void RefineCutBall(const YuyvImage& img, BallDetection& det) const;
  void AdaptColours(const FrameInput& in, const BallState& out);
  void CheckTrackInField(bool have_field_pose, BallState& out);
  void WatchPerspTurn(const CameraRays& rays, BallState& out);
  void ReviewCandidates(const FrameInput& in, const BallState& out);
  bool PredictAt(const Eigen::Vector3f& p);
  bool OwnPoseTrusted() const;  // the localiser's pose, usable and within usable_sigma_m
  void NameGoals();
  void RefuseOffFieldObstacles();
  void RefreshFieldRule();

  const RigCalibration* calibration_ = nullptr;
  const ColorLut* lut_ = nullptr;
  PipelineConfig config_;
  PipelineStats stats_;
  StageClock stage_clock_ = nullptr;
  uint32_t stage_mark_ = 0;
  bool initialised_ = false;
  PipelineTables& tables_;
  BallFinder omni_finder_, persp_finder_;
  BallGeometry persp_geometry_;
  BallCheck persp_check_;
  BallFilter filter_;
  CameraWatch omni_watch_, persp_watch_;
  PerspTurnWatch persp_turn_;
  MirrorRimWatch mirror_rim_;
  // A copy of the calibration's omni model, its centre moved to where the rim watch finds the
  // rim (issue 40 B5); the field features and every omni ray use it.
  OmniCalibration omni_model_;
  float features_centre_u_ = 0, features_centre_v_ = 0;  // the feature rays' centre
  void CorrectOmni();
  FieldFeatureConfig FeatureConfig() const;
  // The omni camera's knocked-mirror evidence (rim or ball samples) as one change (rad); 0: none.
  float OmniKnockedRad() const;
  FrameInput used_;  // this pair's frames as Process() uses them (refused ones left out)
  ImagePrediction pred_omni_, pred_persp_;
  MeasurementInfo meas_;
  float omni_outer_radius_px_ = 1e9f;  // mirror rim in the image (scan table geometry)
  RobotPose pose_;
  FieldModel field_model_;
  FieldFeatureExtractor extractor_;
  Localiser localiser_;
  FieldFeatures features_;
  bool features_ready_ = false;
  bool track_seen_in_field_ = false;  // the current track was inside the field at some frame
  bool track_confirmed_ = false;      // the current track took a triangulated frame
  bool track_found_ = false;          // the last frame had a state
  uint64_t track_since_us_ = 0;       // when the current track was first found
  ColorAdapter* adapter_ = nullptr;   // online colour adaptation, off when null
  float odometry_[3] = {};
  bool odometry_pending_ = false;
  struct FieldRule {  // InField's pose, refreshed when the pose changes (RefreshFieldRule)
    bool active = false;
    float x = 0, y = 0, s = 0, c = 1, half_x = 0, half_y = 0;
  };
  FieldRule field_rule_;
  CandidateTracks candidates_;
  bool candidates_in_field_frame_ = false;
  struct Handover {  // a moving candidate the filter takes next (robot frame)
    bool valid = false;
    float x = 0, y = 0, vx = 0, vy = 0;
    uint64_t t_us = 0;
  };
  Handover handover_;
};

/// A pipeline with its tables in the same object (host tools, tests and benchmarks).
class OwnedPipeline : private PipelineTables, public Pipeline {
 public:
  OwnedPipeline() : PipelineTables(), Pipeline(static_cast<PipelineTables&>(*this)) {}
};

}  // namespace bv
