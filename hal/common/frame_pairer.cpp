#include "hal/common/frame_pairer.h"

namespace bv::hal {

void FramePairer::OnFrameComplete(CameraId id, uint64_t exposure_us, uint32_t sequence,
                                  uint32_t slot) {
  Pending& p = pending_[static_cast<int>(id)];
  if (p.present) ++dropped_;
  p = Pending{true, exposure_us, sequence, slot};
}

int FramePairer::pending_slot(CameraId id) const {
  const Pending& p = pending_[static_cast<int>(id)];
  return p.present ? static_cast<int>(p.slot) : -1;
}

bool FramePairer::TakePair(uint64_t now_us, PairDecision& out) {
  const Pending& o = pending_[0];
  const Pending& s = pending_[1];
  if (!o.present && !s.present) return false;

  if (o.present != s.present) {
    // One camera only: wait for its partner unless the partner is overdue.
    const Pending& lone = o.present ? o : s;
    if (now_us < lone.exposure_us + config_.missing_timeout_us) return false;
  }

  out = PairDecision{};
  uint64_t sum = 0;
  int n = 0;
  for (int c = 0; c < kCameraCount; ++c) {
    const Pending& p = pending_[c];
    out.has[c] = p.present;
    if (!p.present) continue;
    out.slot[c] = p.slot;
    out.exposure_us[c] = p.exposure_us;
    out.sequence[c] = p.sequence;
    sum += p.exposure_us;
    ++n;
  }
  out.exposure_us_pair = sum / static_cast<uint64_t>(n);
  if (!o.present) out.flags |= kPairOmniMissing;
  if (!s.present) out.flags |= kPairPerspMissing;
  if (o.present && s.present) {
    out.skew_us = static_cast<int64_t>(s.exposure_us) - static_cast<int64_t>(o.exposure_us);
    const uint64_t abs_skew = static_cast<uint64_t>(out.skew_us < 0 ? -out.skew_us : out.skew_us);
    if (abs_skew > config_.sync_tolerance_us) out.flags |= kPairOutOfSync;
  }
  if (served_any_ && out.exposure_us_pair <= last_exposure_us_) out.flags |= kPairOutOfOrder;
  out.dropped = dropped_;

  served_any_ = true;
  last_exposure_us_ = out.exposure_us_pair;
  dropped_ = 0;
  pending_[0] = Pending{};
  pending_[1] = Pending{};
  return true;
}

}  // namespace bv::hal
