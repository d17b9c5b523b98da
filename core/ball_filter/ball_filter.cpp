#include "core/ball_filter/ball_filter.h"

#include <algorithm>
#include <cmath>

namespace bv {
namespace {

constexpr float kAnchorWeight = 2.f;  // a floor contact counts like two measurements

float Seconds(uint64_t a_us, uint64_t b_us) {  // a - b in seconds, signed
  return a_us >= b_us ? static_cast<float>(a_us - b_us) * 1e-6f
                      : -static_cast<float>(b_us - a_us) * 1e-6f;
}

bool Finite(const Eigen::Vector3f& v) {
  return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z());
}

// Weighted least-squares line y = a + b t. With one distinct time: a = mean, b = 0.
void FitLine(const float* t, const float* y, const float* w, int n, float& a, float& b) {
  float sw = 0, st = 0, sy = 0;
  for (int i = 0; i < n; ++i) {
    sw += w[i];
    st += w[i] * t[i];
    sy += w[i] * y[i];
  }
  if (!(sw > 0)) {
    a = 0;
    b = 0;
    return;
  }
  const float tm = st / sw, ym = sy / sw;
  float stt = 0, sty = 0;
  for (int i = 0; i < n; ++i) {
    stt += w[i] * (t[i] - tm) * (t[i] - tm);
    sty += w[i] * (t[i] - tm) * (y[i] - ym);
  }
  b = stt > 1e-12f ? sty / stt : 0.f;
  a = ym - b * tm;  // value at t = 0
}

}  // namespace

void BallFilter::Configure(const BallFilterConfig& config) {
  cfg_ = config;
  cfg_.max_window = std::clamp(cfg_.max_window, 3, kMaxWindow);
  cfg_.shrink_after = std::max(cfg_.shrink_after, 1);
  Reset();
}

void BallFilter::Reset() {
  count_ = 0;
  head_ = 0;
  tracking_ = false;
  have_time_ = false;
  cand_valid_ = false;
  large_count_ = 0;
  b_ = std::clamp(cfg_.bounce_factor, 0.f, 1.f);
}

const BallFilter::Obs& BallFilter::Newest(int k) const {
  return obs_[(head_ - 1 - k + 2 * kMaxWindow) % kMaxWindow];
}

void BallFilter::Push(const BallMeasurement& m) {
  obs_[head_] = Obs{m.t_us, m.p_m, m.z_valid};
  head_ = (head_ + 1) % kMaxWindow;
  count_ = std::min(count_ + 1, cfg_.max_window);
}

void BallFilter::KeepNewest(int n) { count_ = std::clamp(n, 0, count_); }

float BallFilter::RollTolerance(const Eigen::Vector3f& p) const {
  return cfg_.roll_tolerance_m + cfg_.roll_tolerance_per_m * std::hypot(p.x(), p.y());
}

void BallFilter::StartTrack(const BallMeasurement& m) {
  count_ = 0;
  tracking_ = true;
  large_count_ = 0;
  cand_valid_ = false;
  lift_count_ = 0;
  anchor_ = false;
  b_pending_ = false;
  bounced_ = false;
  seg_start_us_ = m.t_us;
  const float r = cfg_.ball_radius_m;
  vert_ = (!m.z_valid || m.p_m.z() - r < RollTolerance(m.p_m)) ? Vertical::kRolling
                                                               : Vertical::kAirborne;
  vz0_ = 0;
  Push(m);
  last_meas_us_ = m.t_us;
  Refit();
}

void BallFilter::ZAt(float dt_s, float& z, float& vz, bool& rolling, int& bounces) const {
  const float r = cfg_.ball_radius_m, g = cfg_.gravity_mps2;
  bounces = 0;
  rolling = vert_ == Vertical::kRolling;
  if (rolling) {
    z = r;
    vz = 0;
    return;
  }
  float za = z0_, va = vz0_, tau = 0;
  for (int k = 0; k <= kMaxContacts; ++k) {
    const float disc = va * va + 2.f * g * std::max(za - r, 0.f);
    const float s = (va + std::sqrt(disc)) / g;  // time to the next contact (>= 0 if descending)
    if (dt_s < tau + s || k == kMaxContacts) {
      const float u = dt_s - tau;
      z = za + va * u - 0.5f * g * u * u;
      vz = va - g * u;
      return;
    }
    const float v_out = b_ * std::fabs(va - g * s);
    tau += s;
    ++bounces;
    if (v_out < cfg_.min_bounce_vz_mps) {
      rolling = true;
      z = r;
      vz = 0;
      return;
    }
    za = r;
    va = v_out;
  }
}

