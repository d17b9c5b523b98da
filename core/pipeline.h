#pragma once
// The stage order, written once: LUT on scanlines + attention -> regions -> ball choice ->
// rays -> triangulation (or a one-camera fallback) -> ball filter -> BallState. The filter's
// prediction is projected back into both images for the next frame's attention and ball
// choice. Statically sized; Process() never allocates.
#include <cstdint>

#include "core/ball_filter/ball_filter.h"
#include "core/calibration/calibration.h"
#include "core/common/ball_state.h"
#include "core/common/image.h"
#include "core/common/status.h"
#include "core/detect/detect.h"
#include "core/scanline/scanline.h"
#include "core/triangulation/triangulation.h"

namespace bv {

class ColorLut;

/// The playing field, for the ball choice's "inside the field" rule (paper IV-A): a region whose
/// ground point lies inside is favoured over one outside (a red shirt behind the goal line).
struct FieldConfig {
  float half_length_m = 9.0f;  // MSL field 18 x 12 m
  float half_width_m = 6.0f;
  float margin_m = 0.3f;  // a ball on or just over the line still counts as inside
};

/// The robot's pose in the field, from the main computer's self-localisation. Field frame:
/// origin at the centre spot, metres; heading = field angle (CCW from +X) of the robot's +y.
struct RobotPose {
  bool known = false;  // without a pose there is no field test
  float x_m = 0, y_m = 0, heading_rad = 0;
};

struct PipelineConfig {
  uint32_t predict_ahead_us = 200000;  // actuation latency covered by px/py/pz
  BallFilterConfig filter;
  TriangulationConfig triangulation;
  float max_ray_gap_m = 0.4f;  // larger: the two detections are not the same ball
  BallFinderConfig finder;     // ball choice and attention (core/detect), both cameras
  FieldConfig field;
};

struct FrameInput {
  YuyvImage omni;  // !valid() when that camera delivered no frame
  YuyvImage persp;
  uint64_t t_us = 0;  // exposure time of the pair
};

/// Per-frame counters of the front end (pixels read, regions, overflows) for benches and status.
struct PipelineStats {
  uint32_t pixels_read = 0;
  uint32_t regions_traced = 0;
  uint32_t overflows = 0;
  uint32_t frame_errors = 0;           // images the front end refused (size, stride)
  uint32_t rejected_measurements = 0;  // cumulative: filter rejections (outlier, field, time)
};

/// Where the prediction for the current frame falls in each image (attention, ball choice).
struct ImagePrediction {
  bool valid = false;
  float u_px = 0, v_px = 0, radius_px = 0;
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

class Pipeline {
 public:
  /// Errors: kFailedPrecondition when the calibration is not valid for any camera,
  /// kInvalidArgument / kResourceExhausted from building the scan tables.
  Status Init(const RigCalibration& calibration, const ColorLut& lut, const PipelineConfig& config);
  /// The calibration given to Init (nullptr before).
  const RigCalibration* calibration() const { return calibration_; }
  /// Runs one frame pair. Always fills `out` (found=false and flags when nothing was seen).
  /// proc_us is left 0: the caller owns the clock.
  Status Process(const FrameInput& in, BallState& out);
  const PipelineStats& last_stats() const { return stats_; }
  const BallFilter& filter() const { return filter_; }
  const MeasurementInfo& last_measurement() const { return meas_; }
  /// Forgets the track (e.g. between unrelated stills); calibration and tables stay.
  void ResetTrack() { filter_.Reset(); }
  const ScanlineTableBase& omni_scan() const { return omni_scan_; }
  const ScanlineTableBase& persp_scan() const { return persp_scan_; }
  const ColorLut* lut() const { return lut_; }
  const BallFinder& omni_finder() const { return omni_finder_; }
  const BallFinder& persp_finder() const { return persp_finder_; }
  /// The predicted image positions used for the last frame (annotation, tests).
  const ImagePrediction& omni_prediction() const { return pred_omni_; }
  const ImagePrediction& persp_prediction() const { return pred_persp_; }
  /// Updates the robot's field pose (takes effect from the next frame). Non-finite values are
  /// refused with kInvalidArgument and the old pose kept.
  Status SetRobotPose(const RobotPose& pose);
  const RobotPose& robot_pose() const { return pose_; }
  /// True if the robot-frame floor point is inside the field, or if that cannot be told (no pose).
  bool InField(float x_m, float y_m) const;

 private:
  BallDetection Detect(BallFinder& finder, const YuyvImage& img, const ImagePrediction& pred);
  // BallFinder field predicates: image point -> floor point (ball centre height) -> field test.
  static bool OmniInField(void* self, float u_px, float v_px);
  static bool PerspInField(void* self, float u_px, float v_px);
  void Predict(uint64_t t_us);

  const RigCalibration* calibration_ = nullptr;
  const ColorLut* lut_ = nullptr;
  PipelineConfig config_;
  PipelineStats stats_;
  bool initialised_ = false;
  ScanlineTable<kOmniScanPixels> omni_scan_;
  ScanlineTable<kPerspScanPixels> persp_scan_;
  BallFinder omni_finder_, persp_finder_;
  BallFilter filter_;
  ImagePrediction pred_omni_, pred_persp_;
  MeasurementInfo meas_;
  float omni_outer_radius_px_ = 1e9f;  // mirror rim in the image (scan table geometry)
  RobotPose pose_;
};

}  // namespace bv
