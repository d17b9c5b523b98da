#include "core/ball_check/ball_check.h"

#include <algorithm>
#include <cmath>

#include "core/common/blob.h"
#include "core/common/bytes.h"
#include "core/common/crc32.h"
#include "core/common/round.h"

namespace bv {

const char* PlaceVerdictName(PlaceVerdict v) {
  switch (v) {
    case PlaceVerdict::kPlausible:
      return "plausible";
    case PlaceVerdict::kTooHigh:
      return "too high";
    case PlaceVerdict::kTooSmall:
      return "too small for its place";
    case PlaceVerdict::kOutOfRange:
      return "out of range";
  }
  return "?";
}

namespace {
bool ValidGeometryConfig(const BallGeometryConfig& c) {
  return c.ball_radius_m > 0.0f && c.ball_radius_m < 1.0f && c.max_height_m > c.ball_radius_m &&
         c.max_floor_ratio >= 1.0f && c.min_range_m >= 0.0f && c.max_range_m > c.min_range_m &&
         std::isfinite(c.max_height_m) && std::isfinite(c.max_floor_ratio) &&
         std::isfinite(c.max_range_m);
}
}  // namespace

Status BallGeometry::SetPersp(const PerspCalibration& cal, const BallGeometryConfig& config) {
  mode_ = Mode::kNone;
  if (!cal.valid || !(cal.fx > 0.0f) || !ValidGeometryConfig(config)) {
    return Status(StatusCode::kInvalidArgument,
                  "BallGeometry::SetPersp: calibration not valid or bad geometry config");
  }
  persp_ = &cal;
  config_ = config;
  mode_ = Mode::kPersp;
  return Status::Ok();
}

Status BallGeometry::SetProfile(const FloorBallProfile& profile, const BallGeometryConfig& config) {
  mode_ = Mode::kNone;
  if (!profile.valid || !(profile.slope > 0.0f) || !std::isfinite(profile.horizon_v_px) ||
      !std::isfinite(profile.curve) || !ValidGeometryConfig(config)) {
    return Status(StatusCode::kInvalidArgument,
                  "BallGeometry::SetProfile: profile not valid (slope <= 0, NaN) or bad config");
  }
  profile_ = profile;
  config_ = config;
  mode_ = Mode::kProfile;
  return Status::Ok();
}

namespace {
constexpr float kMaxSpreadForHeight = 0.3f;
constexpr float kNearCutMaxHeightM = 0.5f;
}  // namespace

PlaceVerdict BallGeometry::Check(const CandidateShape& c, BallPlace& out) const {
  out = BallPlace{};
  const float R = config_.ball_radius_m;
  if (mode_ == Mode::kNone || !(c.radius_px > 0.0f)) return PlaceVerdict::kPlausible;
  if (mode_ == Mode::kProfile) {
    // Level pinhole: z = h - R (v - v_h) / r with h = R (1 + 1 / k); below the horizon the
    // profile's own radius (which holds the lens's bend) gives the floor ratio.
    const float h = R * (1.0f + 1.0f / profile_.slope);
    const float r_floor = profile_.RadiusAt(c.v_px);
    out.known = true;
    if (r_floor > 0.0f) {
      out.floor_ratio = r_floor / c.radius_px;
      out.height_m = h - (h - R) * out.floor_ratio;
    } else {
      out.height_m = h + R * (profile_.horizon_v_px - c.v_px) / c.radius_px;
    }
  } else {
    const Result<Ray> centre = PerspPixelToRay(*persp_, c.u_px, c.v_px);
    const Result<Ray> a = PerspPixelToRay(*persp_, c.u_px - c.radius_px, c.v_px);
    const Result<Ray> b = PerspPixelToRay(*persp_, c.u_px + c.radius_px, c.v_px);
    if (!centre.ok() || !a.ok() || !b.ok()) return PlaceVerdict::kPlausible;
    const float cos2 = std::clamp(a->dir.dot(b->dir), -1.0f, 1.0f);
    const float half = 0.5f * std::acos(cos2);  // angular radius
    if (!(half > 1e-5f)) return PlaceVerdict::kPlausible;
    const float range = R / std::sin(half);
    const Eigen::Vector3f p = centre->origin + range * centre->dir;
    out.known = true;
    out.height_m = p.z();
    const float dz = centre->dir.z();
    if (dz < -1e-4f && centre->origin.z() > R) {
      const float t_floor = (R - centre->origin.z()) / dz;
      out.floor_ratio = range / t_floor;
    }
    if (range < config_.min_range_m || range > config_.max_range_m) {
      return PlaceVerdict::kOutOfRange;
    }
  }
  // A learned profile is only as good as its boxes agreed: its scatter widens the size test, and
  // one that scattered widely (boxes of several cameras, balls held up) says nothing of height.
  const float spread = mode_ == Mode::kProfile ? profile_.spread : 0.0f;
  if (spread <= kMaxSpreadForHeight && out.height_m > config_.max_height_m) {
    return PlaceVerdict::kTooHigh;
  }
  if (out.floor_ratio > config_.max_floor_ratio * (1.0f + 2.0f * spread)) {
    return PlaceVerdict::kTooSmall;
  }
  return PlaceVerdict::kPlausible;
}

PerspScanConfig PerspScanFromProfile(const FloorBallProfile& profile,
                                     const BallGeometryConfig& config, int height,
                                     float min_diameter_px) {
  PerspScanConfig c;
  const float R = config.ball_radius_m;
  const float h = R * (1.0f + 1.0f / profile.slope);
  const float dmin = std::max(min_diameter_px, 2.0f);
  const float last = static_cast<float>(height - 1);
  // Diameter per row: above the horizon 2 R (v_h - v) / (z_max - h), below it 2 k (v - v_h) /
  // max_floor_ratio (the profile's curve left out: with curve > 0 the line lies below it, so the
  // spacing errs on the dense side), each floored at dmin: kinks at v_a and v_b.
  const float above = config.max_height_m > h ? 2.0f * R / (config.max_height_m - h) : 0.0f;
  const float below = 2.0f * profile.slope / config.max_floor_ratio;
  const float vh = profile.horizon_v_px;
  auto d_at = [&](float v) {
    const float d = v < vh ? above * (vh - v) : below * (v - vh);
    return std::max(dmin, d);
  };
  const float va = above > 0.0f ? vh - dmin / above : -1.0f;
  const float vb = vh + dmin / below;
  float rows[4] = {0.0f, va, vb, last};
  int n = 0;
  for (float v : rows) {
    v = std::clamp(v, 0.0f, last);
    if (n > 0 && v <= c.diameter.at_px[n - 1]) continue;
    c.diameter.at_px[n] = v;
    c.diameter.diameter_px[n] = d_at(v);
    ++n;
  }
  c.diameter.count = n;
  return c;
}

// ---- features ----

namespace {
constexpr int kRays = 16;
constexpr float kCos[kRays] = {
    1.0f,  0.92387953f,  0.70710678f,  0.38268343f,  0.0f, -0.38268343f, -0.70710678f, -0.92387953f,
    -1.0f, -0.92387953f, -0.70710678f, -0.38268343f, 0.0f, 0.38268343f,  0.70710678f,  0.92387953f};
constexpr float kSin[kRays] = {0.0f,  0.38268343f,  0.70710678f,  0.92387953f,
                               1.0f,  0.92387953f,  0.70710678f,  0.38268343f,
                               0.0f,  -0.38268343f, -0.70710678f, -0.92387953f,
                               -1.0f, -0.92387953f, -0.70710678f, -0.38268343f};
constexpr float kInnerRings[] = {0.3f, 0.55f, 0.8f};
constexpr float kEdgeOuter = 1.3f, kContextRing = 1.7f;
constexpr int kHighlightY = 235;
constexpr int kEdgeStep = 24;

struct Sample {
  bool valid = false;
  Yuv p{0, 0, 0};
  ColorClass cls = ColorClass::kUnknown;
};

struct Moments {
  float n = 0, y = 0, yy = 0, u = 0, v = 0, uu = 0, vv = 0, chroma = 0;
  void Add(const Yuv& p) {
    const float fy = p.y, fu = static_cast<float>(p.u) - 128.0f,
                fv = static_cast<float>(p.v) - 128.0f;
    n += 1;
    y += fy, yy += fy * fy;
    u += fu, v += fv, uu += fu * fu, vv += fv * fv;
    chroma += std::sqrt(fu * fu + fv * fv);
  }
  float MeanY() const { return n > 0 ? y / n : 0.0f; }
  float SdY() const {
    if (n <= 0) return 0.0f;
    const float m = y / n;
    return std::sqrt(std::max(0.0f, yy / n - m * m));
  }
  float SdChroma() const {
    if (n <= 0) return 0.0f;
    const float mu = u / n, mv = v / n;
    return std::sqrt(std::max(0.0f, uu / n - mu * mu + vv / n - mv * mv));
  }
};

int StepL1(const Yuv& a, const Yuv& b) {
  return std::abs(int{a.y} - int{b.y}) + std::abs(int{a.u} - int{b.u}) +
         std::abs(int{a.v} - int{b.v});
}

// The candidate's pixels on the polar pattern, feature group by feature group.
class FeatureSampler {
 public:
  FeatureSampler(const YuyvImage& image, const ColorLut& lut, const CandidateShape& c,
                 BallFeatures& out)
      : image_(image), lut_(lut), c_(c), r_(std::max(c.radius_px, 1.0f)), out_(out) {}