bool BallFilter::StateAt(uint64_t t_us, Eigen::Vector3f& p_m, Eigen::Vector3f& v_mps,
                         BallMode& mode) const {
  if (!tracking_) {
    mode = BallMode::kNone;
    return false;
  }
  const float dt = Seconds(t_us, t_ref_us_);
  float z, vz;
  bool rolling;
  int bounces;
  ZAt(dt, z, vz, rolling, bounces);
  p_m = Eigen::Vector3f(x0_ + vx_ * dt, y0_ + vy_ * dt, z);
  v_mps = Eigen::Vector3f(vx_, vy_, vz);
  mode = rolling ? BallMode::kRolling
                 : ((bounced_ || bounces > 0) ? BallMode::kBouncing : BallMode::kFlying);
  return true;
}

int BallFilter::ContactsAfter(uint64_t t_us, uint64_t* t_out, float* x_out, float* y_out,
                              int max) const {
  if (!tracking_ || vert_ == Vertical::kRolling || max <= 0) return 0;
  const float r = cfg_.ball_radius_m, g = cfg_.gravity_mps2;
  const float after = Seconds(t_us, t_ref_us_);
  float za = z0_, va = vz0_, tau = 0;
  int n = 0;
  for (int k = 0; k < kMaxContacts && n < max; ++k) {
    const float disc = va * va + 2.f * g * std::max(za - r, 0.f);
    const float s = (va + std::sqrt(disc)) / g;
    tau += s;
    if (tau > after) {
      const float t_rel_us = tau * 1e6f;
      const int64_t t_abs = static_cast<int64_t>(t_ref_us_) + static_cast<int64_t>(t_rel_us);
      t_out[n] = t_abs > 0 ? static_cast<uint64_t>(t_abs) : 0;
      x_out[n] = x0_ + vx_ * tau;
      y_out[n] = y0_ + vy_ * tau;
      ++n;
    }
    const float v_out = b_ * std::fabs(va - g * s);
    if (v_out < cfg_.min_bounce_vz_mps) break;
    za = r;
    va = v_out;
  }
  return n;
}

