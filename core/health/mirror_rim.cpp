#include "core/health/mirror_rim.h"

#include <algorithm>
#include <cmath>

#include "core/common/circle_fit.h"
#include "core/common/median.h"

namespace bv {
namespace {

constexpr float kDegPerRad = 57.29578f;

}  // namespace

void MirrorRimWatch::Init(const OmniCalibration& cal, float outer_radius_px,
                          const MirrorRimConfig& config) {
  cal_ = &cal;
  config_ = config;
  outer_px_ = outer_radius_px;
  for (int k = 0; k < kDirections; ++k) {
    const float a = 6.2831853f * static_cast<float>(k) / kDirections;
    cos_[k] = std::cos(a);
    sin_[k] = std::sin(a);
  }
  Reset();
}

void MirrorRimWatch::Reset() {
  frame_ = count_ = next_ = last_points_ = 0;
  for (bool& m : misshapen_) m = false;
  offset_px_ = offset_u_px_ = offset_v_px_ = change_deg_ = last_rms_px_ = 0;
  state_ = CameraState::kAsCalibrated;
}

void MirrorRimWatch::Observe(const YuyvImage& omni) {
  if (!config_.enabled || cal_ == nullptr || !cal_->valid || !omni.valid() || !(outer_px_ > 0.f)) {
    return;
  }
  if (frame_++ % std::max(config_.every_frames, 1) != 0) return;
  float du = 0, dv = 0;
  const Rim rim = Measure(omni, du, dv);
  if (rim == Rim::kNone) return;
  du_[next_] = du;
  dv_[next_] = dv;
  misshapen_[next_] = rim == Rim::kMisshapen;
  next_ = (next_ + 1) % kHistory;
  if (count_ < kHistory) ++count_;
  Decide();
}

// Inward along each direction to the first pixel at or above bright_y (sub-pixel, as the
// calibration finds it on its mean image); a circle through the points by linear least squares,
// twice more without the points more than 2 px (then 1 px) off it. Found on most directions but
// no circle: kMisshapen, the first fit's centre in (du, dv) (a mirror tilted far on its holder).
MirrorRimWatch::Rim MirrorRimWatch::Measure(const YuyvImage& omni, float& du, float& dv) {
  const float cu = cal_->center_u, cv = cal_->center_v;
  const int y0 = config_.bright_y;
  float* const pu = pu_;  // members, not stack: Process() inlines this on the device's stack
  float* const pv = pv_;
  int n = 0;
  const float r0 = outer_px_ + config_.search_out_px;
  const int steps = static_cast<int>(config_.search_out_px + config_.search_in_px);
  for (int k = 0; k < kDirections; ++k) {
    // Nearest pixels one pixel apart (~10 instructions each on the M7); the edge between the
    // last dark and the first bright one by their luma.
    const float c = cos_[k], sn = sin_[k];
    float u = cu + r0 * c + 0.5f, v = cv + r0 * sn + 0.5f;  // +0.5: truncation rounds
    int prev = -1;
    for (int i = 0; i <= steps; ++i, u -= c, v -= sn) {
      if (!(u >= 0.f && v >= 0.f && u < static_cast<float>(omni.width) &&
            v < static_cast<float>(omni.height))) {
        prev = -1;  // outside the image: nothing seen yet
        continue;
      }
      const int y = omni.data[static_cast<ptrdiff_t>(static_cast<int>(v)) * omni.stride_bytes +
                              2 * static_cast<int>(u)];
      if (y >= y0) {
        if (prev < 0) break;  // bright from the first sample in the image: not the rim's edge
        const float rr = r0 - static_cast<float>(i) +
                         static_cast<float>(y - y0) / static_cast<float>(std::max(y - prev, 1));
        pu[n] = cu + rr * c;
        pv[n] = cv + rr * sn;
        ++n;
        break;
      }
      prev = y;
    }
  }
  bool* keep = keep_;
  for (int i = 0; i < n; ++i) keep[i] = true;
  float fu = cu, fv = cv, radius = 0.f, rms = 0.f;
  int used = 0;
  for (int pass = 0; pass < 3; ++pass) {
    // Relative to the calibrated centre, which keeps the sums well scaled.
    CircleSums sums;
    for (int i = 0; i < n; ++i) {
      if (keep[i]) sums.Add(pu[i] - cu, pv[i] - cv);
    }
    used = static_cast<int>(sums.n);
    double a = 0, b = 0, r = 0;
    if (used < config_.min_points) break;
    if (!sums.Solve(a, b, r)) {
      used = 0;
      break;
    }
    fu = cu + static_cast<float>(a);
    fv = cv + static_cast<float>(b);
    radius = static_cast<float>(r);
    if (pass == 0) du = fu - cu, dv = fv - cv;
    const float gate = pass == 0 ? 2.0f : 1.0f;
    double sum2 = 0;
    int kept = 0;
    for (int i = 0; i < n; ++i) {
      const float e = std::hypot(pu[i] - fu, pv[i] - fv) - radius;
      if (keep[i]) sum2 += static_cast<double>(e) * e;
      keep[i] = std::fabs(e) <= gate;
      kept += keep[i];
    }
    rms = static_cast<float>(std::sqrt(sum2 / used));
    if (kept < config_.min_points) break;
  }
  last_points_ = used >= config_.min_points ? used : 0;
  last_rms_px_ = rms;
  if (last_points_ == 0 || !(rms <= config_.max_fit_rms_px)) {
    const bool found = n >= config_.min_points && std::isfinite(du) && std::isfinite(dv);
    return found ? Rim::kMisshapen : Rim::kNone;
  }
  du = fu - cu;
  dv = fv - cv;
  return std::isfinite(du) && std::isfinite(dv) ? Rim::kCircle : Rim::kNone;
}

void MirrorRimWatch::Decide() {
  float us[kHistory] = {}, vs[kHistory] = {};
  for (int i = 0; i < count_; ++i) us[i] = du_[i], vs[i] = dv_[i];
  const float mu = MedianInPlace(us, count_), mv = MedianInPlace(vs, count_);
  offset_px_ = std::hypot(mu, mv);
  offset_u_px_ = mu;
  offset_v_px_ = mv;
  // What the offset turns a ray by: the calibrated rays of a pixel at half the usable radius in
  // the offset's direction and of that pixel moved by it.
  change_deg_ = 0.f;
  if (offset_px_ > 1e-3f) {
    const float eu = mu / offset_px_, ev = mv / offset_px_, r = 0.5f * outer_px_;
    const float u0 = cal_->center_u + r * eu, v0 = cal_->center_v + r * ev;
    const Result<Ray> a = OmniPixelToRay(*cal_, u0, v0);
    const Result<Ray> b = OmniPixelToRay(*cal_, u0 + mu, v0 + mv);
    if (a.ok() && b.ok()) {
      const float c = std::clamp(a->dir.normalized().dot(b->dir.normalized()), -1.f, 1.f);
      change_deg_ = std::acos(c) * kDegPerRad;
    }
  }
  if (count_ < 3) return;  // one odd frame decides nothing
  int misshapen = 0;
  for (int i = 0; i < count_; ++i) misshapen += misshapen_[i];
  const float gate = state_ == CameraState::kAsCalibrated ? config_.flag_px : config_.clear_px;
  if (2 * misshapen > count_ || offset_px_ >= config_.unusable_px) {
    state_ = CameraState::kUnusable;
  } else {
    state_ = offset_px_ >= gate ? CameraState::kChanged : CameraState::kAsCalibrated;
  }
}

}  // namespace bv
