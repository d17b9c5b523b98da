#include "core/color_lut/color_adapt.h"

#include <cmath>

namespace bv {
namespace {

constexpr float kWidenDeg = 10.0f;
constexpr int kRingSamples = 8;
constexpr float kRingCos[kRingSamples] = {1, 0.7071f, 0, -0.7071f, -1, -0.7071f, 0, 0.7071f};
constexpr float kRingSin[kRingSamples] = {0, 0.7071f, 1, 0.7071f, 0, -0.7071f, -1, -0.7071f};

// The smallest model holding both: the hue window spanning both, the lower floors, the higher
// ceiling, the wider luma range (the start model's knee).
BallColorModel Union(const BallColorModel& a, const BallColorModel& b) {
  BallColorModel u = a;
  u.hue_min_deg = std::fmin(a.hue_min_deg, b.hue_min_deg);
  u.hue_max_deg = std::fmax(a.hue_max_deg, b.hue_max_deg);
  u.chroma_min = std::fmin(a.chroma_min, b.chroma_min);
  u.chroma_min_bright = std::fmin(a.chroma_min_bright, b.chroma_min_bright);
  u.chroma_max = std::fmax(a.chroma_max, b.chroma_max);
  u.y_min = a.y_min < b.y_min ? a.y_min : b.y_min;
  u.y_max = a.y_max > b.y_max ? a.y_max : b.y_max;
  u.chroma_abs_min = a.chroma_abs_min < b.chroma_abs_min ? a.chroma_abs_min : b.chroma_abs_min;
  return u;
}

bool Same(const BallColorModel& a, const BallColorModel& b) {
  return a.hue_min_deg == b.hue_min_deg && a.hue_max_deg == b.hue_max_deg &&
         a.chroma_min == b.chroma_min && a.chroma_min_bright == b.chroma_min_bright &&
         a.chroma_max == b.chroma_max && a.bright_y == b.bright_y &&
         a.bright_y_end == b.bright_y_end && a.y_min == b.y_min && a.y_max == b.y_max &&
         a.chroma_abs_min == b.chroma_abs_min;
}

}  // namespace

void ColorAdapter::Start(const BallColorModel& model, ColorLut* table,
                         const ColorAdaptConfig& config) {
  config_ = config;
  table_ = table;
  start_ = model_ = pending_ = model;
  ball_.Clear();
  guard_count_ = guard_next_ = 0;
  frames_since_refit_ = 0;
  next_row_ = -1;
  stats_ = ColorAdaptStats{};
}

void ColorAdapter::Observe(const YuyvImage& image, const BallDetection& det) {
  if (table_ == nullptr || !det.found || !(det.radius_px >= 2.0f)) return;
  BallColorModel wide = model_;
  wide.hue_min_deg -= kWidenDeg;
  wide.hue_max_deg += kWidenDeg;
  wide.chroma_min *= 0.7f;
  wide.chroma_min_bright *= 0.7f;
  const BallColorTest test(wide);
  // A grid over the inner disc, at most ~samples_per_region points.
  const float r = 0.6f * det.radius_px;
  const float side = std::sqrt(static_cast<float>(config_.samples_per_region) * 4.0f / 3.14159f);
  const float step = (2.0f * r) / side > 1.0f ? (2.0f * r) / side : 1.0f;
  for (float dv = -r; dv <= r; dv += step) {
    for (float du = -r; du <= r; du += step) {
      if (du * du + dv * dv > r * r) continue;
      const int u = static_cast<int>(det.u_px + du + 0.5f),
                v = static_cast<int>(det.v_px + dv + 0.5f);
      if (!image.contains(u, v)) continue;
      const Yuv p = image.at(u, v);
      if (test.Contains(p.y, p.u, p.v)) ball_.Add(p);
    }
  }
  const float ring = 2.5f * det.radius_px + 2.0f;
  for (int k = 0; k < kRingSamples; ++k) {
    const int u = static_cast<int>(det.u_px + ring * kRingCos[k] + 0.5f);
    const int v = static_cast<int>(det.v_px + ring * kRingSin[k] + 0.5f);
    if (!image.contains(u, v)) continue;
    const Yuv p = image.at(u, v);
    const ColorClass c = table_->Classify(p.y, p.u, p.v);
    if (c != ColorClass::kField && c != ColorClass::kLine && c != ColorClass::kObstacle) continue;
    guard_[guard_next_] = p;
    guard_next_ = (guard_next_ + 1) % kGuardSamples;
    if (guard_count_ < kGuardSamples) ++guard_count_;
  }
  observed_this_frame_ = true;
}

void ColorAdapter::Step() {
  if (table_ == nullptr) return;
  if (next_row_ >= 0) {  // an accepted model going into the table, a few rows per frame
    const int end = next_row_ + config_.rows_per_frame < (1 << ColorLut::kUBits)
                        ? next_row_ + config_.rows_per_frame
                        : (1 << ColorLut::kUBits);
    ChromaBox rows;
    // Rows not yet rebuilt still hold model_'s ball class.
    UpdateBallRows(model_, pending_, *table_, next_row_, end, rows).IgnoreError();  // validated
    building_box_ = next_row_ == 0 ? rows : Union(building_box_, rows);
    next_row_ = end < (1 << ColorLut::kUBits) ? end : -1;
    if (next_row_ < 0) {
      model_ = pending_;
      box_ = building_box_;
      ++stats_.rebuilds_done;
    }
    return;
  }
  if (!observed_this_frame_) return;
  observed_this_frame_ = false;
  ++stats_.frames_observed;
  if (++frames_since_refit_ < config_.refit_every) return;
  frames_since_refit_ = 0;
  if (ball_.count() >= config_.min_pixels) {
    BallColorModel fitted;
    // From the start model, not the adapted one: Fit's floors only go down from its start, and
    // from the adapted model they would ratchet down with every refit.
    bool ok = ball_.Fit(start_, fitted).ok();
    if (ok) {
      fitted = Union(start_, fitted);
      ok = ValidateBallColorModel(fitted).ok();  // a window over 170 deg: keep the old model
    }
    if (ok) {
      const BallColorTest test(fitted);
      int taken = 0;
      for (int i = 0; i < guard_count_; ++i)
        taken += test.Contains(guard_[i].y, guard_[i].u, guard_[i].v);
      ok = static_cast<float>(taken) <= config_.max_guard_taken * static_cast<float>(guard_count_);
    }
    if (ok && Same(fitted, model_)) {
      // The table already is this model (the light stays within the start model): no rebuild.
      ++stats_.refits_unchanged;
    } else if (ok) {
      pending_ = fitted;
      next_row_ = 0;
      ++stats_.refits;
    } else {
      ++stats_.refits_refused;
    }
  }
  ball_.Scale(0.5f);  // the light changes: older pixels count half at every refit
}

}  // namespace bv