uint16_t BallFilter::Update(const BallMeasurement& m) {
  if (!Finite(m.p_m)) return kFlagOutlierRejected;
  if (std::hypot(m.p_m.x(), m.p_m.y()) > cfg_.max_range_m || m.p_m.z() > cfg_.max_height_m ||
      m.p_m.z() < cfg_.min_height_m) {
    return kFlagOutOfField;
  }
  if (have_time_ && m.t_us <= last_t_us_) return kFlagBadTimestamp;
  have_time_ = true;
  last_t_us_ = m.t_us;

  if (!tracking_ || m.t_us - last_meas_us_ > cfg_.coast_us) {
    StartTrack(m);
    return 0;
  }

  // Vertical hypotheses before comparing with the prediction: a floor contact since the last
  // z observation (bounce), or a rolling ball leaving the floor.
  const float r = cfg_.ball_radius_m, g = cfg_.gravity_mps2;
  const float dt = Seconds(m.t_us, t_ref_us_);
  Eigen::Vector3f p_pred, v_pred;
  BallMode mode_pred;
  StateAt(m.t_us, p_pred, v_pred, mode_pred);
  bool bounce_now = false;
  float t_contact_s = 0, v_in = 0;
  if (vert_ == Vertical::kAirborne && m.z_valid) {
    // First contact of the current arc after the reference time.
    const float disc = vz0_ * vz0_ + 2.f * g * std::max(z0_ - r, 0.f);
    const float s = (vz0_ + std::sqrt(disc)) / g;
    const float frame_s = std::max(dt, 0.f);
    if (s <= dt + 0.5f * frame_s) {
      const float tc = std::min(s, dt);
      v_in = std::fabs(vz0_ - g * tc);
      const float v_out = b_ * v_in;
      const float u = dt - tc;
      const float z_bounce = r + v_out * u - 0.5f * g * u * u;
      const float z_nobounce = z0_ + vz0_ * dt - 0.5f * g * dt * dt;
      if (std::fabs(m.p_m.z() - z_bounce) <= std::fabs(m.p_m.z() - z_nobounce)) {
        bounce_now = true;
        t_contact_s = tc;
        p_pred.z() = std::max(z_bounce, r);
      }
    }
  }

  // Prediction error gates (xy only when z is an assumption).
  Eigen::Vector3f err = m.p_m - p_pred;
  if (!m.z_valid) err.z() = 0;
  const float e = err.norm();
  const float since_s = Seconds(m.t_us, last_meas_us_);
  const float outlier_gate = cfg_.outlier_error_m + cfg_.outlier_growth_mps * since_s;
  if (e > outlier_gate) {
    // A jump is believed only when the next measurement confirms it.
    if (cand_valid_ && m.t_us - cand_.t_us <= cfg_.coast_us &&
        (m.p_m - cand_.p_m).norm() <=
            cfg_.outlier_error_m + cfg_.outlier_growth_mps * Seconds(m.t_us, cand_.t_us)) {
      const BallMeasurement first = cand_;
      StartTrack(first);
      Push(m);
      last_meas_us_ = m.t_us;
      Refit();
      return 0;
    }
    cand_ = m;
    cand_valid_ = true;
    return kFlagOutlierRejected;
  }
  cand_valid_ = false;

  if (bounce_now) {
    seg_start_us_ = t_ref_us_ + static_cast<uint64_t>(t_contact_s * 1e6f);
    anchor_ = true;
    v_in_mps_ = v_in;
    b_pending_ = cfg_.estimate_bounce_factor;
    bounced_ = true;
    if (b_ * v_in < cfg_.min_bounce_vz_mps) {
      vert_ = Vertical::kRolling;
      bounced_ = false;
      anchor_ = false;
    }
  } else if (vert_ == Vertical::kRolling && m.z_valid) {
    const float dz = m.p_m.z() - r;
    const float tol = RollTolerance(m.p_m);
    lift_count_ = dz > 2.f * tol ? lift_count_ + 1 : 0;
    if (lift_count_ >= 2 || dz > 6.f * tol) {
      // Take-off between the last on-floor observation and the first lifted one.
      vert_ = Vertical::kAirborne;
      bounced_ = false;
      anchor_ = false;
      b_pending_ = false;
      const int back = lift_count_ >= 2 ? lift_count_ - 1 : 0;  // lifted obs already stored
      seg_start_us_ = count_ > back ? Newest(back).t_us : m.t_us;
      lift_count_ = 0;
    }
  }

  // Window: repeated large horizontal errors (kick, rebound off a robot) keep only the recent
  // ones. Height has its own models (a bounce is not a reason to forget the x, y history).
  const float e_xy = std::hypot(err.x(), err.y());
  large_count_ = e_xy > cfg_.large_error_m ? large_count_ + 1 : 0;
  if (large_count_ >= cfg_.shrink_after) {
    KeepNewest(cfg_.shrink_after - 1);
    large_count_ = 0;
  }
  Push(m);
  last_meas_us_ = m.t_us;
  Refit();
  return 0;
}

