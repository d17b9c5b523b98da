#include "core/color_lut/color_teach.h"

#include <cmath>

namespace bv {
namespace {

constexpr float kRadToDeg = 57.2957795f;
constexpr float kChromaStep = 0.02f;
constexpr float kMinFitPixels = 100.0f;
constexpr float kHueReachDeg = 60.0f;

int HueBin(float deg) {
  int b = static_cast<int>(std::floor(deg)) % BallColorStats::kHueBins;
  return b < 0 ? b + BallColorStats::kHueBins : b;
}

float Total(const float* bins, int n) {
  float t = 0;
  for (int i = 0; i < n; ++i) t += bins[i];
  return t;
}

// Value (bin centre) below which a fraction q of the histogram lies.
float Percentile(const float* bins, int n, float step, float q) {
  const float target = q * Total(bins, n);
  float acc = 0;
  for (int i = 0; i < n; ++i) {
    acc += bins[i];
    if (acc >= target && acc > 0) return (static_cast<float>(i) + 0.5f) * step;
  }
  return (static_cast<float>(n) - 0.5f) * step;
}

// Sum of the bins whose centre lies in [lo, hi] (unwrapped degrees).
float HueCount(const float* bins, float lo, float hi) {
  float n = 0;
  for (int d = static_cast<int>(std::floor(lo - 0.5f)); d <= static_cast<int>(hi); ++d) {
    const float centre = static_cast<float>(d) + 0.5f;
    if (centre >= lo && centre <= hi) n += bins[HueBin(static_cast<float>(d))];
  }
  return n;
}

// Value (bin centre, unwrapped near `centre`) below which a fraction q of the hue histogram's
// bins within `half` degrees of `centre` lies (the ball's own hues, not what
// else a box holds).
float HuePercentileNear(const float* bins, float centre, float half, float q) {
  const float target = q * HueCount(bins, centre - half, centre + half);
  const int first = static_cast<int>(std::floor(centre - half));
  float acc = 0;
  for (int d = first; d <= static_cast<int>(std::ceil(centre + half)); ++d) {
    const float c = static_cast<float>(d) + 0.5f;
    if (c < centre - half || c > centre + half) continue;
    acc += bins[HueBin(static_cast<float>(d))];
    if (acc >= target && acc > 0) return c;
  }
  return centre + half;
}

// The most common hue, from the histogram summed over a sliding window of +-`half` degrees.
float HueMode(const float* bins, int half) {
  constexpr int n = BallColorStats::kHueBins;
  float sum = 0;
  for (int d = -half; d <= half; ++d) sum += bins[(d + n) % n];
  float best = sum;
  int best_i = 0;
  for (int i = 1; i < n; ++i) {
    sum += bins[(i + half) % n] - bins[(i - half - 1 + n) % n];
    if (sum > best) {
      best = sum;
      best_i = i;
    }
  }
  return static_cast<float>(best_i) + 0.5f;
}

float Clamp(float x, float lo, float hi) { return x < lo ? lo : (x > hi ? hi : x); }

float HueMean(float sum_cos, float sum_sin) { return std::atan2(sum_sin, sum_cos) * kRadToDeg; }

}  // namespace

// atan(k / 64) in degrees, k = 0..64: HueDeg interpolates it (error < 0.002 deg, far below the
// 1 deg bins) at a fraction of atan2f's cost, for the device's online adaptation (128 pixels a
// confirmed pair).
constexpr float kAtanDeg[65] = {
    0.000000f,  0.895174f,  1.789911f,  2.683775f,  3.576334f,  4.467159f,  5.355825f,  6.241914f,
    7.125016f,  8.004729f,  8.880659f,  9.752425f,  10.619655f, 11.481991f, 12.339087f, 13.190611f,
    14.036243f, 14.875682f, 15.708638f, 16.534838f, 17.354025f, 18.165957f, 18.970408f, 19.767169f,
    20.556045f, 21.336859f, 22.109448f, 22.873665f, 23.629378f, 24.376469f, 25.114835f, 25.844388f,
    26.565051f, 27.276763f, 27.979474f, 28.673146f, 29.357754f, 30.033280f, 30.699723f, 31.357085f,
    32.005383f, 32.644640f, 33.274888f, 33.896167f, 34.508523f, 35.112011f, 35.706691f, 36.292630f,
    36.869898f, 37.438572f, 37.998732f, 38.550465f, 39.093859f, 39.629005f, 40.156000f, 40.674940f,
    41.185925f, 41.689058f, 42.184443f, 42.672185f, 43.152390f, 43.625165f, 44.090620f, 44.548861f,
    45.000000f};

float HueDeg(const Yuv& p) {
  const float du = static_cast<float>(p.u) - 128.0f, dv = static_cast<float>(p.v) - 128.0f;
  const float ax = std::fabs(du), ay = std::fabs(dv);
  if (ax == 0.0f && ay == 0.0f) return 0.0f;
  const bool steep = ay > ax;
  const float t = (steep ? ax / ay : ay / ax) * 64.0f;
  const int k = static_cast<int>(t) < 64 ? static_cast<int>(t) : 63;
  float a = kAtanDeg[k] + (t - static_cast<float>(k)) * (kAtanDeg[k + 1] - kAtanDeg[k]);
  if (steep) a = 90.0f - a;
  if (du < 0.0f) a = 180.0f - a;
  return dv < 0.0f ? -a : a;
}

float RelativeChroma(const Yuv& p) {
  const float du = static_cast<float>(p.u) - 128.0f, dv = static_cast<float>(p.v) - 128.0f;
  return std::sqrt(du * du + dv * dv) / (p.y > 0 ? static_cast<float>(p.y) : 1.0f);
}

float UnwrapNear(float deg, float centre) {
  while (deg - centre > 180.0f) deg -= 360.0f;
  while (deg - centre <= -180.0f) deg += 360.0f;
  return deg;
}

// In place: a `*this = BallColorStats()` would build a 4 KB temporary on the stack.
void BallColorStats::Clear() { Scale(0.0f); }

void BallColorStats::Scale(float factor) {
  for (float& x : hue_) x *= factor;
  for (float& x : chroma_dark_) x *= factor;
  for (float& x : chroma_bright_) x *= factor;
  for (float& x : chroma_all_) x *= factor;
  for (float& x : luma_) x *= factor;
  sum_cos_ *= factor;
  sum_sin_ *= factor;
  n_ *= factor;
  n_hue_ *= factor;
}

void BallColorStats::Add(const Yuv& p, float weight) {
  const float du = static_cast<float>(p.u) - 128.0f, dv = static_cast<float>(p.v) - 128.0f;
  const float len = std::sqrt(du * du + dv * dv);
  const float c = len / (p.y > 0 ? static_cast<float>(p.y) : 1.0f);
  const int cb = static_cast<int>(c / kChromaStep);
  const int bin = cb < kChromaBins ? cb : kChromaBins - 1;
  n_ += weight;
  luma_[p.y] += weight;
  chroma_all_[bin] += weight;
  if (p.y <= bright_y_) chroma_dark_[bin] += weight;
  if (p.y >= bright_y_end_) chroma_bright_[bin] += weight;
  if (c >= kHueMinChroma) {
    hue_[HueBin(HueDeg(p))] += weight;
    sum_cos_ += weight * du / len;  // cos and sin of the hue angle
    sum_sin_ += weight * dv / len;
    n_hue_ += weight;
  }
}

float BallColorStats::hue_mean_deg() const { return HueMean(sum_cos_, sum_sin_); }

Status BallColorStats::Fit(const BallColorModel& start, BallColorModel& out) const {
  if (n_ < kMinFitPixels) {
    return Status(StatusCode::kFailedPrecondition,
                  "teach: fewer than 100 ball pixels to learn from");
  }
  if (n_hue_ < 0.5f * kMinFitPixels) {
    return Status(StatusCode::kFailedPrecondition,
                  "teach: the taught pixels are nearly grey (relative chroma below 0.25): not a "
                  "ball colour");
  }
  BallColorModel m = start;
  // Hue: the central 96 % of the pixels within kHueReachDeg of the most common hue, with a margin
  // for what the pixels did not show (4 deg ~ the spread of one surface's pixels from sensor
  // noise at Y 60). Beyond that reach a taught region's pixels are not the ball's surface (the
  // carpet or a robot inside a box, the white of a highlight tinted by the lens), however many.
  const float mode = HueMode(hue_, 10);
  const float h_lo = HuePercentileNear(hue_, mode, kHueReachDeg, 0.02f) - 4.0f;
  const float h_hi = HuePercentileNear(hue_, mode, kHueReachDeg, 0.98f) + 4.0f;
  const float mid = 0.5f * (h_lo + h_hi);
  const float half = 0.5f * (h_hi - h_lo) > 8.0f ? 0.5f * (h_hi - h_lo) : 8.0f;
  m.hue_min_deg = mid - half;
  m.hue_max_deg = mid + half;
  // The chroma floors, like the luma floor, only ever go down from the start model's: taught
  // pixels are the ball's inside, and a far ball is all edge, mixed with what surrounds it (lob
  // 173: the omni ball 8 px across at 5.3 m, a tenth of its pixels below a taught floor of 0.40).
  const auto floor_of = [](const float* bins, float start_floor) {
    if (Total(bins, kChromaBins) < 50.0f) return start_floor;
    const float f = Clamp(0.85f * Percentile(bins, kChromaBins, kChromaStep, 0.03f), 0.12f, 0.5f);
    return f < start_floor ? f : start_floor;
  };
  m.chroma_min = floor_of(chroma_dark_, start.chroma_min);
  const float bright = floor_of(chroma_bright_, start.chroma_min_bright);
  m.chroma_min_bright = bright < m.chroma_min ? bright : m.chroma_min;
  m.chroma_max =
      Clamp(1.3f * Percentile(chroma_all_, kChromaBins, kChromaStep, 0.995f), 1.0f, 4.0f);
  // Luma is what shade changes: the floor only ever goes down from the start model's (pixels
  // that never showed the ball in deep shade must not exclude it there).
  const float y_floor = Percentile(luma_, kLumaBins, 1.0f, 0.005f) - 8.0f;
  m.y_min = static_cast<uint8_t>(
      Clamp(y_floor < static_cast<float>(start.y_min) ? y_floor : start.y_min, 12.0f, 96.0f));
  BV_TRY(ValidateBallColorModel(m));
  out = m;
  return Status::Ok();
}

void HueHistogram::Clear() {
  for (float& b : bins) b = 0.0f;
}

void HueHistogram::AddIfInModelIgnoringHue(const BallColorTest& test, const Yuv& p, float weight) {
  if (test.ContainsIgnoringHue(p.y, p.u, p.v)) bins[HueBin(HueDeg(p))] += weight;
}

void NarrowHueWindow(const BallColorStats& ball, const HueHistogram& background,
                     float background_weight, BallColorModel& m) {
  // The ball's hues are those inside the fitted window (what a box holds beyond it is not the
  // ball); percentiles unwrapped near the window's centre, so lo and hi compare with its bounds.
  const float centre = 0.5f * (m.hue_min_deg + m.hue_max_deg);
  const float half = 0.5f * (m.hue_max_deg - m.hue_min_deg);
  const float total = HueCount(ball.hue(), m.hue_min_deg, m.hue_max_deg);
  if (total < kMinFitPixels || Total(background.bins, BallColorStats::kHueBins) <= 0) return;
  // Never into the central 90 % of the ball's hues, and 2 deg beyond the percentile: a window
  // fitted to the frames taught from must still hold the ball in the light of other frames.
  const float qs_lo[] = {-1, 0.005f, 0.01f, 0.02f, 0.03f, 0.05f};
  const float qs_hi[] = {-1, 0.995f, 0.99f, 0.98f, 0.97f, 0.95f};
  float best_lo = m.hue_min_deg, best_hi = m.hue_max_deg, best = 3.4e38f;
  for (float ql : qs_lo) {
    float lo = m.hue_min_deg;
    if (ql >= 0) {
      const float p = HuePercentileNear(ball.hue(), centre, half, ql) - 2.0f;
      lo = p > m.hue_min_deg ? p : m.hue_min_deg;
    }
    for (float qh : qs_hi) {
      float hi = m.hue_max_deg;
      if (qh >= 0) {
        const float p = HuePercentileNear(ball.hue(), centre, half, qh) + 2.0f;
        hi = p < m.hue_max_deg ? p : m.hue_max_deg;
      }
      if (hi - lo < 6.0f) continue;
      const float cost = total - HueCount(ball.hue(), lo, hi) +
                         background_weight * HueCount(background.bins, lo, hi);
      if (cost < best) {
        best = cost;
        best_lo = lo;
        best_hi = hi;
      }
    }
  }
  m.hue_min_deg = best_lo;
  m.hue_max_deg = best_hi;
}

void FieldCheck::Add(const BallColorTest& test, const Yuv& p) {
  const bool taken = test.Contains(p.y, p.u, p.v);
  ++all;
  all_taken += taken;
  const ColorClass bg = BackgroundClass(p.y, p.u, p.v);
  if (bg == ColorClass::kField || bg == ColorClass::kLine) {
    ++field;
    field_taken += taken;
  }
}

namespace {

constexpr float kSeedHueTolDeg = 15.0f;
constexpr float kSeedMinChroma = 0.10f;
constexpr int kMaxRunPx = 160;
constexpr int kBackgroundStride = 8;
constexpr float kBackgroundWeight = kBackgroundStride * kBackgroundStride;

// The seed pixel's own colour, relaxed: what the ball around it looks like in sun and shade.
struct SeedTest {
  float hue_deg;
  bool operator()(const Yuv& p) const {
    if (p.y < 12 || RelativeChroma(p) < kSeedMinChroma) return false;
    const float d = UnwrapNear(HueDeg(p), hue_deg) - hue_deg;
    return d <= kSeedHueTolDeg && d >= -kSeedHueTolDeg;
  }
};

struct Disc {
  float u, v, r;
};

// From the target along 8 rays while the seed colour holds: the centre (between opposite run
// ends) and the radius (median run), clamped to 1.5 x a known radius.
Status MeasureBall(const YuyvImage& img, const TeachTarget& t, Disc& out) {
  const int u0 = static_cast<int>(t.u_px + 0.5f), v0 = static_cast<int>(t.v_px + 0.5f);
  if (!img.contains(u0, v0))
    return Status(StatusCode::kNotFound, "teach: the point is outside the image");
  const Yuv seed = img.at(u0, v0);
  if (seed.y < 12 || RelativeChroma(seed) < 0.15f) {
    return Status(StatusCode::kNotFound,
                  "teach: the pixel at the point is grey or dark, not a ball");
  }
  const SeedTest test{HueDeg(seed)};
  static constexpr int kDu[8] = {1, 1, 0, -1, -1, -1, 0, 1}, kDv[8] = {0, 1, 1, 1, 0, -1, -1, -1};
  float run[8];
  for (int k = 0; k < 8; ++k) {
    int n = 0;
    while (n < kMaxRunPx && img.contains(u0 + (n + 1) * kDu[k], v0 + (n + 1) * kDv[k]) &&
           test(img.at(u0 + (n + 1) * kDu[k], v0 + (n + 1) * kDv[k]))) {
      ++n;
    }
    run[k] = (static_cast<float>(n) + 0.5f) * ((kDu[k] != 0 && kDv[k] != 0) ? 1.41421f : 1.0f);
  }
  out.u = t.u_px + 0.5f * (run[0] - run[4]);
  out.v = t.v_px + 0.5f * (run[2] - run[6]);
  float r[4];
  for (int k = 0; k < 4; ++k) r[k] = 0.5f * (run[k] + run[k + 4]);  // diameters / 2
  for (int i = 1; i < 4; ++i) {                                     // sort 4
    for (int j = i; j > 0 && r[j - 1] > r[j]; --j) {
      const float x = r[j];
      r[j] = r[j - 1];
      r[j - 1] = x;
    }
  }
  out.r = 0.5f * (r[1] + r[2]);
  if (t.radius_px > 0 && out.r > 1.5f * t.radius_px) out.r = 1.5f * t.radius_px;
  if (out.r < 2.0f)
    return Status(StatusCode::kNotFound,
                  "teach: the ball-coloured region at the point is under 4 px across");
  if (out.r >= 0.9f * kMaxRunPx)
    return Status(StatusCode::kNotFound, "teach: the region at the point is larger than a ball");
  return Status::Ok();
}

template <typename F>
void ForBackground(const YuyvImage& img, const Disc& d, F&& f) {
  const float keep_out = 2.0f * d.r + 6.0f;
  for (int v = 3; v < img.height; v += kBackgroundStride) {
    for (int u = (v / kBackgroundStride) % kBackgroundStride; u < img.width;
         u += kBackgroundStride) {
      const float du = static_cast<float>(u) - d.u, dv = static_cast<float>(v) - d.v;
      if (du * du + dv * dv > keep_out * keep_out) f(img.at(u, v));
    }
  }
}

}  // namespace

Status TeachFromImages(const YuyvImage images[2], const TeachTarget targets[2],
                       const BallColorModel& start, TeachWorkspace& ws, BallColorModel& out,
                       int& failed_camera) {
  failed_camera = -1;
  ws.ball.Clear();
  ws.background.Clear();
  Disc disc[2] = {};
  bool used[2] = {false, false};
  for (int c = 0; c < 2; ++c) {
    if (!targets[c].valid || images[c].data == nullptr) continue;
    failed_camera = c;
    BV_TRY(MeasureBall(images[c], targets[c], disc[c]));
    const Disc& d = disc[c];
    const SeedTest test{HueDeg(images[c].at(static_cast<int>(targets[c].u_px + 0.5f),
                                            static_cast<int>(targets[c].v_px + 0.5f)))};
    // The ball inside 0.85 of its radius: the outline mixes with what is around it.
    const float rin = 0.85f * d.r;
    for (int v = static_cast<int>(d.v - rin); v <= static_cast<int>(d.v + rin) + 1; ++v) {
      for (int u = static_cast<int>(d.u - rin); u <= static_cast<int>(d.u + rin) + 1; ++u) {
        const float du = static_cast<float>(u) - d.u, dv = static_cast<float>(v) - d.v;
        if (!images[c].contains(u, v) || du * du + dv * dv > rin * rin) continue;
        const Yuv p = images[c].at(u, v);
        if (test(p)) ws.ball.Add(p);
      }
    }
    used[c] = true;
  }
  if (!used[0] && !used[1]) {
    return Status(StatusCode::kNotFound, "teach: no camera image at the point");
  }
  BV_TRY(ws.ball.Fit(start, out));
  // Narrow the hue window against ball-coloured background, then check the field.
  const BallColorTest fitted(out);
  for (int c = 0; c < 2; ++c) {
    if (!used[c]) continue;
    ForBackground(images[c], disc[c],
                  [&](const Yuv& p) { ws.background.AddIfInModelIgnoringHue(fitted, p); });
  }
  NarrowHueWindow(ws.ball, ws.background, kBackgroundWeight, out);
  const BallColorTest narrowed(out);
  FieldCheck check;
  for (int c = 0; c < 2; ++c) {
    if (used[c]) ForBackground(images[c], disc[c], [&](const Yuv& p) { check.Add(narrowed, p); });
  }
  failed_camera = -1;
  if (check.field_taken_fraction() > kMaxFieldTaken) {
    return Status(StatusCode::kOutOfRange,
                  "teach: the taught colour would take the field's or lines' pixels");
  }
  return Status::Ok();
}

}  // namespace bv