  void Shape() {
    float* f = out_.f;
    const int w = c_.u_max - c_.u_min + 1, h = c_.v_max - c_.v_min + 1;
    f[kFeatRoundness] = c_.roundness;
    f[kFeatHullRoundness] = c_.hull_roundness;
    f[kFeatWidthRatio] = c_.width_ratio;
    f[kFeatFill] = std::min(1.0f, c_.area_px / static_cast<float>(std::max(w * h, 1)));
    f[kFeatAspect] = static_cast<float>(std::min(w, h)) / static_cast<float>(std::max(w, h));
    f[kFeatLogRadius] = std::log2(r_);
    f[kFeatArc] = static_cast<float>(c_.arc_sectors) / 16.0f;
    const bool cut = c_.u_min <= 0 || c_.v_min <= 0 || c_.u_max >= image_.width - 1 ||
                     c_.v_max >= image_.height - 1;
    f[kFeatCut] = cut ? 1.0f : 0.0f;
  }

  // The centre and three rings: colour, spread, shading, texture; keeps the outermost ring for
  // the edge.
  void Inside() {
    const Sample centre = At(0, 0);
    AddInside(centre, 0, 0);
    float core_n = centre.valid ? 1.0f : 0.0f, core_ball = Core(centre) ? 1.0f : 0.0f;
    float texture = 0, texture_n = 0;
    Sample prev[kRays];
    for (Sample& p : prev) p = centre;
    for (float ring : kInnerRings) {
      for (int i = 0; i < kRays; ++i) {
        const Sample s = At(ring * r_ * kCos[i], ring * r_ * kSin[i]);
        AddInside(s, kCos[i], kSin[i]);
        if (ring == kInnerRings[0] && s.valid) {
          core_n += 1;
          core_ball += Core(s) ? 1.0f : 0.0f;
        }
        if (s.valid && prev[i].valid) {
          texture += static_cast<float>(std::abs(int{s.p.y} - int{prev[i].p.y}));
          texture_n += 1;
        }
        prev[i] = s;
        if (ring == kInnerRings[2]) inner_edge_[i] = s;
      }
    }
    float* f = out_.f;
    const float in_y = in_.MeanY(), in_n = std::max(in_.n, 1.0f);
    f[kFeatInBall] = in_ball_ / in_n;
    f[kFeatInWhite] = in_white_ / in_n;
    f[kFeatInLuma] = in_y / 255.0f;
    f[kFeatInLumaSpread] = in_.SdY() / (in_y + 16.0f);
    const float in_chroma = in_.n > 0 ? in_.chroma / in_.n : 0.0f;
    f[kFeatInChroma] = std::min(in_chroma / (in_y + 16.0f), 2.0f);
    f[kFeatInChromaSpread] = in_.SdChroma() / (in_chroma + 8.0f);
    f[kFeatCoreBall] = core_n > 0 ? core_ball / core_n : 0.0f;
    f[kFeatInTexture] = texture_n > 0 ? texture / texture_n / (in_y + 16.0f) : 0.0f;
    f[kFeatShadeTopBottom] =
        top_.n > 0 && bottom_.n > 0 ? (top_.MeanY() - bottom_.MeanY()) / (in_y + 16.0f) : 0.0f;
    f[kFeatShadeLeftRight] = left_.n > 0 && right_.n > 0
                                 ? std::fabs(left_.MeanY() - right_.MeanY()) / (in_y + 16.0f)
                                 : 0.0f;
  }