void BallFilter::Refit() {
  const Obs& newest = Newest(0);
  const float advance_s = Seconds(newest.t_us, t_ref_us_);
  t_ref_us_ = newest.t_us;
  float t[kMaxWindow + 1] = {}, w[kMaxWindow + 1] = {}, ya[kMaxWindow + 1] = {},
                       yb[kMaxWindow + 1] = {};
  for (int i = 0; i < count_; ++i) {
    const Obs& o = Newest(i);
    t[i] = Seconds(o.t_us, t_ref_us_);
    w[i] = 1.f;
    ya[i] = o.p.x();
    yb[i] = o.p.y();
  }
  FitLine(t, ya, w, count_, x0_, vx_);
  FitLine(t, yb, w, count_, y0_, vy_);

  if (vert_ == Vertical::kAirborne) {
    const float g = cfg_.gravity_mps2, r = cfg_.ball_radius_m;
    int n = 0;
    for (int i = 0; i < count_; ++i) {
      const Obs& o = Newest(i);
      if (!o.z_valid || o.t_us < seg_start_us_) continue;
      t[n] = Seconds(o.t_us, t_ref_us_);
      ya[n] = o.p.z() + 0.5f * g * t[n] * t[n];  // remove gravity: a line remains
      w[n] = 1.f;
      ++n;
    }
    const int measured = n;
    if (anchor_) {
      t[n] = Seconds(seg_start_us_, t_ref_us_);
      ya[n] = r + 0.5f * g * t[n] * t[n];
      w[n] = kAnchorWeight;
      ++n;
    }
    float t_lo = 0, t_hi = 0;
    for (int i = 0; i < n; ++i) {
      t_lo = i ? std::min(t_lo, t[i]) : t[i];
      t_hi = i ? std::max(t_hi, t[i]) : t[i];
    }
    if (n >= 2 && t_hi - t_lo > 0.005f) {
      FitLine(t, ya, w, n, z0_, vz0_);
    } else if (anchor_) {
      // Right at a floor contact: the rebound predicted by v_out = b v_in.
      const float u = -Seconds(seg_start_us_, t_ref_us_);
      const float v_out = b_ * v_in_mps_;
      z0_ = r + v_out * u - 0.5f * g * u * u;
      vz0_ = v_out - g * u;
    } else if (n >= 1) {
      // One point on a new arc: keep the velocity the previous model had at this time.
      z0_ = ya[0] - 0.5f * g * t[0] * t[0];
      vz0_ -= g * advance_s;
    }
    if (anchor_ && b_pending_ && measured >= 4 && v_in_mps_ > 0.5f) {
      const float ts = Seconds(seg_start_us_, t_ref_us_);
      const float v_out = vz0_ - g * ts;
      const float b_est = v_out / v_in_mps_;
      if (b_est > cfg_.min_bounce_factor && b_est < cfg_.max_bounce_factor) {
        b_ = 0.5f * (b_ + b_est);
      }
      b_pending_ = false;
    }
    // A long arc hugging the floor is a rolling ball after all.
    if (measured >= 4 && !anchor_) {
      float ss = 0;
      int k = 0;
      for (int i = 0; i < count_ && k < measured; ++i) {
        const Obs& o = Newest(i);
        if (!o.z_valid || o.t_us < seg_start_us_) continue;
        ss += (o.p.z() - r) * (o.p.z() - r);
        ++k;
      }
      if (std::sqrt(ss / static_cast<float>(k)) < RollTolerance(newest.p) &&
          std::fabs(vz0_) < cfg_.min_bounce_vz_mps) {
        vert_ = Vertical::kRolling;
      }
    }
  }
  if (vert_ == Vertical::kRolling) {
    z0_ = cfg_.ball_radius_m;
    vz0_ = 0;
  }
  if (!std::isfinite(x0_) || !std::isfinite(y0_) || !std::isfinite(vx_) || !std::isfinite(vy_) ||
      !std::isfinite(z0_) || !std::isfinite(vz0_)) {
    // Cannot happen with finite inputs; never let a NaN escape.
    tracking_ = false;
    count_ = 0;
  }
}

void BallFilter::FillState(uint64_t t_us, uint32_t ahead_us, BallState& out) const {
  out.found = false;
  out.mode = BallMode::kNone;
  out.flags &=
      static_cast<uint16_t>(~(kFlagCoasting | kFlagLost | kFlagHasBounce | kFlagHasPrediction));
  if (!tracking_) return;
  if (t_us > last_meas_us_ + cfg_.coast_us) {
    out.flags |= kFlagLost;
    return;
  }
  if (t_us != last_meas_us_) out.flags |= kFlagCoasting;
  Eigen::Vector3f p, v;
  BallMode mode;
  StateAt(t_us, p, v, mode);
  out.found = true;
  out.x_m = p.x();
  out.y_m = p.y();
  out.z_m = p.z();
  out.vx_mps = v.x();
  out.vy_mps = v.y();
  out.vz_mps = v.z();
  out.mode = mode;
  uint64_t tb;
  float bx, by;
  if (ContactsAfter(t_us, &tb, &bx, &by, 1) == 1) {
    out.t_bounce_us = tb;
    out.bounce_x_m = bx;
    out.bounce_y_m = by;
    out.flags |= kFlagHasBounce;
  }
  StateAt(t_us + ahead_us, p, v, mode);
  out.predict_ahead_us = ahead_us;
  out.px_m = p.x();
  out.py_m = p.y();
  out.pz_m = p.z();
  out.flags |= kFlagHasPrediction;
}

}  // namespace bv
