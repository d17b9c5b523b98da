// Clock sync over a simulated 921600 Bd link: prints the estimator's offset and drift errors
// after 1, 10 and 60 s for several link models (tools/ballvision/clock_sync.h).
//   build/host/bench/bench_clock_sync [runs]
// The link model: the main computer stamps t1 and then writes the request (scheduling delay),
// the bytes go out through its driver / USB adapter (out latency), cross the wire (10 bits a
// byte), the coprocessor's interrupt stamps the delimiter (t2, a few µs late), the loop answers
// when it next polls, the reply waits for the TX ring to empty and is stamped (t3) as it
// starts, crosses the wire, comes back through the adapter (in latency) and the host stamps t4 when
// its read returns. The coprocessor clock runs fast or slow by `drift_ppm`.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <vector>

#include "core/protocol/link.h"
#include "tools/ballvision/clock_sync.h"

namespace {

using bv::tools::ClockSync;
namespace protocol = bv::protocol;

constexpr double kByteUs = 10.0 / 921600.0 * 1e6;

struct LinkModel {
  const char* name;
  double out_base_us, out_jitter_us;  // host -> coprocessor: base + uniform(0, jitter)
  double in_base_us, in_jitter_us;    // coprocessor -> host
  double sched_mean_us;               // host scheduling delay, exponential, on t1 and t4
  double hiccup_prob, hiccup_us;      // rare long host stalls
  double busy_prob, busy_max_us;      // TX ring busy when the reply is due: uniform wait
  double reset_at_s;                  // coprocessor reboots (clock restarts at 0); < 0: never
  // false: the firmware's way, the reply waits for an empty ring and t3 is stamped then;
  // true: t3 stamped when queued behind the busy ring (for comparison)
  bool stamp_before_queue = false;
};

struct Errors {
  double offset_us[3];
  double drift_ppm[3];
  uint32_t restarts;
};

constexpr double kCheckpoints[3] = {1.0, 10.0, 60.0};

Errors RunOnce(const LinkModel& m, double drift_ppm, uint32_t seed, double rate_hz) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::exponential_distribution<double> sched(1.0 / m.sched_mean_us);
  const double rate = 1.0 + drift_ppm * 1e-6;     // device µs per true µs
  double dev0 = 3e6 + u01(rng) * 1e9;             // device clock at true time 0
  const double host0 = 1.7e15 + u01(rng) * 1e12;  // host clock (true time) at 0
  auto dev = [&](double t) { return dev0 + t * rate; };
  ClockSync sync;
  Errors e{};
  int next_check = 0;
  const double period_us = 1e6 / rate_hz;
  bool reset_done = false;
  uint32_t id = 0;
  const double req_wire = kByteUs * protocol::WireFrameBytes(protocol::kClockSyncRequestBytes);
  const double rep_wire = kByteUs * protocol::WireFrameBytes(protocol::kClockSyncReplyBytes);
  for (double t = u01(rng) * period_us; next_check < 3; t += period_us) {
    if (m.reset_at_s >= 0 && !reset_done && t >= m.reset_at_s * 1e6) {
      reset_done = true;
      dev0 = -t * rate + 2e6;  // rebooted: uptime 2 s now
    }
    while (next_check < 3 && t >= kCheckpoints[next_check] * 1e6) {
      // Error of host time assigned to a packet stamped now, and of the drift.
      const double now_dev = dev(t);
      const double host_est = static_cast<double>(sync.ToHostTime(static_cast<uint64_t>(now_dev))) +
                              (now_dev - std::floor(now_dev));
      e.offset_us[next_check] = sync.valid() ? host_est - (host0 + t) : NAN;
      const double true_ppm = (1.0 / rate - 1.0) * 1e6;
      e.drift_ppm[next_check] = sync.DriftPpm() - true_ppm;
      ++next_check;
    }
    const double t1_true = t;
    const double t1_stamp = host0 + t1_true;
    double send = t1_true + sched(rng);
    if (u01(rng) < m.hiccup_prob) send += m.hiccup_us;
    const double arrive = send + m.out_base_us + u01(rng) * m.out_jitter_us + req_wire;
    const double t2 = std::floor(dev(arrive + u01(rng) * 5.0));
    const double answer = arrive + u01(rng) * 1500.0;  // loop busy with a pair
    const double wait = u01(rng) < m.busy_prob ? u01(rng) * m.busy_max_us : 0.0;
    const double leave = answer + wait;
    // DMA / UART start: a few µs after the stamp.
    const double t3 = std::floor(dev(m.stamp_before_queue ? answer : leave - u01(rng) * 5.0));
    double back = leave + rep_wire + m.in_base_us + u01(rng) * m.in_jitter_us + sched(rng);
    if (u01(rng) < m.hiccup_prob) back += m.hiccup_us;
    const double t4_stamp = host0 + back;
    ++id;
    sync.OnRequestSent(id, static_cast<int64_t>(t1_stamp));
    protocol::ClockSyncReply r;
    r.id = id;
    r.t1_host_us = static_cast<uint64_t>(static_cast<int64_t>(t1_stamp));
    r.t2_rx_us = static_cast<uint64_t>(t2);
    r.t3_tx_us = static_cast<uint64_t>(t3);
    (void)sync.OnReply(r, static_cast<int64_t>(t4_stamp));
  }
  e.restarts = sync.restarts();
  return e;
}

