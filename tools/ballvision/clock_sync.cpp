#include "tools/ballvision/clock_sync.h"

#include <algorithm>
#include <cmath>

namespace bv::tools {

void ClockSync::OnRequestSent(uint32_t id, int64_t t1_host_us) {
  pending_[pending_next_] = Pending{id, t1_host_us, true};
  pending_next_ = (pending_next_ + 1) % kPending;
}

void ClockSync::Restart() {
  count_ = 0;
  head_ = 0;
  intercept_ = slope_ = min_delay_ = centroid_ = 0;
}

ClockSync::Verdict ClockSync::OnReply(const protocol::ClockSyncReply& reply, int64_t t4_host_us) {
  Pending* p = nullptr;
  for (Pending& e : pending_) {
    if (e.used && e.id == reply.id) p = &e;
  }
  if (p == nullptr) {
    for (size_t i = 0; i < answered_count_; ++i) {
      if (answered_[i] == reply.id) {
        ++duplicates_;
        return Verdict::kDuplicate;
      }
    }
    ++unknown_;
    return Verdict::kUnknownId;
  }
  if (static_cast<uint64_t>(p->t1) != reply.t1_host_us) {
    ++rejected_;
    return Verdict::kMismatch;
  }
  const int64_t t1 = p->t1;
  if (t4_host_us < t1 || reply.t3_tx_us < reply.t2_rx_us) {
    ++rejected_;
    return Verdict::kInconsistent;
  }
  p->used = false;
  answered_[answered_next_] = reply.id;
  answered_next_ = (answered_next_ + 1) % kAnswered;
  if (answered_count_ < kAnswered) ++answered_count_;

  const Raw raw{t1, reply.t2_rx_us, reply.t3_tx_us, t4_host_us};
  Verdict verdict = Verdict::kAccepted;
  if (count_ > 0 && !Consistent(raw)) {
    // One odd exchange is held back; a second one that agrees with it, and not with the
    // estimate, is a clock jump: restart from the two.
    if (!have_suspect_ || !Agree(suspect_, raw)) {
      if (have_suspect_) ++outliers_;
      suspect_ = raw;
      have_suspect_ = true;
      return Verdict::kHeld;
    }
    ++restarts_;
    verdict = Verdict::kRestarted;
    Restart();
    Add(suspect_);
    ++accepted_;
  } else if (have_suspect_) {
    ++outliers_;  // the held exchange was an outlier
  }
  have_suspect_ = false;
  Add(raw);
  ++accepted_;
  Fit();
  return verdict;
}

// Whole frames cross the wire between t1 and t2 (t2 stamps the request's last byte) and
// between t3 and t4: known time, not path delay. Host times relative to t1, device times
// relative to t2, so the doubles stay small.
ClockSync::Sample ClockSync::MakeSample(const Raw& r) const {
  const double h1 = config_.byte_us * protocol::WireFrameBytes(protocol::kClockSyncRequestBytes);
  const double h4 = static_cast<double>(r.t4 - r.t1) -
                    config_.byte_us * protocol::WireFrameBytes(protocol::kClockSyncReplyBytes);
  const double d3 = static_cast<double>(r.t3 - r.t2);
  Sample s;
  s.delay = std::fmax((h4 - h1) - d3, 0.0);  // < 0 only through timestamp noise
  s.t_dev = static_cast<double>(static_cast<int64_t>(r.t2 - dev_ref_)) + d3 / 2;
  s.offset = static_cast<double>((r.t1 - static_cast<int64_t>(r.t2)) - offset_ref_) +
             (h1 + (h4 - d3)) / 2.0;
  return s;
}

void ClockSync::Add(const Raw& r) {
  if (count_ == 0) {
    dev_ref_ = r.t2;
    offset_ref_ = r.t1 - static_cast<int64_t>(r.t2);
  }
  const Sample s = MakeSample(r);
  ring_[head_] = s;
  head_ = (head_ + 1) % kWindow;
  if (count_ < kWindow) ++count_;
  if (count_ == 1 || s.t_dev > last_t_dev_) last_t_dev_ = s.t_dev;
}

// Both the exchange (d/2) and the line (fitted to exchanges no better than d_min) may be off by
// half their delays; the slope by up to twice the largest drift, away from its centroid.
bool ClockSync::Consistent(const Raw& r) const {
  const Sample s = MakeSample(r);
  const double allowance = (s.delay + min_delay_) / 2.0 + config_.jump_margin_us +
                           2.0 * config_.max_drift_ppm * 1e-6 * std::fabs(s.t_dev - centroid_);
  return std::fabs(s.offset - (intercept_ + slope_ * s.t_dev)) <= allowance;
}

bool ClockSync::Agree(const Raw& a, const Raw& b) const {
  const Sample sa = MakeSample(a), sb = MakeSample(b);
  const double allowance = (sa.delay + sb.delay) / 2.0 + config_.jump_margin_us +
                           config_.max_drift_ppm * 1e-6 * std::fabs(sa.t_dev - sb.t_dev);
  return std::fabs(sa.offset - sb.offset) <= allowance;
}

void ClockSync::Fit() {
  double dmin = ring_[0].delay;
  for (size_t i = 0; i < count_; ++i) dmin = std::fmin(dmin, ring_[i].delay);
  min_delay_ = dmin;
  // (floor / (d - d_min + floor))^4: an exchange 2 floors above the best counts 1/81.
  auto weight = [&](const Sample& x) {
    const double e = config_.delay_floor_us / (x.delay - dmin + config_.delay_floor_us);
    return (e * e) * (e * e);
  };
  double sw = 0, sx = 0, sy = 0;
  for (size_t i = 0; i < count_; ++i) {
    const double w = weight(ring_[i]);
    sw += w, sx += w * ring_[i].t_dev, sy += w * ring_[i].offset;
  }
  const double mx = sx / sw, my = sy / sw;
  double sxx = 0, sxy = 0;
  for (size_t i = 0; i < count_; ++i) {
    const double w = weight(ring_[i]);
    const double dx = ring_[i].t_dev - mx;
    sxx += w * dx * dx;
    sxy += w * dx * (ring_[i].offset - my);
  }
  // Below ~0.1 s of weighted spread the slope is noise: hold the offset flat until then; and
  // no crystal drifts more than max_drift_ppm.
  const double limit = config_.max_drift_ppm * 1e-6;
  slope_ = sxx / sw > 1e10 ? std::clamp(sxy / sxx, -limit, limit) : 0.0;
  intercept_ = my - slope_ * mx;
  centroid_ = mx;
}

double ClockSync::OffsetUs(uint64_t t_dev_us) const {
  return static_cast<double>(offset_ref_) + RelativeOffset(t_dev_us);
}

double ClockSync::RelativeOffset(uint64_t t_dev_us) const {
  const double x = static_cast<double>(static_cast<int64_t>(t_dev_us - dev_ref_));
  return intercept_ + slope_ * x;
}

int64_t ClockSync::ToHostTime(uint64_t t_dev_us) const {
  return static_cast<int64_t>(t_dev_us) + offset_ref_ +
         static_cast<int64_t>(std::llround(RelativeOffset(t_dev_us)));
}

}  // namespace bv::tools