  // The edge ring just beyond the outline and a context ring further out.
  void Outside() {
    Moments ring;
    float out_cls[kColorClassCount] = {};
    int steps[kRays];
    int n_steps = 0, strong = 0;
    for (int i = 0; i < kRays; ++i) {
      const Sample e = At(kEdgeOuter * r_ * kCos[i], kEdgeOuter * r_ * kSin[i]);
      const Sample x = At(kContextRing * r_ * kCos[i], kContextRing * r_ * kSin[i]);
      for (const Sample* s : {&e, &x}) {
        if (!s->valid) continue;
        ring.Add(s->p);
        out_cls[static_cast<int>(s->cls)] += 1;
      }
      if (e.valid && inner_edge_[i].valid) {
        const int step = StepL1(e.p, inner_edge_[i].p);
        steps[n_steps++] = step;
        strong += step >= kEdgeStep;
      }
    }
    float* f = out_.f;
    const float ring_n = std::max(ring.n, 1.0f);
    f[kFeatOutField] = out_cls[static_cast<int>(ColorClass::kField)] / ring_n;
    f[kFeatOutLine] = out_cls[static_cast<int>(ColorClass::kLine)] / ring_n;
    f[kFeatOutBall] = out_cls[static_cast<int>(ColorClass::kBall)] / ring_n;
    f[kFeatOutDark] = (out_cls[static_cast<int>(ColorClass::kObstacle)] +
                       out_cls[static_cast<int>(ColorClass::kUnknown)]) /
                      ring_n;
    const float in_y = in_.MeanY(), ring_y = ring.MeanY();
    f[kFeatLumaContrast] = ring.n > 0 ? (in_y - ring_y) / (in_y + ring_y + 16.0f) : 0.0f;
    if (ring.n > 0 && in_.n > 0) {
      const float du = in_.u / in_.n - ring.u / ring.n, dv = in_.v / in_.n - ring.v / ring.n;
      f[kFeatChromaContrast] = std::sqrt(du * du + dv * dv) / 128.0f;
    }
    f[kFeatOutLumaSpread] = ring.SdY() / (ring_y + 16.0f);
    if (n_steps == 0) return;
    std::sort(steps, steps + n_steps);
    float sum = 0;
    for (int i = 0; i < n_steps; ++i) sum += static_cast<float>(steps[i]);
    const int quarter = std::max(1, n_steps / 4);
    float weak = 0;
    for (int i = 0; i < quarter; ++i) weak += static_cast<float>(steps[i]);
    f[kFeatEdgeMean] = sum / static_cast<float>(n_steps) / 128.0f;
    f[kFeatEdgeMin] = weak / static_cast<float>(quarter) / 128.0f;
    f[kFeatEdgeFraction] = static_cast<float>(strong) / static_cast<float>(n_steps);
  }

