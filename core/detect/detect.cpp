#include "core/detect/detect.h"

#include <algorithm>
#include <cmath>

#include "core/common/round.h"

namespace bv {

Status BallFinder::Init(const ScanlineTableBase& scanlines, const BallFinderConfig& config) {
  scan_ = nullptr;
  if (!scanlines.built()) {
    return Status(StatusCode::kFailedPrecondition, "BallFinder::Init: scanline table not built");
  }
  if (config.attention_samples < 0 || config.attention_samples > kMaxAttentionSamples ||
      !(config.min_roundness >= 0.0f && config.min_roundness <= 1.0f) ||
      !(config.min_hull_roundness >= 0.0f && config.min_hull_roundness <= 1.0f) ||
      !(config.min_width_ratio >= 0.0f && config.min_width_ratio <= 1.0f) ||
      !(config.min_area_px >= 1.0f) || !(config.min_cut_area_px >= 0.0f) || config.prng_seed == 0 ||
      config.min_arc_sectors < 1 || config.min_arc_sectors > kCircleSectors ||
      config.min_arc_sectors_sized < 1 || config.min_arc_sectors_sized > kCircleSectors) {
    return Status(
        StatusCode::kInvalidArgument,
        "BallFinder::Init: attention_samples > 256, a roundness or width ratio outside 0..1, "
        "min_area < 1, min_cut_area < 0, prng_seed 0 or min_arc_sectors outside 1..16");
  }
  scan_ = &scanlines;
  config_ = config;
  regions_.set_min_keep_area(config.min_area_px);
  rng_ = config.prng_seed;
  return Status::Ok();
}

namespace {
constexpr int kContextSamples = 16;
// Unit circle in 16 steps, Q8.
constexpr int16_t kRingCos[kContextSamples] = {256,  237,  181,  98,  0, -98, -181, -237,
                                               -256, -237, -181, -98, 0, 98,  181,  237};
constexpr int16_t kRingSin[kContextSamples] = {0, 98,  181,  237,  256,  237,  181,  98,
                                               0, -98, -181, -237, -256, -237, -181, -98};

// Fraction of ring samples just outside the region that are field or line coloured.
float FieldContext(const YuyvImage& image, const ColorLut& lut, const Region& r) {
  const float radius =
      0.5f * static_cast<float>(std::max(r.u_max - r.u_min, r.v_max - r.v_min)) + 3.0f;
  const int rad_q8 = static_cast<int>(radius * 256.0f);
  const int cu = static_cast<int>(r.cu_px + 0.5f), cv = static_cast<int>(r.cv_px + 0.5f);
  int n = 0;
  for (int i = 0; i < kContextSamples; ++i) {
    const ColorClass c = ClassAt(image, lut, cu + ((kRingCos[i] * rad_q8) >> 16),
                                 cv + ((kRingSin[i] * rad_q8) >> 16));
    n += c == ColorClass::kField || c == ColorClass::kLine;
  }
  return static_cast<float>(n) / kContextSamples;
}

bool CutByBorder(const Region& r, int width, int height) {
  return r.u_min <= 0 || r.v_min <= 0 || r.u_max >= width - 1 || r.v_max >= height - 1;
}
}  // namespace

// The shape test, then the field test (in reject mode an outside region fails).
bool BallFinder::Passes(const Region& r, bool& in_field) const {
  in_field = true;
  const bool clean = r.roundness >= config_.min_roundness;
  const bool compact =
      r.hull_roundness >= config_.min_hull_roundness && r.width_ratio >= config_.min_width_ratio;
  const bool circle = r.arc_sectors > 0;
  if (r.area_px < config_.min_area_px || !(clean || compact || circle)) return false;
  if (r.area_px < config_.min_cut_area_px && CutByBorder(r, scan_->width(), scan_->height())) {
    return false;
  }
  in_field = config_.field == nullptr ||
             config_.field->Inside(r.cu_px, r.cv_px, std::sqrt(r.area_px / 3.14159265f));
  return in_field || !reject_outside_;
}

CandidateShape BallFinder::ShapeOf(const Region& r) {
  CandidateShape c;
  c.u_px = r.cu_px;
  c.v_px = r.cv_px;
  c.area_px = r.area_px;
  c.radius_px = std::sqrt(r.area_px / 3.14159265f);
  c.roundness = r.roundness;
  c.hull_roundness = r.hull_roundness;
  c.width_ratio = r.width_ratio;
  c.u_min = r.u_min, c.v_min = r.v_min, c.u_max = r.u_max, c.v_max = r.v_max;
  c.arc_sectors = r.arc_sectors;
  return c;
}

namespace {
BallDetection DetectionOf(const Region& r, float confidence) {
  BallDetection d;
  d.found = true;
  d.arc_sectors = r.arc_sectors;
  d.u_px = r.cu_px;
  d.v_px = r.cv_px;
  d.area_px = r.area_px;
  d.radius_px = std::sqrt(r.area_px / 3.14159265f);
  d.roundness = r.hull_roundness;
  d.confidence = confidence;
  return d;
}

// Inserts `d` into the list out[0..n), kept in descending `keys`; the last drops out when the list
// is full. Returns the new count.
size_t InsertByKey(std::span<BallDetection> out, float* keys, size_t n, const BallDetection& d,
                   float key) {
  size_t k = n < out.size() ? n++ : out.size();
  while (k > 0 && keys[k - 1] < key) {
    if (k < out.size()) {
      out[k] = out[k - 1];
      keys[k] = keys[k - 1];
    }
    --k;
  }
  if (k < out.size()) {
    out[k] = d;
    keys[k] = key;
  }
  return n;
}
}  // namespace

size_t BallFinder::Ranked(std::span<BallDetection> out) const {
  const auto regions = regions_.regions();
  size_t n = 0;
  float keys[kMaxRegions];
  for (size_t i = 0; i < regions.size(); ++i) {
    if (rank_key_[i] < 0.0f) continue;
    // The chosen region ranks first whatever its key (a prediction chose it).
    const float key = static_cast<int>(i) == chosen_ ? 1e30f : rank_key_[i];
    n = InsertByKey(out.first(std::min(out.size(), kMaxRegions)), keys, n,
                    DetectionOf(regions[i], rank_key_[i]), key);
  }
  if (chosen_ >= 0 && n > 0) {
    // The chosen ball as Find reported it (soft centroid).
    out[0].u_px = chosen_u_;
    out[0].v_px = chosen_v_;
  }
  return n;
}

size_t BallFinder::Candidates(std::span<BallDetection> out) const {
  size_t n = 0;
  float keys[kMaxRegions];
  const auto regions = regions_.regions();
  for (size_t i = 0; i < regions.size(); ++i) {
    const Region& r = regions[i];
    bool in_field = true;
    if (r.hole || !Passes(r, in_field) || refused_[i] != 0) continue;
    // Largest first.
    n = InsertByKey(out.first(std::min(out.size(), kMaxRegions)), keys, n,
                    DetectionOf(r, r.hull_roundness), r.area_px);
  }
  return n;
}

// A region that is not a clean disc gets the circle of its outline when one spans enough of it:
// the ball's own centre and radius, where the centroid is pulled towards whatever it merged with
// or away from what hides it. A nearly whole circle on a region no larger keeps the centroid (it
// averages every pixel).
void BallFinder::FitCircles(const Prediction* prediction, int image_width, int image_height) {
  constexpr float kCleanHull = 0.9f, kCleanWidth = 0.85f;
  constexpr int kWholeSectors = 14;
  // Below this an outline has too few pixels to show a circle's curvature (a speck, a far ball).
  constexpr float kMinCircleRadiusPx = 5.0f;
  constexpr float kMergedArea = 1.2f;
  const bool sized = prediction != nullptr && prediction->radius_px > 0.0f;
  CircleSearch search;
  if (sized) {
    // The predicted ball: its radius within the apparent-size ratio the pipeline allows, its
    // centre within a radius of the prediction.
    search.r_min_px = 0.8f * prediction->radius_px;
    search.r_max_px = 1.25f * prediction->radius_px + 1.0f;
    search.min_sectors = config_.min_arc_sectors_sized;
    search.expected_radius_px = prediction->radius_px;
    search.cu_px = prediction->u_px;
    search.cv_px = prediction->v_px;
    search.max_centre_px = std::max(prediction->radius_px, 6.0f);
  } else {
    search.r_min_px = kMinCircleRadiusPx;
    search.min_sectors = config_.min_arc_sectors;
  }
  search.image_width = image_width;
  search.image_height = image_height;
  const float reach = search.max_centre_px + search.r_max_px + 2.0f;
  int fits = 0;
  const auto regions = regions_.regions();
  for (size_t i = 0; i < regions.size() && fits < kMaxCircleFits; ++i) {
    const Region& r = regions[i];
    // Cut by the image border: the centroid is the visible cap's, however clean its outline.
    const bool at_border = CutByBorder(r, image_width, image_height);
    if (r.hole || r.area_px < config_.min_area_px ||
        (!at_border && r.hull_roundness >= kCleanHull && r.width_ratio >= kCleanWidth)) {
      continue;
    }
    // Nowhere near the predicted ball: no circle there could be it.
    if (sized && (static_cast<float>(r.u_min) > search.cu_px + reach ||
                  static_cast<float>(r.u_max) < search.cu_px - reach ||
                  static_cast<float>(r.v_min) > search.cv_px + reach ||
                  static_cast<float>(r.v_max) < search.cv_px - reach)) {
      continue;
    }
    ++fits;
    if (!sized) {
      // A cut ball's circle is wider than what is left of it (up to its chord: a 60 deg cap).
      search.r_max_px = (at_border ? 1.0f : 0.5f) *
                            static_cast<float>(std::max(r.u_max - r.u_min, r.v_max - r.v_min)) +
                        1.0f;
    }
    CircleFit fit;
    if (!regions_.FitCircle(i, search, fit)) continue;
    const float disc = 3.14159265f * fit.radius_px * fit.radius_px;
    if (fit.sectors < kWholeSectors || r.area_px > kMergedArea * disc) regions_.SetCircle(i, fit);
  }
}

uint32_t BallFinder::NextRandom() {  // xorshift32
  rng_ ^= rng_ << 13;
  rng_ ^= rng_ >> 17;
  rng_ ^= rng_ << 5;
  return rng_;
}

void BallFinder::Seed(const YuyvImage& image, const ColorLut& lut, int u, int v,
                      FrontEndStats& stats) {
  ++stats.seeds;
  const SeedOutcome o = regions_.TraceSeed(image, lut, ColorClass::kBall, u, v);
  if (o == SeedOutcome::kNewRegion) ++stats.regions;
}

Status BallFinder::Find(const YuyvImage& image, const ColorLut& lut, const Prediction* prediction,
                        BallDetection& out, FrontEndStats& stats) {
  out = BallDetection{};
  stats = FrontEndStats{};
  regions_.Clear();
  attention_count_ = 0;
  chosen_ = -1;
  if (scan_ == nullptr)
    return Status(StatusCode::kFailedPrecondition, "BallFinder: not initialised");
  if (image.data == nullptr || image.width != scan_->width() || image.height != scan_->height() ||
      image.stride_bytes < 2 * image.width) {
    return Status(
        StatusCode::kInvalidArgument,
        "BallFinder::Find: frame size differs from the scanline table (or null/short stride)");
  }
  // 1. Monte-Carlo attention first, so the predicted ball is traced before clutter can fill the
  //    region capacity.
  const uint32_t attention_reads = Attend(image, lut, prediction, stats);
  regions_.ProtectTraced();  // clutter the scanlines find later cannot replace them
  stats.attention_samples = attention_reads;
  // 2. Scanlines, row-major: a seed at the first ball sample of every run along a row. The chroma
  //    box rejects most samples before the table is read.
  const PairChromaTest box(config_.ball_box);
  bool in_run = false;  // the previous kept sample was ball
  // The loop hints the cache ahead (a fresh frame is cold).
  scan_->ForEachKeptPair(
      image.data, image.stride_bytes, box, [&](int u, int v, uint32_t w, bool follows) {
        const auto y = static_cast<uint8_t>(w >> ((u & 1) * 16));
        const bool ball = lut.Classify(y, static_cast<uint8_t>(w >> 8),
                                       static_cast<uint8_t>(w >> 24)) == ColorClass::kBall;
        if (ball && !(follows && in_run)) Seed(image, lut, u, v, stats);
        in_run = ball;
      });
  stats.scan_pixels = scan_->pixel_count();
  if (config_.fit_circles) FitCircles(prediction, image.width, image.height);
  // 3. Ball choice.
  const Choice choice = ChooseBall(image, lut, prediction, stats);
  stats.candidates = choice.candidates;
  stats.holes = choice.holes;
  stats.overflows = regions_.overflows();
  stats.small = regions_.dropped_small();
  stats.pixels_read += stats.scan_pixels + attention_reads + regions_.pixels_read();
  if (choice.best < 0) return Status::Ok();
  chosen_ = choice.best;
  const Region& ball = regions_.regions()[static_cast<size_t>(choice.best)];
  Report(ball, choice, prediction, out);
  if (config_.soft_centroid) SoftCentroid(image, lut, ball, out);
  chosen_u_ = out.u_px;
  chosen_v_ = out.v_px;
  return Status::Ok();
}

bool BallFinder::InsideTracedBox(int u, int v) const {
  for (const Region& r : regions_.regions()) {
    if (!r.hole && u > r.u_min && u < r.u_max && v > r.v_min && v < r.v_max) return true;
  }
  return false;
}

// Normal samples around the prediction from the sum of four 12-bit uniforms (Irwin-Hall, no
// libm); a seed at every ball-coloured one. Returns the pixels read.
uint32_t BallFinder::Attend(const YuyvImage& image, const ColorLut& lut,
                            const Prediction* prediction, FrontEndStats& stats) {
  uint32_t attention_reads = 0;
  if (prediction == nullptr || !std::isfinite(prediction->u_px) ||
      !std::isfinite(prediction->v_px) || !std::isfinite(prediction->sigma_px) ||
      !(prediction->sigma_px > 0.0f)) {
    return attention_reads;
  }
  constexpr float kInvSigma = 1.0f / 2364.9f;  // sd of the sum of four U[0, 4096)
  for (int i = 0; i < config_.attention_samples; ++i) {
    float z[2];
    for (float& zi : z) {
      const uint32_t a = NextRandom(), b = NextRandom();
      const int32_t sum =
          static_cast<int32_t>((a & 4095) + ((a >> 16) & 4095) + (b & 4095) + ((b >> 16) & 4095));
      zi = static_cast<float>(sum - 8192) * kInvSigma;
    }
    const int u = RoundToInt(prediction->u_px + prediction->sigma_px * z[0]);
    const int v = RoundToInt(prediction->v_px + prediction->sigma_px * z[1]);
    if (!image.contains(u, v)) continue;
    attention_u_[attention_count_] = static_cast<int16_t>(u);
    attention_v_[attention_count_] = static_cast<int16_t>(v);
    ++attention_count_;
    ++attention_reads;
    // A sample inside the box of a region traced already is almost always in that region: its
    // walk to the boundary (up to the ball's width, every pixel classified) and the contour check
    // are skipped. The scanlines still seed anything else inside the box.
    if (ClassAt(image, lut, u, v) == ColorClass::kBall && !InsideTracedBox(u, v)) {
      Seed(image, lut, u, v, stats);
    }
  }
  return attention_reads;
}

// Of the regions that pass: inside the field, then nearest the prediction, else the most ball-like
// shape (ShapeEvidence) with field colour around it (a ball on the carpet; cheap: 16 lookups on a
// ring).
BallFinder::Choice BallFinder::ChooseBall(const YuyvImage& image, const ColorLut& lut,
                                          const Prediction* prediction, FrontEndStats& stats) {
  const auto regions = regions_.regions();
  const bool checked = config_.check != nullptr && config_.check->active();
  Choice choice;
  for (size_t i = 0; i < regions.size(); ++i) {
    const Region& r = regions[i];
    rank_key_[i] = -1.0f;
    refused_[i] = static_cast<uint8_t>(Refusal::kShapeOrField);
    if (r.hole) {
      ++choice.holes;
      continue;
    }
    bool in_field = true;
    if (!Passes(r, in_field)) {
      stats.outside_field += !in_field;
      continue;
    }
    refused_[i] = static_cast<uint8_t>(Refusal::kNone);
    float score = 1;
    bool classified = false;
    if (checked) {
      float bonus = 0;
      if (prediction != nullptr) {
        const float du = r.cu_px - prediction->u_px, dv = r.cv_px - prediction->v_px;
        const float s2 = 9.0f * prediction->sigma_px * prediction->sigma_px;
        if (du * du + dv * dv <= s2) bonus = config_.tracked_logit_bonus;
      }
      const CandidateVerdict v = config_.check->Evaluate(image, lut, ShapeOf(r), nullptr, bonus);
      stats.pixels_read += v.pixels_read;
      if (!v.pass) {
        const bool place = v.place != PlaceVerdict::kPlausible;
        stats.refused_place += place;
        stats.refused_look += !place;
        refused_[i] = static_cast<uint8_t>(place ? Refusal::kPlace : Refusal::kLook);
        continue;
      }
      score = v.score;
      classified = v.classified;
    }
    ++choice.candidates;
    // The classifier's probability when it ran (an even chance for a candidate it cannot judge),
    // else the shape and the field around it; times the place check's prior (1 without one).
    float evidence = score;
    if (checked && config_.check->looks()) {
      if (!classified) evidence *= 0.5f;
    } else {
      evidence *= ShapeEvidence(r) * (0.2f + FieldContext(image, lut, r));
      stats.pixels_read += kContextSamples;
    }
    rank_key_[i] = evidence;
    float key = evidence;
    if (prediction != nullptr) {
      const float du = r.cu_px - prediction->u_px, dv = r.cv_px - prediction->v_px;
      key = -(du * du + dv * dv);
    }
    if (choice.best < 0 || (in_field && !choice.in_field) ||
        (in_field == choice.in_field && key > choice.key)) {
      choice.best = static_cast<int>(i);
      choice.key = key;
      choice.in_field = in_field;
    }
  }
  return choice;
}

// The chosen region as the detection. Confidence: roundness, discounted when the field test
// failed or was unavailable, when other candidates compete, and with distance from the prediction.
void BallFinder::Report(const Region& r, const Choice& choice, const Prediction* prediction,
                        BallDetection& out) const {
  out = DetectionOf(r, 0.0f);
  float conf = r.hull_roundness;
  if (config_.field != nullptr && !choice.in_field) conf *= 0.5f;
  if (choice.candidates > 1) {
    conf *= 1.0f / (1.0f + 0.25f * static_cast<float>(choice.candidates - 1));
  }
  if (prediction != nullptr && prediction->sigma_px > 0.0f) {
    const float d2 = -choice.key / (9.0f * prediction->sigma_px * prediction->sigma_px);
    conf *= 1.0f / (1.0f + d2);
  }
  out.confidence = conf;
}

namespace {
// SoftCentroid's window as one 32-bit mask per row (bit x: pixel x of the row is ball).
struct RowMasks {
  uint32_t ball[BallFinder::kSoftWindow + 2] = {};  // rows -1 .. h, the outer two empty
  uint32_t Row(int y) const { return ball[y + 1]; }
  bool Ball(int x, int y) const { return x >= 0 && x < 32 && ((Row(y) >> x) & 1u); }
  static uint32_t Spread(uint32_t m) { return m | (m << 1) | (m >> 1); }
  // Ball, or an 8-neighbour of a ball pixel: the pixels a boundary can split.
  uint32_t Near(int y) const { return Spread(Row(y - 1)) | Spread(Row(y)) | Spread(Row(y + 1)); }
  // Ball with all four 4-neighbours ball.
  uint32_t Interior(int y) const {
    const uint32_t m = Row(y);
    return m & (m << 1) & (m >> 1) & Row(y - 1) & Row(y + 1);
  }
  bool NearAt(int x, int y) const {
    return x >= 0 && x < 32 && y >= 0 && y < BallFinder::kSoftWindow && ((Near(y) >> x) & 1u);
  }
  bool InteriorAt(int x, int y) const {
    return x >= 0 && x < 32 && y >= 0 && y < BallFinder::kSoftWindow && ((Interior(y) >> x) & 1u);
  }
};

float Dot3(const float* a, const float* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
void Load(const Yuv& p, float* out) { out[0] = p.y, out[1] = p.u, out[2] = p.v; }
}  // namespace

// A pixel on the ball's outline is a mix of ball and what lies behind it. The binary class keeps
// a mixed pixel against a grey background down to ~40 % ball and drops it against the green
// field below ~65 %, so the centroid moves away from the field. Here every pixel of the boundary
// band (ball pixels with a non-ball 4-neighbour, non-ball pixels touching the ball) weighs its
// ball fraction: its colour unmixed, along the line in YUV from the background just outside it
// (outward from the centroid) to the ball just inside. Interior pixels weigh 1. Cut balls,
// fitted circles and balls wider than the window (near ones, whose bias costs little in 3D)
// keep what they have.
void BallFinder::SoftCentroid(const YuyvImage& image, const ColorLut& lut, const Region& r,
                              BallDetection& out) const {
  constexpr int kMargin = 2, kSteps = 4;
  constexpr float kOffLine = 0.0625f;  // (a quarter of the ball-background distance)^2
  const int u0 = r.u_min - kMargin, v0 = r.v_min - kMargin;
  const int w = r.u_max - r.u_min + 1 + 2 * kMargin, h = r.v_max - r.v_min + 1 + 2 * kMargin;
  if (r.arc_sectors > 0 || w > kSoftWindow || h > kSoftWindow || u0 - kSteps < 0 ||
      v0 - kSteps < 0 || u0 + w + kSteps > image.width || v0 + h + kSteps > image.height) {
    return;
  }
  RowMasks mask;
  float mean[3] = {0, 0, 0};
  int n_ball = 0;
  for (int y = 0; y < h; ++y) {
    uint32_t row = 0;
    for (int x = 0; x < w; ++x) {
      const Yuv p = image.at(u0 + x, v0 + y);
      if (lut.Classify(p.y, p.u, p.v) != ColorClass::kBall) continue;
      row |= 1u << x;
      mean[0] += p.y, mean[1] += p.u, mean[2] += p.v;
      ++n_ball;
    }
    mask.ball[y + 1] = row;
  }
  if (n_ball == 0) return;
  for (float& m : mean) m /= static_cast<float>(n_ball);
  const float cx = r.cu_px - static_cast<float>(u0), cy = r.cv_px - static_cast<float>(v0);
  float sw = 0, su = 0, sv = 0;
  for (int y = 0; y < h; ++y) {
    const uint32_t inner = mask.Interior(y);
    for (uint32_t m = inner; m != 0; m &= m - 1) {
      sw += 1.f;
      su += static_cast<float>(__builtin_ctz(m));
      sv += static_cast<float>(y);
    }
    for (uint32_t m = mask.Near(y) & ~inner & ((w < 32 ? (1u << w) : 0u) - 1u); m != 0;
         m &= m - 1) {
      const int x = __builtin_ctz(m);
      const float dx = static_cast<float>(x) - cx, dy = static_cast<float>(y) - cy;
      const float len = std::sqrt(dx * dx + dy * dy);
      const float ex = len > 0.f ? dx / len : 1.f, ey = len > 0.f ? dy / len : 0.f;
      // Background: the first pixel outward off the band; ball: the first interior one inward.
      const float* ball = mean;
      float bg[3] = {0, 0, 0}, in[3] = {0, 0, 0};
      bool have_bg = false;
      for (int k = 1; k <= kSteps && !have_bg; ++k) {
        const int bx = x + RoundToInt(static_cast<float>(k) * ex);
        const int by = y + RoundToInt(static_cast<float>(k) * ey);
        if (mask.NearAt(bx, by)) continue;
        Load(image.at(u0 + bx, v0 + by), bg);
        have_bg = true;
      }
      for (int k = 1; k <= kSteps; ++k) {
        const int ix = x - RoundToInt(static_cast<float>(k) * ex);
        const int iy = y - RoundToInt(static_cast<float>(k) * ey);
        if (!mask.InteriorAt(ix, iy)) continue;
        Load(image.at(u0 + ix, v0 + iy), in);
        ball = in;
        break;
      }
      float weight = mask.Ball(x, y) ? 1.f : 0.f;
      if (have_bg) {
        float p[3];
        Load(image.at(u0 + x, v0 + y), p);
        const float d[3] = {ball[0] - bg[0], ball[1] - bg[1], ball[2] - bg[2]};
        const float e[3] = {p[0] - bg[0], p[1] - bg[1], p[2] - bg[2]};
        const float dd = Dot3(d, d), ed = Dot3(e, d);
        // Unmixed only where the pixel is a mix of these two colours: not too alike (10 levels
        // apart), the pixel near the line between them (a third colour, a shadow strip between
        // the ball and a white line, is no mix of the two). Else the class decides.
        const float off_line = Dot3(e, e) - ed * ed / std::max(dd, 1.f);
        if (dd >= 100.f && off_line <= std::max(kOffLine * dd, 100.f)) {
          weight = std::clamp(ed / dd, 0.f, 1.f);
        }
      }
      sw += weight;
      su += weight * static_cast<float>(x);
      sv += weight * static_cast<float>(y);
    }
  }
  if (!(sw > 0.f)) return;
  out.u_px = static_cast<float>(u0) + su / sw;
  out.v_px = static_cast<float>(v0) + sv / sw;
}
}  // namespace bv
