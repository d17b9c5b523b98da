#pragma once
// Offset and drift of the coprocessor's clock against the main computer's, from NTP-style
// exchanges over the serial link (docs/protocol.md, "Clock sync"):
//   t1 host sends the request, t2 coprocessor receives it, t3 coprocessor queues the reply,
//   t4 host has the whole reply.
// Each exchange gives offset = host - device = ((t1 - t2) + (t4 - t3)) / 2 and path delay
// d = (t4 - t1) - (t3 - t2); whatever the asymmetry, the true offset lies within +-d/2 of it.
// The estimate is a line offset(t_dev) fitted by weighted least squares over the last
// kWindow exchanges, weights (floor / (d - d_min + floor))^4: the minimum-delay exchanges
// decide, jittered or queued ones hardly count; the slope is bounded by max_drift_ppm. An
// exchange whose offset interval cannot meet the line's (beyond (d + d_min)/2, a margin and a
// drift allowance) is held; if the next one agrees with it and not with the line, a clock
// jumped (coprocessor reset): the estimator restarts from the two. Otherwise it was an outlier.
// No heap: a fixed ring of exchanges (usable as is on a small main computer).
#include <cstddef>
#include <cstdint>

#include "core/protocol/link.h"

namespace bv::tools {

class ClockSync {
 public:
  static constexpr size_t kWindow = 1024;  // exchanges (100 s at 10 Hz)
  static constexpr size_t kPending = 32;   // requests awaiting a reply
  static constexpr size_t kAnswered = 32;  // recent ids, to tell duplicates from strangers

  struct Config {
    /// Wire time of one byte (10 bits at the baud rate): the request's bytes before t2 and the
    /// reply's before t4 are taken off the path delays (0: no correction).
    double byte_us = 10.0 / 921600.0 * 1e6;
    double delay_floor_us = 20.0;
    /// Clock-rate difference the jump test allows between exchanges (crystals: < 100 ppm).
    double max_drift_ppm = 200.0;
    /// Extra room of the jump test: timestamping noise of both sides.
    double jump_margin_us = 500.0;
  };

  enum class Verdict {
    kAccepted,
    kDuplicate,     // this id was answered already
    kUnknownId,     // no such request outstanding (too old, or never sent)
    kMismatch,      // echoed t1 differs from what was sent with this id
    kInconsistent,  // t4 before t1, or device time negative in between
    kHeld,          // disagrees with the estimate: kept aside until the next exchange
    kRestarted,     // accepted with the held one: a clock jumped, the estimator restarted
  };

  ClockSync() : ClockSync(Config{}) {}
  explicit ClockSync(const Config& config) : config_(config) {}

  /// Records a request sent at host time t1_host_us (t1 must be what the request carries).
  void OnRequestSent(uint32_t id, int64_t t1_host_us);
  /// Feeds a reply received complete at host time t4_host_us.
  Verdict OnReply(const protocol::ClockSyncReply& reply, int64_t t4_host_us);

  bool valid() const { return count_ > 0; }
  /// Host time of a coprocessor timestamp (any packet's t_us). Meaningless until valid().
  int64_t ToHostTime(uint64_t t_dev_us) const;
  /// Offset host - device (µs) at device time t_dev_us, and the fitted drift (ppm: host µs
  /// per device µs, minus 1, times 1e6).
  double OffsetUs(uint64_t t_dev_us) const;
  double DriftPpm() const { return slope_ * 1e6; }
  /// Smallest path delay in the window (µs) and the exchanges in it.
  double MinDelayUs() const { return min_delay_; }
  size_t samples() const { return count_; }

  uint32_t accepted() const { return accepted_; }
  uint32_t duplicates() const { return duplicates_; }
  uint32_t unknown() const { return unknown_; }
  /// Mismatched or inconsistent replies: faults of the link or the coprocessor.
  uint32_t rejected() const { return rejected_; }
  /// Held exchanges the next one did not confirm: answered, but delayed (a busy host or line).
  uint32_t outliers() const { return outliers_; }
  /// True while an exchange is held (answered, neither accepted nor an outlier yet).
  bool holding() const { return have_suspect_; }
  uint32_t restarts() const { return restarts_; }

 private:
  struct Sample {
    double t_dev;   // device time of the exchange's midpoint, relative to dev_ref_
    double offset;  // host - device, µs
    double delay;   // µs
  };
  struct Raw {
    int64_t t1;
    uint64_t t2, t3;
    int64_t t4;
  };
  Sample MakeSample(const Raw& r) const;
  void Add(const Raw& r);
  bool Consistent(const Raw& r) const;
  bool Agree(const Raw& a, const Raw& b) const;
  void Restart();
  void Fit();
  double RelativeOffset(uint64_t t_dev_us) const;  // offset - offset_ref_

  Config config_;
  struct Pending {
    uint32_t id;
    int64_t t1;
    bool used;
  };
  Pending pending_[kPending] = {};
  size_t pending_next_ = 0;
  uint32_t answered_[kAnswered] = {};
  size_t answered_count_ = 0;
  size_t answered_next_ = 0;

  Sample ring_[kWindow] = {};
  size_t head_ = 0;
  size_t count_ = 0;
  uint64_t dev_ref_ = 0;    // device time origin of the current estimate
  int64_t offset_ref_ = 0;  // whole µs taken out of every sample's offset
  double last_t_dev_ = 0;   // newest sample, relative to dev_ref_
  double intercept_ = 0;    // offset at dev_ref_
  double slope_ = 0;
  double min_delay_ = 0;
  double centroid_ = 0;  // weighted mean device time of the fit
  Raw suspect_{};
  bool have_suspect_ = false;

  uint32_t accepted_ = 0, duplicates_ = 0, unknown_ = 0, rejected_ = 0, outliers_ = 0,
           restarts_ = 0;
};

}  // namespace bv::tools