double Quantile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(q * (v.size() - 1) + 0.5)];
}

}  // namespace

int main(int argc, char** argv) {
  const int runs = argc > 1 ? std::atoi(argv[1]) : 200;
  if (runs < 1) {
    std::fprintf(stderr, "usage: bench_clock_sync [runs >= 1]\n");
    return 2;
  }
  const double rate_hz = 10.0;
  // Ball states and field packets keep the TX ring busy ~14 % of the time at 30 Hz (up to
  // 4.6 ms of queued bytes); a running capture keeps up to two 540-byte chunks queued.
  const LinkModel models[] = {
      {"direct UART, quiet host", 20, 20, 20, 20, 20, 0.0, 0, 0.14, 4600, -1},
      {"USB adapter (1 ms latency timer), busy host", 150, 125, 150, 1000, 80, 0.02, 5000, 0.14,
       4600, -1},
      {"USB adapter, capture running", 150, 125, 150, 1000, 80, 0.02, 5000, 0.95, 11700, -1},
      {"  same, t3 stamped before the queue", 150, 125, 150, 1000, 80, 0.02, 5000, 0.95, 11700, -1,
       true},
      {"USB adapter, coprocessor reset at 30 s", 150, 125, 150, 1000, 80, 0.02, 5000, 0.14, 4600,
       30},
      {"USB adapter, asymmetric base (in +200 us)", 150, 125, 350, 1000, 80, 0.02, 5000, 0.14, 4600,
       -1},
  };
  const double drifts[] = {40.0, -73.0};
  std::printf(
      "clock sync, 921600 Bd, %.0f exchanges/s, %d runs per row (random offsets, "
      "seeds 1..%d); |error| median / p95\n",
      rate_hz, runs, runs);
  std::printf("%-46s %6s  %-22s %-22s %-22s %-20s %-20s %-20s %s\n", "link", "drift",
              "offset 1 s (us)", "offset 10 s (us)", "offset 60 s (us)", "drift 1 s (ppm)",
              "drift 10 s (ppm)", "drift 60 s (ppm)", "restarts");
  for (const LinkModel& m : models) {
    for (double drift : drifts) {
      std::vector<double> off[3], dr[3];
      uint32_t restarts = 0;
      for (int i = 0; i < runs; ++i) {
        const Errors e = RunOnce(m, drift, static_cast<uint32_t>(i + 1), rate_hz);
        for (int k = 0; k < 3; ++k) {
          off[k].push_back(std::fabs(e.offset_us[k]));
          dr[k].push_back(std::fabs(e.drift_ppm[k]));
        }
        restarts += e.restarts;
      }
      std::printf("%-46s %+6.0f ", m.name, drift);
      for (int k = 0; k < 3; ++k) {
        std::printf(" %8.1f / %-11.1f", Quantile(off[k], 0.5), Quantile(off[k], 0.95));
      }
      for (int k = 0; k < 3; ++k) {
        std::printf(" %7.2f / %-10.2f", Quantile(dr[k], 0.5), Quantile(dr[k], 0.95));
      }
      std::printf(" %.2f/run\n", static_cast<double>(restarts) / runs);
    }
  }
  return 0;
}
