#pragma once
// Size, place and look of a ball candidate: what tells the ball from ceiling lamps, banners,
// shirts and number plates once the colour table and the shape test have let them through.
//   1. Size and place (BallGeometry): where a candidate would be if it were the ball, from its
//      image position and apparent radius, by the camera's calibration or, for a camera without
//      one, by the floor-ball profile a teach learned from boxes. A lamp that would be 8 m up, or
//      a speck far smaller than a ball on the floor at that row, is not the ball.
//   2. Look (BallClassifier): a small int8 network on features of the candidate's pixels (shape,
//      edge along the outline, colour spread, highlight, what surrounds it), weights from a blob.
// Both are evaluated only on the few candidates per image; nothing here allocates.
#include <cstddef>
#include <cstdint>
#include <span>

#include "core/ball_check/floor_profile.h"
#include "core/calibration/calibration.h"
#include "core/color_lut/color_lut.h"
#include "core/common/image.h"
#include "core/common/status.h"
#include "core/scanline/scanline.h"

namespace bv {

/// A candidate as the front end describes it: its centre, radius and shape (core/contour).
struct CandidateShape {
  float u_px = 0, v_px = 0;
  float radius_px = 0;  // equivalent-disc radius, or the fitted circle's
  float area_px = 0;
  float roundness = 0, hull_roundness = 0, width_ratio = 0;
  int16_t u_min = 0, v_min = 0, u_max = 0, v_max = 0;  // bbox, inclusive
  uint8_t arc_sectors = 0;                             // > 0: centre and radius from a circle
};

// ---- size and place ----

/// Where a candidate would be if it were the ball.
struct BallPlace {
  bool known = false;  // false: no geometry for this camera, or the ray could not be formed
  float height_m = 0;  // ball centre above the floor
  // Apparent size against a ball on the floor at this image position: r_floor / r (1 on the
  // floor, smaller for a raised ball, larger for a region too small for a ball there); 0 above
  // the horizon, where no floor ball can be.
  float floor_ratio = 0;
};

enum class PlaceVerdict : uint8_t {
  kPlausible = 0,
  kTooHigh,     // would be higher than any ball flies (a lamp, a banner high on the wall)
  kTooSmall,    // far smaller than a ball on the floor there would look (below the floor)
  kOutOfRange,  // nearer than the robot's own body or further than the hall
};
const char* PlaceVerdictName(PlaceVerdict v);

struct BallGeometryConfig {
  float ball_radius_m = 0.11f;
  float max_height_m = 4.0f;  // highest ball centre still a ball (a high lob)
  // A region of a ball on the floor may be smaller than the ball (shade, highlight, occlusion,
  // a fragment): up to this ratio r_floor / r it is still one (widened by a learned profile's
  // scatter).
  float max_floor_ratio = 4.0f;
  float min_range_m = 0.15f, max_range_m = 30.0f;  // persp calibration only
};

class BallGeometry {
 public:
  /// No geometry: every candidate is plausible, nothing is known of its place.
  void Clear() { mode_ = Mode::kNone; }
  /// A calibrated perspective camera. kInvalidArgument for an invalid calibration or config.
  Status SetPersp(const PerspCalibration& cal, const BallGeometryConfig& config);
  /// A camera known only by the floor-ball profile a teach learned. kInvalidArgument when the
  /// profile is not valid or the config is bad.
  Status SetProfile(const FloorBallProfile& profile, const BallGeometryConfig& config);
  bool known() const { return mode_ != Mode::kNone; }
  float ball_radius_m() const { return config_.ball_radius_m; }

  /// Fills `out` (known = false when nothing can be said) and returns the verdict.
  PlaceVerdict Check(const CandidateShape& c, BallPlace& out) const;

