#pragma once
// Teaching the ball colour model (core/color_lut/color_model.h) from pixels, allocation-free:
// fixed-size histograms of the taught pixels' hue, relative chroma and luma, the model fitted
// from their percentiles, the hue window narrowed against ball-coloured background, and the
// check that the taught colour does not take the field. Used by `ballvision lut teach` on the
// host and by the device's teach command (firmware), so both learn the same way.
#include <cstdint>

#include "core/color_lut/color_model.h"
#include "core/common/image.h"
#include "core/common/status.h"

namespace bv {

/// atan2(V-128, U-128) in degrees, (-180, 180].
float HueDeg(const Yuv& p);
/// |(U-128, V-128)| / Y (Y 0 counts as 1).
float RelativeChroma(const Yuv& p);
/// deg + k * 360 within (centre - 180, centre + 180]: hue windows may cross +-180 deg (yellow).
float UnwrapNear(float deg, float centre);

/// Histograms of ball pixels. ~4 KB: the device keeps it in its upload buffer while teaching.
class BallColorStats {
 public:
  static constexpr int kHueBins = 360;     // 1 deg; pixels with relative chroma >= 0.25 only
  static constexpr int kChromaBins = 128;  // relative chroma 0..2.56 in steps of 0.02
  static constexpr int kLumaBins = 256;
  static constexpr float kHueMinChroma = 0.25f;  // below, hue is mostly sensor noise

  void Clear();
  void Add(const Yuv& p, float weight = 1.0f);
  /// Multiplies every count by `factor` (decay: old light counts less).
  void Scale(float factor);
  float count() const { return n_; }
  float hue_count() const { return n_hue_; }
  const float* hue() const { return hue_; }
  float hue_mean_deg() const;  // circular mean of the hue histogram's pixels

  /// The model with these pixels' hue (central 96 % around their circular mean, 4 deg margin),
  /// relative chroma floors (0.85 x the 3rd percentile below / above the bright knee), ceiling
  /// (1.3 x the 99.5th percentile) and luma floor (floors never above the start's); the rest from
  /// `start`. kFailedPrecondition naming the reason: fewer than 100 pixels, or nearly grey.
  Status Fit(const BallColorModel& start, BallColorModel& out) const;

 private:
  float hue_[kHueBins] = {};
  float chroma_dark_[kChromaBins] = {}, chroma_bright_[kChromaBins] = {};
  float chroma_all_[kChromaBins] = {};
  float luma_[kLumaBins] = {};
  float sum_cos_ = 0, sum_sin_ = 0, n_ = 0, n_hue_ = 0;
  uint8_t bright_y_ = 128, bright_y_end_ = 192;
};

/// Hue histogram (1 deg bins, as BallColorStats) of background pixels the model takes apart
/// from its hue window.
struct HueHistogram {
  float bins[BallColorStats::kHueBins] = {};
  void Clear();
  void AddIfInModelIgnoringHue(const BallColorTest& test, const Yuv& p, float weight = 1.0f);
};

/// Narrows m's hue window to the pair of ball-hue percentiles (0.5..5 % at either end, 2 deg out)
/// that costs the fewest ball pixels plus `background_weight` x the background samples inside.
void NarrowHueWindow(const BallColorStats& ball, const HueHistogram& background,
                     float background_weight, BallColorModel& m);

/// Counts of field / line background samples (BackgroundClass) and how many the model takes.
struct FieldCheck {
  uint32_t field = 0, field_taken = 0, all = 0, all_taken = 0;
  void Add(const BallColorTest& test, const Yuv& p);
  float field_taken_fraction() const { return field ? float(field_taken) / float(field) : 0.f; }
};
/// A taught colour may take at most this fraction of the field's and lines' pixels.
inline constexpr float kMaxFieldTaken = 0.002f;

// --- one-step teaching from one frame pair (the device's teach command) ---

/// Where the ball is in one camera's image: its centre, and its radius when known (from a
/// projected floor point; 0: measured from the image).
struct TeachTarget {
  bool valid = false;
  float u_px = 0, v_px = 0, radius_px = 0;
};

/// The state a teach needs (~6 KB): the device places it in its upload buffer.
struct TeachWorkspace {
  BallColorStats ball;
  HueHistogram background;
};

/// Learns the ball colour from the frame pair: from each valid target a region of the seed
/// pixel's own colour (hue within 15 deg, relative chroma >= 0.1) is measured along 8 rays,
/// the disc inside it feeds the statistics; the fitted model is narrowed against the images'
/// background (every 8th pixel of every 8th row outside the ball) and checked against their
/// field and lines. `failed_camera` names the camera (0 omni, 1 persp) an error is about.
/// Errors: kNotFound (no ball-coloured region at a target, or it is too small / too large),
/// kFailedPrecondition (the pixels cannot be a ball colour: grey, too few), kOutOfRange (the
/// colour would take more than kMaxFieldTaken of the field's and lines' pixels).
Status TeachFromImages(const YuyvImage images[2], const TeachTarget targets[2],
                       const BallColorModel& start, TeachWorkspace& ws, BallColorModel& out,
                       int& failed_camera);

}  // namespace bv