 private:
  Sample At(float du, float dv) {
    Sample s;
    const int u = RoundToInt(c_.u_px + du);
    const int v = RoundToInt(c_.v_px + dv);
    if (!image_.contains(u, v)) return s;
    s.valid = true;
    s.p = image_.at(u, v);
    s.cls = lut_.Classify(s.p.y, s.p.u, s.p.v);
    ++out_.pixels_read;
    return s;
  }
  static bool Core(const Sample& s) {
    return s.valid &&
           (s.cls == ColorClass::kBall || s.cls == ColorClass::kLine || s.p.y >= kHighlightY);
  }
  void AddInside(const Sample& s, float cs, float sn) {
    if (!s.valid) return;
    in_.Add(s.p);
    in_ball_ += s.cls == ColorClass::kBall;
    in_white_ += s.cls == ColorClass::kLine || s.p.y >= kHighlightY;
    if (sn < -0.1f) top_.Add(s.p);
    if (sn > 0.1f) bottom_.Add(s.p);
    if (cs < -0.1f) left_.Add(s.p);
    if (cs > 0.1f) right_.Add(s.p);
  }

  const YuyvImage& image_;
  const ColorLut& lut_;
  const CandidateShape& c_;
  const float r_;
  BallFeatures& out_;
  Moments in_, top_, bottom_, left_, right_;
  float in_ball_ = 0, in_white_ = 0;
  Sample inner_edge_[kRays];
};
}  // namespace

void ComputeBallFeatures(const YuyvImage& image, const ColorLut& lut, const CandidateShape& c,
                         BallFeatures& out) {
  out = BallFeatures{};
  FeatureSampler s(image, lut, c, out);
  s.Shape();
  s.Inside();
  s.Outside();
}

// ---- classifier ----

float BallClassifier::Logit(const BallFeatures& features) const {
  if (w_.hidden == 0) return 0.0f;
  int8_t x[kBallFeatureCount];
  for (int i = 0; i < kBallFeatureCount; ++i) {
    const float q = std::round((features.f[i] - w_.in_mean[i]) * w_.in_scale[i]);
    // Written so that a NaN feature maps to -127 (std::clamp would pass it through).
    x[i] = static_cast<int8_t>(q > -127.0f ? (q < 127.0f ? q : 127.0f) : -127.0f);
  }
  int32_t out = w_.b2;
  for (int j = 0; j < w_.hidden; ++j) {
    int32_t acc = w_.b1[j];
    for (int i = 0; i < kBallFeatureCount; ++i) acc += int32_t{w_.w1[j][i]} * int32_t{x[i]};
    if (acc <= 0) continue;  // ReLU
    const float a = std::min(std::round(static_cast<float>(acc) * w_.s1), 127.0f);
    out += int32_t{w_.w2[j]} * static_cast<int32_t>(a);
  }
  return static_cast<float>(out) * w_.s2;
}

float BallClassifier::MaxAbsLogit() const {
  int64_t bound = w_.b2 < 0 ? -int64_t{w_.b2} : int64_t{w_.b2};
  for (int j = 0; j < w_.hidden; ++j) bound += 127 * (w_.w2[j] < 0 ? -w_.w2[j] : w_.w2[j]);
  return static_cast<float>(bound) * std::fabs(w_.s2);
}

namespace {
constexpr float kMaxLayerScale = 1e6f;
constexpr int32_t kMaxBias = int32_t{1} << 24;

const char* CheckWeights(const BallClassifierWeights& w) {
  if (w.hidden < 1 || w.hidden > BallClassifierWeights::kMaxHidden) {
    return "ball classifier: hidden units not in 1..16";
  }
  for (int i = 0; i < kBallFeatureCount; ++i) {
    if (!std::isfinite(w.in_mean[i]) || !std::isfinite(w.in_scale[i]) || w.in_scale[i] < 0) {
      return "ball classifier: input mean or scale not finite (or scale < 0)";
    }
  }
  if (!(w.s1 > 0.0f) || !(w.s2 > 0.0f) || !(w.s1 <= kMaxLayerScale) || !(w.s2 <= kMaxLayerScale) ||
      !std::isfinite(w.threshold_logit)) {
    return "ball classifier: layer scale not in (0, 1e6], or threshold not finite";
  }
  // Bounded biases keep every int32 sum of Logit() from overflowing (28 x 127 x 127 per hidden
  // unit, 16 x 127 x 127 at the output) and, with the scales, the logit finite.
  for (int j = 0; j < w.hidden; ++j) {
    if (w.b1[j] > kMaxBias || w.b1[j] < -kMaxBias) return "ball classifier: b1 beyond +-2^24";
  }
  if (w.b2 > kMaxBias || w.b2 < -kMaxBias) return "ball classifier: b2 beyond +-2^24";
  return nullptr;
}
}  // namespace

Result<size_t> SerializeBallClassifier(const BallClassifierWeights& w, std::span<uint8_t> out) {
  if (const char* why = CheckWeights(w)) return Status(StatusCode::kInvalidArgument, why);
  uint8_t payload[BallClassifierPayloadBytes(BallClassifierWeights::kMaxHidden)];
  ByteWriter p(payload);
  p.U8(kBallFeatureSetVersion);
  p.U8(kBallFeatureCount);
  p.U8(static_cast<uint8_t>(w.hidden));
  p.U8(0);
  for (float m : w.in_mean) p.F32(m);
  for (float s : w.in_scale) p.F32(s);
  for (int j = 0; j < w.hidden; ++j)
    for (int8_t x : w.w1[j]) p.U8(static_cast<uint8_t>(x));
  for (int j = 0; j < w.hidden; ++j) p.I32(w.b1[j]);
  p.F32(w.s1);
  for (int j = 0; j < w.hidden; ++j) p.U8(static_cast<uint8_t>(w.w2[j]));
  p.I32(w.b2);
  p.F32(w.s2);
  p.F32(w.threshold_logit);
  BV_TRY(p.status());
  return WriteBlob(BlobKind::kBallClassifier, kBallClassifierBlobVersion, p.written(), out);
}

Status BallClassifier::Parse(std::span<const uint8_t> blob) {
  Result<BlobView> view = ReadBlob(blob, BlobKind::kBallClassifier, kBallClassifierBlobVersion);
  if (!view.ok()) return view.status();
  ByteReader r(view->payload);
  const uint8_t set = r.U8(), features = r.U8(), hidden = r.U8();
  r.U8();
  if (set != kBallFeatureSetVersion || features != kBallFeatureCount) {
    return Status(StatusCode::kInvalidArgument,
                  "ball classifier: feature set version or count differs from this build's");
  }
  if (hidden == 0 || hidden > BallClassifierWeights::kMaxHidden) {
    return Status(StatusCode::kInvalidArgument, "ball classifier: hidden units not in 1..16");
  }
  if (view->payload.size() != BallClassifierPayloadBytes(hidden)) {
    return Status(StatusCode::kInvalidArgument,
                  "ball classifier: payload size does not match its hidden units");
  }
  BallClassifierWeights w;
  w.hidden = hidden;
  for (float& m : w.in_mean) m = r.F32();
  for (float& s : w.in_scale) s = r.F32();
  for (int j = 0; j < hidden; ++j)
    for (int8_t& x : w.w1[j]) x = static_cast<int8_t>(r.U8());
  for (int j = 0; j < hidden; ++j) w.b1[j] = r.I32();
  w.s1 = r.F32();
  for (int j = 0; j < hidden; ++j) w.w2[j] = static_cast<int8_t>(r.U8());
  w.b2 = r.I32();
  w.s2 = r.F32();
  w.threshold_logit = r.F32();
  if (!r.ok()) return Status(StatusCode::kDataLoss, "ball classifier: payload truncated");
  if (const char* why = CheckWeights(w)) return Status(StatusCode::kInvalidArgument, why);
  w_ = w;
  id_ = Crc32(view->payload);
  return Status::Ok();
}

// ---- both ----

CandidateVerdict BallCheck::Evaluate(const YuyvImage& image, const ColorLut& lut,
                                     const CandidateShape& c, BallFeatures* features,
                                     float logit_bonus) const {
  CandidateVerdict v;
  if (config_.use_place && geometry_ != nullptr && geometry_->known()) {
    v.place = geometry_->Check(c, v.where);
    if (v.place != PlaceVerdict::kPlausible) {
      v.pass = false;
      v.score = 0;
      return v;
    }
    if (v.where.known) {
      const float raised = std::max(0.0f, v.where.height_m - 2.0f * geometry_->ball_radius_m());
      v.score = std::exp(-raised / config_.raised_prior_m);
    }
  }
  // A near ball low in the view whose centre lies beyond the image border (cut by it, its circle
  // fitted) shows too little of itself for its look to be judged: a calibrated place decides.
  const bool centre_inside =
      image.contains(static_cast<int>(std::lround(c.u_px)), static_cast<int>(std::lround(c.v_px)));
  const bool near_cut = !centre_inside && v.where.known && v.where.height_m < kNearCutMaxHeightM;
  const bool look = looks() && !near_cut;
  if (!look && features == nullptr) return v;
  // A bonus no logit can offset (a tracked candidate's) decides alone, and the probability it
  // gives is 1 in float (1 + e^-x == 1 beyond x = 17): the features are not read.
  constexpr float kSureLogit = 20.0f;
  if (look && features == nullptr &&
      logit_bonus - classifier_->MaxAbsLogit() >
          std::max(classifier_->threshold_logit(), kSureLogit)) {
    v.classified = true;
    v.logit = logit_bonus;
    return v;
  }
  BallFeatures local;
  BallFeatures& feat = features != nullptr ? *features : local;
  ComputeBallFeatures(image, lut, c, feat);
  v.pixels_read = feat.pixels_read;
  if (look) {
    v.classified = true;
    v.logit = classifier_->Logit(feat) + logit_bonus;
    v.pass = v.logit > classifier_->threshold_logit();
    v.score *= 1.0f / (1.0f + std::exp(-v.logit));
  }
  return v;
}

}  // namespace bv