 private:
  enum class Mode : uint8_t { kNone, kPersp, kProfile };
  Mode mode_ = Mode::kNone;
  BallGeometryConfig config_;
  const PerspCalibration* persp_ = nullptr;
  FloorBallProfile profile_;
};

/// The persp scan pattern for a camera known by its floor-ball profile: at each row the spacing of
/// the smallest ball the place check still takes there (below the horizon a floor ball
/// max_floor_ratio times too small, above it a ball at max_height_m), never under
/// min_diameter_px. The profile must be valid and learned on an image of `height` rows.
PerspScanConfig PerspScanFromProfile(const FloorBallProfile& profile,
                                     const BallGeometryConfig& config, int height,
                                     float min_diameter_px);

// ---- look ----

/// What the classifier sees of a candidate; every value is dimensionless and bounded, so one
/// set of weights serves any image size and camera. Indices are part of the classifier blob's
/// contract (kBallFeatureSetVersion): append, never reorder.
enum BallFeature : uint8_t {
  kFeatRoundness = 0,   // chain-code roundness
  kFeatHullRoundness,   // hull roundness
  kFeatWidthRatio,      // narrowest / widest extent
  kFeatFill,            // area / bbox area (a disc 0.785)
  kFeatAspect,          // bbox min / max side
  kFeatLogRadius,       // log2 of the radius in px
  kFeatArc,             // arc_sectors / 16 (0: the region's own centre)
  kFeatCut,             // 1 when the bbox touches the image border
  kFeatInBall,          // inside (r <= 0.75): fraction of ball-class samples
  kFeatInWhite,         // inside: fraction of highlight samples (line class or Y >= 235)
  kFeatInLuma,          // inside: mean Y / 255
  kFeatInLumaSpread,    // inside: std Y / (mean Y + 16)
  kFeatInChroma,        // inside: mean relative chroma |(U, V) - 128| / (Y + 16)
  kFeatInChromaSpread,  // inside: std of (U, V) / (mean |(U, V) - 128| + 8)
  kFeatShadeTopBottom,  // inside: (Y top half - Y bottom half) / (mean Y + 16)
  kFeatShadeLeftRight,  // inside: |Y left - Y right| / (mean Y + 16)
  kFeatOutField,        // ring at 1.4 r: fraction field class
  kFeatOutLine,         // ring: fraction line class
  kFeatOutBall,         // ring: fraction ball class (the colour goes on: a shirt, a banner)
  kFeatOutDark,         // ring: fraction obstacle or unknown class
  kFeatLumaContrast,    // (Y inside - Y ring) / (Y inside + Y ring + 16)
  kFeatChromaContrast,  // |(U, V) inside - (U, V) ring| / 128
  kFeatOutLumaSpread,   // ring: std Y / (mean Y + 16)
  kFeatEdgeMean,        // pairs at 0.8 r / 1.25 r on 16 rays: mean colour step / 128
  kFeatEdgeMin,         // ... the weakest quarter of the rays' mean step / 128
  kFeatEdgeFraction,    // ... fraction of rays with a step of at least 24 levels
  kFeatCoreBall,        // centre and ring 0.3 r: fraction ball class or highlight (a digit's
                        // "0" is hollow)
  kFeatInTexture,       // inside: mean |Y step| between successive samples along the rays /
                        // (mean Y + 16) (a ball's shading is smooth; cloth, print and faces not)
  kFeatCount
};
inline constexpr int kBallFeatureCount = kFeatCount;
inline constexpr uint8_t kBallFeatureSetVersion = 1;

struct BallFeatures {
  float f[kBallFeatureCount] = {};
  uint32_t pixels_read = 0;
};

/// Samples the candidate's pixels on a fixed polar pattern (~130 lookups) and fills `out`.
void ComputeBallFeatures(const YuyvImage& image, const ColorLut& lut, const CandidateShape& c,
                         BallFeatures& out);

/// The classifier's numbers: features standardised and quantised to int8 (x = clamp(round((f -
/// in_mean) * in_scale))), one hidden ReLU layer of int8 weights with int32 accumulation, its
/// activations requantised to int8 by s1, a linear output whose int32 sum times s2 is the logit
/// of "ball".
struct BallClassifierWeights {
  static constexpr int kMaxHidden = 16;
  int hidden = 0;
  float in_mean[kBallFeatureCount] = {};
  float in_scale[kBallFeatureCount] = {};
  int8_t w1[kMaxHidden][kBallFeatureCount] = {};
  int32_t b1[kMaxHidden] = {};
  float s1 = 0;
  int8_t w2[kMaxHidden] = {};
  int32_t b2 = 0;
  float s2 = 0;
  float threshold_logit = 0;  // a candidate is a ball above it
};

// --- the classifier blob (BlobKind::kBallClassifier) ---
// payload: feature_set_version u8 | features u8 | hidden u8 | reserved u8 |
//          in_mean f32[features] | in_scale f32[features] | w1 i8[hidden][features] |
//          b1 i32[hidden] | s1 f32 | w2 i8[hidden] | b2 i32 | s2 f32 | threshold_logit f32
inline constexpr uint16_t kBallClassifierBlobVersion = 1;
inline constexpr size_t BallClassifierPayloadBytes(int hidden) {
  return 4 + 8 * kBallFeatureCount + static_cast<size_t>(hidden) * kBallFeatureCount +
         4 * static_cast<size_t>(hidden) + 4 + static_cast<size_t>(hidden) + 4 + 4 + 4;
}
inline constexpr size_t kBallClassifierBlobMaxBytes =
    16 + BallClassifierPayloadBytes(BallClassifierWeights::kMaxHidden);
/// kInvalidArgument for weights Parse would refuse, kResourceExhausted if `out` is small.
Result<size_t> SerializeBallClassifier(const BallClassifierWeights& w, std::span<uint8_t> out);

/// The built-in weights blob (core/ball_check/ball_classifier_weights.cpp, generated by
/// tools/python/train_ball_classifier.py), for BallClassifier::Parse.
std::span<const uint8_t> BuiltInBallClassifierBlob();

/// int8 multilayer perceptron on BallFeatures (BallClassifierWeights), evaluated on the device.
class BallClassifier {
 public:
  bool loaded() const { return w_.hidden > 0; }
  /// Logit of "ball" (> threshold_logit(): ball). 0 when not loaded.
  float Logit(const BallFeatures& features) const;
  float threshold_logit() const { return w_.threshold_logit; }
  void set_threshold_logit(float t) { w_.threshold_logit = t; }
  /// No Logit exceeds this in magnitude (hidden activations lie in 0..127).
  float MaxAbsLogit() const;
  const BallClassifierWeights& weights() const { return w_; }
  uint32_t id() const { return id_; }  // CRC-32 of the blob's payload; 0 when not loaded
  void Clear() { *this = BallClassifier{}; }

