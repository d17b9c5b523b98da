#pragma once
// A knocked mirror, told from the omni image alone (issue 40 B4): the mirror's rim is the circle
// where its bright image ends in the dark around it, and `calibrate omni` put the image centre
// at that circle's centre (tools/ballvision/calib_omni_steps.h, FindCentre). A mirror tilted or
// moved on its holder moves the rim circle in the image: 1.5 deg of tilt and 2 mm moved it by
// 12 px on the reference rig, while the circle fitted to one frame stays within 1 px of the
// calibration's centre. Every few frames the rim is measured the same way as the calibration
// does (inward along fixed directions to the first pixel of Y >= 40), a circle is fitted,
// trimmed of directions a strut or a bright object at the rim spoils, and the median offset of
// the last measurements against the calibrated centre decides.
#include <cstdint>

#include "core/calibration/calibration.h"
#include "core/common/ball_state.h"
#include "core/common/image.h"

namespace bv {

struct MirrorRimConfig {
  bool enabled = true;
  int every_frames = 4;         // one measurement per this many frames (its cost, ~1.4 k px)
  uint8_t bright_y = 40;        // calibrate omni's rim threshold
  float search_out_px = 24.0f;  // the walk starts this far beyond the usable circle ...
  float search_in_px = 16.0f;   // ... and ends this far inside it
  int min_points = 20;          // of kDirections, after trimming
  float max_fit_rms_px = 1.5f;  // a fit with a larger rms is no circle
  float flag_px = 4.0f;         // median centre offset at which the mirror is flagged ...
  float clear_px = 2.5f;        // ... and below which the flag clears
  // Beyond correction (kUnusable: the omni frames are not used): the rim this far off, or no
  // circle in most measurements while found on most directions (10 deg of tilt: 27 px, and a
  // fit 8 px rms).
  float unusable_px = 20.0f;
  // While flagged, re-centre the pipeline's omni model on the rim (Pipeline::CorrectOmni). Off:
  // on a knock held out from its design (seed 908) the ball and the robots came out worse
  // (core/health/README.md).
  bool recentre = false;
};

class MirrorRimWatch {
 public:
  static constexpr int kDirections = 48;
  static constexpr int kHistory = 5;  // measurements in the median

  /// `outer_radius_px`: the usable mirror circle (the self-mask's, or the reference rig's); the
  /// rim lies just beyond it. Forgets every measurement.
  void Init(const OmniCalibration& cal, float outer_radius_px, const MirrorRimConfig& config);
  void Reset();
  /// Watches nothing (no omni calibration) until the next Init.
  void Clear() {
    cal_ = nullptr;
    Reset();
  }
  /// One omni frame (ignored unless it is this frame's turn and the image is valid).
  void Observe(const YuyvImage& omni);
  /// kAsCalibrated, kChanged, or kUnusable (beyond correction).
  CameraState state() const { return state_; }
  /// The median centre offset (px) and what it turns a ray at half the rim radius by (deg).
  float offset_px() const { return offset_px_; }
  /// The median offset's image components (px): where the rim's centre now lies against the
  /// calibrated centre.
  float offset_u_px() const { return offset_u_px_; }
  float offset_v_px() const { return offset_v_px_; }
  float change_deg() const { return change_deg_; }
  /// The last measurement: points kept and the fit's rms (px); 0 points: none usable.
  int last_points() const { return last_points_; }
  float last_rms_px() const { return last_rms_px_; }

 private:
  enum class Rim : uint8_t { kNone, kCircle, kMisshapen };
  Rim Measure(const YuyvImage& omni, float& du, float& dv);
  void Decide();

  MirrorRimConfig config_;
  const OmniCalibration* cal_ = nullptr;
  float outer_px_ = 0;
  float cos_[kDirections] = {}, sin_[kDirections] = {};
  float pu_[kDirections] = {}, pv_[kDirections] = {};  // one measurement's rim points
  bool keep_[kDirections] = {};
  int frame_ = 0;
  float du_[kHistory] = {}, dv_[kHistory] = {};
  bool misshapen_[kHistory] = {};
  int count_ = 0, next_ = 0;
  float offset_px_ = 0, offset_u_px_ = 0, offset_v_px_ = 0, change_deg_ = 0, last_rms_px_ = 0;
  int last_points_ = 0;
  CameraState state_ = CameraState::kAsCalibrated;
};

}  // namespace bv