  /// Validates the blob (kind, version, CRC, sizes, finite values) before touching *this.
  /// Errors: those of ReadBlob, kInvalidArgument naming the bad field.
  Status Parse(std::span<const uint8_t> blob);

 private:
  BallClassifierWeights w_;
  uint32_t id_ = 0;
};

// ---- both ----

/// What the checks said of one candidate.
struct CandidateVerdict {
  PlaceVerdict place = PlaceVerdict::kPlausible;
  BallPlace where;
  bool classified = false;  // a classifier ran
  float logit = 0;          // its logit (classified)
  bool pass = true;         // neither check refused it
  // Ranking score in (0, 1]: the classifier's probability (1 without one), times a prior that
  // prefers a ball on the floor to one in the air (still images: a shirt at chest height is far
  // more common than a ball there).
  float score = 1;
  uint32_t pixels_read = 0;
};

struct BallCheckConfig {
  bool use_place = true;
  bool use_look = true;
  // Raised candidates' prior: exp(-max(0, height - ball radius) / raised_prior_m).
  float raised_prior_m = 1.5f;
};

class BallCheck {
 public:
  /// `geometry` and `classifier` may be null (that check is off); both must outlive the check.
  void Init(const BallGeometry* geometry, const BallClassifier* classifier,
            const BallCheckConfig& config) {
    geometry_ = geometry;
    classifier_ = classifier;
    config_ = config;
  }
  /// The classifier runs (on candidates whose centre lies inside the image).
  bool looks() const { return config_.use_look && classifier_ != nullptr && classifier_->loaded(); }
  bool active() const {
    return (config_.use_place && geometry_ != nullptr && geometry_->known()) ||
           (config_.use_look && classifier_ != nullptr && classifier_->loaded());
  }
  /// Runs both checks on one candidate. `features` (may be null) receives the classifier's
  /// inputs, computed also without a classifier (training data, debugging); they are not computed
  /// when neither needs them, nor for a candidate the place check refused.
  /// `logit_bonus` is added to the classifier's logit before its threshold (a candidate where the
  /// tracked ball is predicted: the track is evidence the look alone does not have).
  CandidateVerdict Evaluate(const YuyvImage& image, const ColorLut& lut, const CandidateShape& c,
                            BallFeatures* features = nullptr, float logit_bonus = 0.0f) const;

 private:
  const BallGeometry* geometry_ = nullptr;
  const BallClassifier* classifier_ = nullptr;
  BallCheckConfig config_;
};

}  // namespace bv
