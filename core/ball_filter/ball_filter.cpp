#include "core/ball_filter/ball_filter.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Geometry>  // cross products

namespace bv {
namespace {

using Vec6 = Eigen::Matrix<float, 6, 1>;
using Mat6 = Eigen::Matrix<float, 6, 6>;

constexpr float kSigmaFloorM = 0.003f;  // metric noise floor of a ray (centroid quantisation)
constexpr float kMinDepthM = 0.1f;      // depth along a ray used for its angular residual
constexpr int kColdIterations = 4;      // Gauss-Newton steps from a point on a ray (warm: 2)
constexpr float kModelCheckChi2PerDof = 1.5f;  // a fit this much worse than the noise is checked
constexpr float kConstraintWeight = 1e6f;      // rolling: z = r, vz = 0 (1 mm, 1 mm/s)
constexpr float kRegPos = 1e-4f;               // 100 m: keeps an unobserved direction finite
constexpr float kRegVel = 1e-2f;               // 10 m/s
constexpr float kMaxUpwardDirZ = 0.7f;         // rays steeper than ~44 deg up cannot see a ball
constexpr float kRestSpeedMps = 0.02f;         // slower: at rest (no rolling deceleration)
constexpr float kHuberSigma = 3.f;             // residuals beyond this many sigmas count linearly
constexpr float kStopCheckSpeedMps = 0.5f;  // a rolling fit this slow is checked for having stopped
constexpr float kMinQuietScale = 0.015625f;  // white part: at least an eighth of the model's sigma
constexpr float kOffSigma = 3.f;  // a frame this far from the prediction may start a segment
constexpr int kRestFrames = 4;    // frames that must agree with a ball at rest
constexpr float kUnobservableGateRad = 0.15f;  // direction gate while the range is unknown
constexpr float kUnknownDepthM = 4.f;          // where a lone ray above the floor's horizon starts
constexpr float kAmbiguousChi2 = 4.f;  // two flights this close in chi^2 but apart: ambiguous
constexpr float kFloorChi2 = 9.f;      // the floor must not cost more than 3 sigma (1 dof: height)
constexpr int kStereoFramesForOneStart = 3;  // a flight fit from the current state suffices
constexpr int kRestitutionMemory = 8;        // rebounds averaged into b
// The rays' measured noise level: the rows of the last ~128 frames (4 s at 30 Hz), starting from
// the configured prior as if 2 rows had shown it (forgotten like the rest; 8 held the level near
// the model's for 2-3 s). A fit's variance factor is pulled towards it by 8 rows.
constexpr float kNoiseForget = 1.f - 1.f / 128.f, kNoiseStartRows = 2.f, kNoisePriorRows = 8.f;
// A later segment's first frames do not measure the noise: their fit leans on the prior and the
// model change, and at 20 % of the stated noise they put the level 2x high for seconds after each
// bounce.
constexpr int kNoiseSegmentFrames = 6;

float Seconds(uint64_t a_us, uint64_t b_us) {  // a - b in seconds, signed
  return a_us >= b_us ? static_cast<float>(a_us - b_us) * 1e-6f
                      : -static_cast<float>(b_us - a_us) * 1e-6f;
}

uint64_t AddSeconds(uint64_t t_us, float s) {
  const double us = static_cast<double>(t_us) + static_cast<double>(s) * 1e6;
  return us <= 0 ? 0 : static_cast<uint64_t>(us + 0.5);
}

bool Finite(const Eigen::Vector3f& v) {
  return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z());
}

// One ray's whitened rows: horizontal angle (e1), vertical angle (e2 = d x e1), range cue.
struct RayRows {
  Eigen::Vector3f jac[3];   // d row / d ball position, over the row's sigma
  float res[3] = {};        // the row's residual over its sigma
  float inv_sigma[2] = {};  // 1 / the angular rows' sigma
  int n = 0;                // 2, or 3 with a range cue
};

// One ray's whitened rows for the ball at x relative to the ray origin: its angles across the ray
// (horizontal e1 then e2 = d x e1) and the range cue's residual along it. Angular, not metric: a
// metric residual would let the fit shrink towards the camera centre, where every ray of one
// camera meets. Returns chi^2.
float RayRowsAt(const Eigen::Vector3f& x, const Eigen::Vector3f& d, float sigma_h, float sigma_v,
                float range, float range_sigma, RayRows& rr) {
  Eigen::Vector3f e1 = d.cross(Eigen::Vector3f::UnitZ());
  const float n1 = e1.norm();
  if (n1 < 1e-3f) {
    e1 = Eigen::Vector3f::UnitX() - d * d.x();
    e1.normalize();
  } else {
    e1 /= n1;
  }
  const Eigen::Vector3f e2 = d.cross(e1);
  const float along = d.dot(x);
  const float rho = std::max(along, kMinDepthM);
  const Eigen::Vector3f* es[2] = {&e1, &e2};
  const float sig[2] = {sigma_h + kSigmaFloorM / rho, sigma_v + kSigmaFloorM / rho};
  for (int j = 0; j < 2; ++j) {
    // The angle itself (atan2): a point behind the camera, on the ray's backward extension, is
    // half a turn off, not on the ray.
    const float across = es[j]->dot(x);
    // Small angles (every ray near its fit) need no arctangent: tan is within 1 % below 0.17 rad.
    const bool small = along > 6.f * std::fabs(across);
    const float res = small ? across / along : std::atan2(across, along);
    const float n2 =
        small ? along * along : std::max(across * across + along * along, kMinDepthM * kMinDepthM);
    rr.inv_sigma[j] = 1.f / sig[j];
    rr.jac[j] = (along * *es[j] - across * d) / (n2 * sig[j]);
    rr.res[j] = res / sig[j];
  }
  rr.n = 2;
  if (range > 0.f && range_sigma > 0.f) {
    rr.jac[2] = d / range_sigma;
    rr.res[2] = (d.dot(x) - range) / range_sigma;
    rr.n = 3;
  }
  float chi2 = 0;
  for (int k = 0; k < rr.n; ++k) chi2 += rr.res[k] * rr.res[k];
  return chi2;
}

// The rows' J^T W J (m) and J^T W r (g).
void RayNormal(const RayRows& rr, Eigen::Matrix3f& m, Eigen::Vector3f& g) {
  m.setZero();
  g.setZero();
  for (int k = 0; k < rr.n; ++k) {
    m += rr.jac[k] * rr.jac[k].transpose();
    g += rr.res[k] * rr.jac[k];
  }
}

// Cholesky of the 6x6 normal matrix, written out: Eigen's matrix-right-hand-side solves go
// through its blocked (heap-using) path, and this is all the filter needs. False if not positive
// definite.
bool Cholesky6(const Mat6& h, Mat6& l) {
  l.setZero();
  for (int j = 0; j < 6; ++j) {
    float d = h(j, j);
    for (int k = 0; k < j; ++k) d -= l(j, k) * l(j, k);
    if (!(d > 0.f)) return false;
    l(j, j) = std::sqrt(d);
    for (int i = j + 1; i < 6; ++i) {
      float v = h(i, j);
      for (int k = 0; k < j; ++k) v -= l(i, k) * l(j, k);
      l(i, j) = v / l(j, j);
    }
  }
  return true;
}

Vec6 CholeskySolve(const Mat6& l, const Vec6& b) {
  Vec6 y;
  for (int i = 0; i < 6; ++i) {
    float v = b(i);
    for (int k = 0; k < i; ++k) v -= l(i, k) * y(k);
    y(i) = v / l(i, i);
  }
  for (int i = 5; i >= 0; --i) {
    float v = y(i);
    for (int k = i + 1; k < 6; ++k) v -= l(k, i) * y(k);
    y(i) = v / l(i, i);
  }
  return y;
}

Mat6 CholeskyInverse(const Mat6& l) {
  Mat6 inv;
  for (int c = 0; c < 6; ++c) inv.col(c) = CholeskySolve(l, Vec6::Unit(c));
  return inv;
}

}  // namespace

void BallFilter::Configure(const BallFilterConfig& config) {
  cfg_ = config;
  cfg_.max_window = std::clamp(cfg_.max_window, 4, kMaxWindow);
  noise_dof_ = kNoiseStartRows;
  noise_chi2_ = kNoiseStartRows * NoisePrior();
  seg_noise_ = NoiseShare{};
  for (NoiseShare& n : recent_noise_) n = NoiseShare{};
  b_ = std::clamp(cfg_.bounce_factor, 0.f, 1.f);
  b_samples_ = 0;
  Reset();
}

void BallFilter::Reset() {
  count_ = 0;
  head_ = 0;
  tracking_ = false;
  have_time_ = false;
  observable_ = false;
  cand_valid_ = false;
  off_count_ = 0;
  seg_ = Segment{};
  seg_noise_ = NoiseShare{};
  fit_ = Fit{};
  // b is the ball's and the floor's, not the track's: like the rays' noise level it outlives it.
  b_pending_ = false;
}

const BallFilter::Stored& BallFilter::Newest(int k) const {
  return obs_[(head_ - 1 - k + 2 * kMaxWindow) % kMaxWindow];
}

void BallFilter::Push(const BallObservation& obs) {
  Stored& s = obs_[head_];
  s.t_us = obs.t_us;
  s.n = static_cast<uint8_t>(obs.n_rays);
  for (int i = 0; i < obs.n_rays; ++i) {
    const BallRay& r = obs.rays[i];
    s.rays[i] = StoredRay{r.dir,           r.sigma_h_rad, r.sigma_v_rad, r.range_m,
                          r.range_sigma_m, r.bias_h_rad,  r.bias_v_rad,  r.camera};
  }
  head_ = (head_ + 1) % kMaxWindow;
  count_ = std::min(count_ + 1, cfg_.max_window);
}

// Displacement from the accelerations over tau (relative to p + v tau, v the velocity at the
// reference time). Air: gravity and drag at the midpoint velocity (second order over the window).
// Rolling: constant deceleration along the motion, from a reference velocity (tau <= 0 in fits,
// so a ball that has come to rest is not run backwards through its stop).
void BallFilter::Accel(Motion m, const Eigen::Vector3f& v_ref, float tau, Eigen::Vector3f& a,
                       Eigen::Vector3f& dv) const {
  if (m == Motion::kAir) {
    const Eigen::Vector3f g(0, 0, -cfg_.gravity_mps2);
    const Eigen::Vector3f vm = v_ref + 0.5f * tau * g;
    const Eigen::Vector3f acc = g - cfg_.drag_per_m * vm.norm() * vm;
    a = 0.5f * tau * tau * acc;
    dv = tau * acc;
    return;
  }
  const float s = std::hypot(v_ref.x(), v_ref.y());
  if (s < kRestSpeedMps) {
    a.setZero();
    dv.setZero();
    return;
  }
  const float d = cfg_.rolling_decel_mps2 + cfg_.drag_per_m * s * s;
  const Eigen::Vector3f u(v_ref.x() / s, v_ref.y() / s, 0.f);
  a = u * (-0.5f * d * tau * tau);
  dv = u * (-d * tau);
}

namespace {

// One term of the normal equations at the reference state (p0, v0): m and gp of a position at
// tau seconds from it, p = p0 + v0 tau (+ the motion's own terms).
inline void AddTerm(float tau, const Eigen::Matrix3f& m, const Eigen::Vector3f& gp, Mat6& h,
                    Vec6& g) {
  h.block<3, 3>(0, 0) += m;
  h.block<3, 3>(0, 3) += tau * m;
  h.block<3, 3>(3, 0) += tau * m;
  h.block<3, 3>(3, 3) += tau * tau * m;
  g.head<3>() += gp;
  g.tail<3>() += tau * gp;
}

}  // namespace

// The previous segment's state at the contact, p(tau_c) and v(tau_c) of this segment; the rolling
// constraints; the damping that keeps an unobserved direction finite.
void BallFilter::AddPriorAndConstraints(const Segment& seg, const Vec6& x, Mat6& h, Vec6& g) const {
  const Eigen::Vector3f p0 = x.head<3>(), v0 = x.tail<3>();
  if (seg.has_prior) {
    const float tau = Seconds(seg.prior_us, t_ref_us_);
    Eigen::Vector3f a, adot;
    Accel(seg.motion, v0, tau, a, adot);
    Eigen::Matrix3f mp = Eigen::Matrix3f::Zero(), mv = Eigen::Matrix3f::Zero();
    Eigen::Vector3f rp, rv;
    for (int j = 0; j < 3; ++j) {
      mp(j, j) = 1.f / (seg.prior_sigma[j] * seg.prior_sigma[j]);
      mv(j, j) = 1.f / (seg.prior_sigma[3 + j] * seg.prior_sigma[3 + j]);
      rp(j) = p0(j) + v0(j) * tau + a(j) - seg.prior_mean[j];
      rv(j) = v0(j) + adot(j) - seg.prior_mean[3 + j];
    }
    AddTerm(tau, mp, mp * rp, h, g);
    h.block<3, 3>(3, 3) += mv;
    g.tail<3>() += mv * rv;
  }
  if (seg.motion == Motion::kRolling) {
    h(2, 2) += kConstraintWeight;
    h(5, 5) += kConstraintWeight;
    if (seg.at_rest) {
      h(3, 3) += kConstraintWeight;
      h(4, 4) += kConstraintWeight;
    }
  }
  for (int j = 0; j < 3; ++j) {
    h(j, j) += kRegPos;
    h(3 + j, 3 + j) += kRegVel;
  }
}

// Gauss-Newton over the segment's rays (angular residuals), its prior and its constraints, from
// the nominal state at t_ref_us_; a small damping keeps an unobserved direction where it was.
BallFilter::Fit BallFilter::Solve(const Segment& seg, const Vec6& nominal, uint64_t end_us,
                                  int iterations) const {
  Fit f;
  Vec6 x = nominal;
  const float r0 = cfg_.ball_radius_m;
  auto constrain = [&](Vec6& v) {
    if (seg.motion != Motion::kRolling) return;
    v(2) = r0;
    v(5) = 0;
    if (seg.at_rest) v(3) = v(4) = 0;
  };
  constrain(x);
  Mat6 h;
  int rows = 0;
  Eigen::Matrix<float, 6, 4> bias_g;  // the gradient's response to each shared ray error
  for (int it = 0; it < iterations; ++it) {
    // The covariance comes from the last iteration's normal matrix, and so does its bias part.
    const bool last = it + 1 == iterations;
    h.setZero();
    Vec6 g = Vec6::Zero();
    bias_g.setZero();
    rows = 0;
    const Eigen::Vector3f p0 = x.head<3>(), v0 = x.tail<3>();
    for (int i = 0; i < count_; ++i) {
      const Stored& s = Newest(i);
      if (s.t_us < seg.start_us) break;
      if (s.t_us > end_us) continue;
      const float tau = Seconds(s.t_us, t_ref_us_);
      if (last && s.n > 0) f.span_s = std::max(f.span_s, -tau);
      Eigen::Vector3f a, dv;
      Accel(seg.motion, v0, tau, a, dv);
      const Eigen::Vector3f p = p0 + v0 * tau + a;
      for (int k = 0; k < s.n; ++k) {
        const StoredRay& r = s.rays[k];
        RayRows rr;
        const float chi = RayRowsAt(p - origin_[r.camera], r.dir, r.sigma_h, r.sigma_v, r.range,
                                    r.range_sigma, rr);
        const int nr = rr.n;
        Eigen::Matrix3f m;
        Eigen::Vector3f gp;
        RayNormal(rr, m, gp);
        // Huber: one wrong ray bends the fit only linearly.
        const float z = std::sqrt(chi / static_cast<float>(nr));
        const float huber = z > kHuberSigma ? kHuberSigma / z : 1.f;
        m *= huber;
        gp *= huber;
        AddTerm(tau, m, gp, h, g);
        const float b[2] = {r.bias_h, r.bias_v};
        for (int j = 0; last && j < 2; ++j) {
          const Eigen::Vector3f c = huber * b[j] * rr.inv_sigma[j] * rr.jac[j];
          bias_g.col(2 * r.camera + j).head<3>() += c;
          bias_g.col(2 * r.camera + j).tail<3>() += tau * c;
        }
        rows += nr;
      }
    }
    AddPriorAndConstraints(seg, x, h, g);
    Mat6 l;
    if (!Cholesky6(h, l)) return f;
    const Vec6 step = CholeskySolve(l, g);
    if (!step.allFinite()) return f;
    x -= step;
    constrain(x);
  }
  f.x = x;
  Mat6 l;
  if (!Cholesky6(h, l)) return f;
  f.cov = CholeskyInverse(l);
  f.bias = f.cov * bias_g;
  if (!f.x.allFinite() || !f.cov.allFinite() || !f.bias.allFinite()) return f;
  f.rows = rows;
  for (int i = 0; i < count_; ++i) {
    if (Newest(i).t_us < seg.start_us) break;
    if (Newest(i).t_us > end_us) continue;
    f.chi2 += ObsChi2(Newest(i), seg, f.x, t_ref_us_);
  }
  const int dof = rows - (seg.motion == Motion::kAir ? 6 : seg.at_rest ? 2 : 4);
  if (dof > 0 && f.chi2 > static_cast<float>(dof)) {
    f.inflation = f.chi2 / static_cast<float>(dof);
    f.cov *= f.inflation;
  }
  // Quieter residuals than the model: a variance factor, pulled by kNoisePriorRows rows towards
  // the level the rays have shown over recent frames, so a few lucky frames (a segment's first)
  // do not claim precision the cameras have not shown, nor lose what they have.
  f.quiet_scale = std::clamp((f.chi2 + kNoisePriorRows * noise_level()) /
                                 (static_cast<float>(std::max(dof, 0)) + kNoisePriorRows),
                             kMinQuietScale, 1.f);
  f.ok = true;
  return f;
}

float BallFilter::ObsChi2(const Stored& s, const Segment& seg, const Vec6& x,
                          uint64_t t_ref) const {
  const float tau = Seconds(s.t_us, t_ref);
  Eigen::Vector3f a, dv;
  Accel(seg.motion, x.tail<3>(), tau, a, dv);
  const Eigen::Vector3f p = x.head<3>() + x.tail<3>() * tau + a;
  float chi2 = 0;
  for (int k = 0; k < s.n; ++k) {
    const StoredRay& r = s.rays[k];
    RayRows rr;
    chi2 +=
        RayRowsAt(p - origin_[r.camera], r.dir, r.sigma_h, r.sigma_v, r.range, r.range_sigma, rr);
  }
  return chi2;
}

// A fit is physically possible only with the ball outside the robot and in front of every camera
// that sees it now (a single camera's rays all meet at its centre: a degenerate "solution").
bool BallFilter::Plausible(const Fit& f) const {
  if (!f.ok) return false;
  const Eigen::Vector3f p = f.x.head<3>();
  const float d = p.head<2>().norm();
  if (d < cfg_.robot_radius_m || d > cfg_.max_range_m || p.z() > cfg_.max_height_m) return false;
  const Stored& s = Newest(0);
  for (int k = 0; k < s.n; ++k) {
    if ((p - origin_[s.rays[k].camera]).dot(s.rays[k].dir) < cfg_.robot_radius_m) return false;
  }
  return true;
}

// A point estimate of one frame's observation (starting a track, checking a jump): the midpoint
// of the two rays (eq. 2), the persp ray at its size range, or an omni ray on the floor.
bool BallFilter::PointOf(const BallObservation& obs, Eigen::Vector3f& p) const {
  const float r = cfg_.ball_radius_m;
  if (obs.n_rays == 2) {
    const BallRay &a = obs.rays[0], &b = obs.rays[1];
    const Eigen::Vector3f w = a.origin - b.origin;
    const float ab = a.dir.dot(b.dir), den = 1.f - ab * ab;
    if (den > 1e-5f) {
      const float s = (ab * b.dir.dot(w) - a.dir.dot(w)) / den;
      const float t = (b.dir.dot(w) - ab * a.dir.dot(w)) / den;
      if (s > 0.f && t > 0.f) {
        p = 0.5f * (a.origin + s * a.dir + b.origin + t * b.dir);
        return Finite(p);
      }
    }
  }
  for (int i = 0; i < obs.n_rays; ++i) {
    const BallRay& ray = obs.rays[i];
    if (ray.range_m > 0.f) {
      p = ray.origin + ray.dir * ray.range_m;
      return Finite(p);
    }
  }
  // One ray: on the floor if it meets the floor within reach, else (a ball in the air above the
  // floor's horizon) at a nominal depth; the fit decides, flagged unobservable until it can.
  const BallRay& ray = obs.rays[0];
  float depth = kUnknownDepthM;
  if (ray.dir.z() < -1e-3f && ray.origin.z() > r) {
    const float floor_depth = (r - ray.origin.z()) / ray.dir.z();
    if ((ray.dir * floor_depth).head<2>().norm() <= cfg_.max_range_m) depth = floor_depth;
  }
  p = ray.origin + ray.dir * depth;
  return Finite(p);
}

void BallFilter::StartTrack(const BallObservation& obs) {
  count_ = 0;
  tracking_ = true;
  off_count_ = 0;
  cand_valid_ = false;
  b_pending_ = false;
  Eigen::Vector3f p0 = Eigen::Vector3f::Zero();
  PointOf(obs, p0);
  seg_ = Segment{};
  seg_noise_ = NoiseShare{};
  seg_.start_us = track_start_us_ = obs.t_us;
  seg_.motion = p0.z() - cfg_.ball_radius_m < cfg_.roll_tolerance_m + 0.01f * p0.head<2>().norm()
                    ? Motion::kRolling
                    : Motion::kAir;
  Push(obs);
  t_ref_us_ = obs.t_us;
  Vec6 nominal = Vec6::Zero();
  for (int j = 0; j < 3; ++j) nominal(j) = p0(j);
  fit_ = Solve(seg_, nominal, UINT64_MAX, kColdIterations);
  // Two rays fix the height: a start "near the floor" by the distance-grown tolerance (a 21 cm
  // ball at 5 m passes) is on the floor only if the floor explains the rays about as well as a
  // free point. Else the floor fit slides the ball along the rays (1.2 m at 5 m on a render).
  if (fit_.ok && seg_.motion == Motion::kRolling && obs.n_rays == 2) {
    Segment air = seg_;
    air.motion = Motion::kAir;
    const Fit free = Solve(air, nominal, UINT64_MAX, kColdIterations);
    if (free.ok && fit_.chi2 - free.chi2 > kFloorChi2) {
      seg_ = air;
      fit_ = free;
    }
  }
  if (!fit_.ok) tracking_ = false;
}

// A floor fit of a ball in the air runs far out along near-horizontal rays: the flight is fitted
// from the current state and from nearer points on the newest ray (at rest); the best plausible
// fit wins.
BallFilter::Fit BallFilter::SolveFlight(const Segment& seg) const {
  // Only the best fit is kept whole (stack: this runs deep in the frame's call chain); the others'
  // position and chi^2 tell whether the rays are ambiguous.
  Fit best;
  Eigen::Vector3f where[3];
  float chi2[3];
  bool plausible[3];
  const Stored& nw = Newest(0);
  // Frames seen by both cameras fix the positions by themselves: the current state is start
  // enough, and the other starts (each a cold fit) would only find the same flight.
  int stereo = 0;
  for (int i = 0; i < count_ && Newest(i).t_us >= seg.start_us; ++i) stereo += Newest(i).n > 1;
  const int starts = stereo >= kStereoFramesForOneStart ? 1 : 3;
  for (int i = 0; i < starts; ++i) {
    Vec6 start = fit_.x;
    if (i > 0) {
      start.setZero();
      start.head<3>() = origin_[nw.rays[0].camera] + nw.rays[0].dir * (i == 1 ? 2.f : 5.f);
    }
    const Fit f = Solve(seg, start, UINT64_MAX, kColdIterations);
    plausible[i] = Plausible(f);
    where[i] = f.x.head<3>();
    chi2[i] = f.chi2;
    if (i == 0 || (plausible[i] && (!Plausible(best) || f.chi2 < best.chi2))) best = f;
  }
  // Another plausible flight nearly as good but elsewhere: the rays cannot tell them apart yet.
  for (int i = 0; i < starts; ++i) {
    if (plausible[i] && chi2[i] < best.chi2 + kAmbiguousChi2 &&
        (where[i] - best.x.head<3>()).norm() > cfg_.unobservable_sigma_m) {
      best.ambiguous = true;
    }
  }
  return best;
}

uint16_t BallFilter::UpdateObservable() {
  const float pos_var = fit_.cov(0, 0) + fit_.cov(1, 1) + fit_.cov(2, 2);
  observable_ = tracking_ && fit_.ok && !fit_.ambiguous &&
                pos_var < cfg_.unobservable_sigma_m * cfg_.unobservable_sigma_m;
  return observable_ ? 0 : kFlagUnobservable;
}

bool BallFilter::SwitchToFlight(float max_speed_mps) {
  Segment air = seg_;
  air.motion = Motion::kAir;
  air.at_rest = false;
  const Fit f = SolveFlight(air);
  if (!Plausible(f) || f.x.tail<3>().norm() > max_speed_mps) return false;
  seg_ = air;
  fit_ = f;
  RetractSegmentNoise();
  return true;
}

void BallFilter::Refit() {
  const Fit f = Solve(seg_, fit_.x);
  if (Plausible(f)) {
    fit_ = f;
    return;
  }
  // Gauss-Newton from a poor state can land behind a camera or inside the robot, and a floor fit
  // of a ball in the air runs out along near-horizontal rays: the flight fitted from points on
  // the rays, else the frame alone.
  if (SwitchToFlight(std::numeric_limits<float>::infinity())) return;
  BallObservation newest;
  newest.t_us = Newest(0).t_us;
  newest.n_rays = Newest(0).n;
  for (int k = 0; k < newest.n_rays; ++k) {
    const StoredRay& r = Newest(0).rays[k];
    BallRay& out = newest.rays[k];
    out.origin = origin_[r.camera];
    out.dir = r.dir;
    out.sigma_h_rad = r.sigma_h;
    out.sigma_v_rad = r.sigma_v;
    out.range_m = r.range;
    out.range_sigma_m = r.range_sigma;
    out.camera = r.camera;
  }
  StartTrack(newest);
}

// Bounce check before the newest observation (already pushed) is fitted: the current arc meets
// the floor before it. The rebound (Rebound: b vertically, friction on the slip horizontally)
// starts a new segment with the contact as its prior, if the new frame fits it better than the
// arc continued through the floor.
bool BallFilter::TryBounce(uint64_t t_new_us) {
  if (seg_.motion != Motion::kAir || !fit_.ok) return false;
  const float dt = Seconds(t_new_us, t_ref_us_);
  Eigen::Vector3f p = fit_.x.head<3>(), v = fit_.x.tail<3>();
  const float r = cfg_.ball_radius_m, g = cfg_.gravity_mps2;
  if (v.z() >= 0.f && p.z() > r) {
    // Still rising: can it come down before t_new at all?
    if (v.z() / g >= dt) return false;
  }
  uint64_t tc = 0;
  float cx = 0, cy = 0;
  int nc = 0;
  Eigen::Vector3f pe, ve;
  BallMode mode;
  // Find the first contact in (t_ref, t_new]: evolve the arc without its bounces.
  Evolve(dt, pe, ve, mode, &tc, &cx, &cy, 1, nc);
  if (nc == 0 || tc > t_new_us) return false;
  // State just before the contact on the current arc.
  const float tau_c = Seconds(tc, t_ref_us_);
  Eigen::Vector3f a, adot;
  Accel(Motion::kAir, v, tau_c, a, adot);
  const Eigen::Vector3f pc = p + v * tau_c + a;
  const Eigen::Vector3f vin = v + adot;
  if (vin.z() >= 0.f) return false;
  Segment next;
  next.start_us = tc;
  next.has_prior = true;
  next.prior_us = tc;
  next.v_in_z = -vin.z();
  next.v_in_xy = vin.head<2>();
  next.spin_in = seg_.spin;
  Eigen::Vector3f vout;
  next.grip = Rebound(vin, seg_.spin, vout, next.spin);
  next.motion = vout.z() < cfg_.min_bounce_vz_mps ? Motion::kRolling : Motion::kAir;
  next.bounced = next.motion == Motion::kAir;
  if (next.motion == Motion::kRolling) vout.z() = 0.f;
  const Eigen::Vector3f pos_sig(std::sqrt(std::max(fit_.cov(0, 0), 0.f)) + 0.03f,
                                std::sqrt(std::max(fit_.cov(1, 1), 0.f)) + 0.03f, 0.01f);
  for (int j = 0; j < 3; ++j) {
    next.prior_mean[j] = j == 2 ? r : pc(j);
    next.prior_mean[3 + j] = vout(j);
    next.prior_sigma[j] = pos_sig(j);
  }
  // The rebound is known as well as what went into it: the spin (none assumed after a kick) and
  // b (the configured value until a rebound has been fitted).
  next.spin_known = next.grip || seg_.spin_known;
  const float v_in_h = std::hypot(vin.x(), vin.y());
  next.prior_sigma[3] = next.prior_sigma[4] =
      seg_.spin_known ? 0.1f * v_in_h + 0.1f : 0.3f * v_in_h + 0.2f;
  next.prior_sigma[5] = b_samples_ > 0 ? 0.12f * next.v_in_z + 0.1f : 0.25f * next.v_in_z + 0.2f;
  // Compare on the newest frame: old arc continued vs the rebound's prior.
  const Stored& s = Newest(0);
  const float chi_old = ObsChi2(s, seg_, fit_.x, t_ref_us_);
  Vec6 xr;
  const float tr = Seconds(t_ref_us_, tc);  // reference state of the rebound at t_ref (tr <= 0)
  Eigen::Vector3f ar, ardot;
  Accel(next.motion, vout, tr, ar, ardot);
  xr.head<3>() = Eigen::Vector3f(next.prior_mean[0], next.prior_mean[1], r) + vout * tr + ar;
  xr.tail<3>() = vout + ardot;
  const float chi_new = ObsChi2(s, next, xr, t_ref_us_);
  if (!(chi_new < chi_old)) return false;
  seg_ = next;
  seg_noise_ = NoiseShare{};
  b_pending_ = next.motion == Motion::kAir && next.v_in_z > 1.f;
  // The rebound's state at the new reference time is the nominal for the refit.
  const float tn = Seconds(t_new_us, tc);
  Accel(next.motion, vout, tn, ar, ardot);
  fit_.x.head<3>() = Eigen::Vector3f(pc.x(), pc.y(), r) + vout * tn + ar;
  fit_.x.tail<3>() = vout + ardot;
  if (next.motion == Motion::kRolling) {
    fit_.x(2) = r;
    fit_.x(5) = 0;
  }
  return true;
}

// The rays worth fitting: finite, unit, not steeply up, not into the robot's own body; a range
// cue only when it is finite and positive.
void BallFilter::ValidRays(const BallObservation& in, BallObservation& obs) const {
  obs.t_us = in.t_us;
  const float r = cfg_.ball_radius_m;
  for (int i = 0; i < std::min(in.n_rays, BallObservation::kMaxRays); ++i) {
    BallRay ray = in.rays[i];
    const float n = ray.dir.norm();
    if (!Finite(ray.origin) || !std::isfinite(n) || n < 0.5f || ray.camera > 1 ||
        !(ray.sigma_h_rad > 0.f) || !(ray.sigma_v_rad > 0.f) || !std::isfinite(ray.sigma_h_rad) ||
        !std::isfinite(ray.sigma_v_rad)) {
      continue;
    }
    ray.dir /= n;
    if (ray.dir.z() > kMaxUpwardDirZ) continue;
    if (ray.dir.z() < -1e-3f && ray.origin.z() > r) {
      const Eigen::Vector3f f = ray.origin + ray.dir * ((r - ray.origin.z()) / ray.dir.z());
      if (f.head<2>().norm() < cfg_.robot_radius_m) continue;
    }
    if (!(std::isfinite(ray.range_m) && std::isfinite(ray.range_sigma_m) && ray.range_m > 0.f &&
          ray.range_sigma_m > 0.f)) {
      ray.range_m = ray.range_sigma_m = 0.f;
    }
    // A shared error no larger than the ray's own; one that is not a number is none.
    ray.bias_h_rad =
        std::isfinite(ray.bias_h_rad) ? std::clamp(ray.bias_h_rad, 0.f, ray.sigma_h_rad) : 0.f;
    ray.bias_v_rad =
        std::isfinite(ray.bias_v_rad) ? std::clamp(ray.bias_v_rad, 0.f, ray.sigma_v_rad) : 0.f;
    obs.rays[obs.n_rays++] = ray;
  }
}

// Each ray against the prediction: the ones within the gate go to `kept`. Returns the largest
// kept ray's distance from the prediction, in ray sigmas.
float BallFilter::GateRays(const BallObservation& obs, BallObservation& kept) const {
  Eigen::Vector3f pp, vp, sp;
  BallMode mp;
  StateAt(obs.t_us, pp, vp, mp);
  SigmaAt(obs.t_us, sp, false);
  const float dt = Seconds(obs.t_us, t_ref_us_);
  kept.t_us = obs.t_us;
  float off = 0;
  for (int i = 0; i < obs.n_rays; ++i) {
    const BallRay& ray = obs.rays[i];
    const Eigen::Vector3f w = pp - ray.origin;
    const float along = w.dot(ray.dir);
    const float dist = along > 0.f ? (w - along * ray.dir).norm() : w.norm();
    const float ray_sigma = std::max(ray.sigma_h_rad, ray.sigma_v_rad) * std::max(along, 0.f);
    float gate =
        cfg_.gate_min_m + cfg_.outlier_growth_mps * dt + cfg_.gate_sigmas * (sp.norm() + ray_sigma);
    // Range along the rays unknown: only the direction to the prediction can be checked.
    if (!observable_) gate = std::max(gate, kUnobservableGateRad * w.norm());
    if (dist <= gate) {
      kept.rays[kept.n_rays++] = ray;
      off = std::max(off, dist / (ray_sigma + kSigmaFloorM));
    }
  }
  return off;
}

// No ray within the gate. A jump: confirmed when the next frame agrees with it, then the track
// restarts there; otherwise the frame is kept as the candidate for that.
uint16_t BallFilter::ConfirmJump(const BallObservation& obs, bool have_point,
                                 const Eigen::Vector3f& point) {
  Eigen::Vector3f pc;
  if (cand_valid_ && have_point && PointOf(cand_, pc) &&
      (pc - point).norm() <
          cfg_.outlier_error_m * 0.5f + cfg_.outlier_growth_mps * Seconds(obs.t_us, cand_.t_us)) {
    const BallObservation first = cand_;
    StartTrack(first);
    if (tracking_) {
      Push(obs);
      t_ref_us_ = obs.t_us;
      Refit();
      return UpdateObservable();
    }
    return kFlagOutlierRejected;
  }
  cand_ = obs;
  cand_valid_ = have_point;
  return kFlagOutlierRejected;
}

uint16_t BallFilter::Update(const BallObservation& in) {
  if (have_time_ && in.t_us <= last_t_us_) return kFlagBadTimestamp;
  BallObservation obs;
  ValidRays(in, obs);
  if (obs.n_rays == 0) return in.n_rays > 0 ? kFlagOutlierRejected : 0;
  Eigen::Vector3f point;
  const bool have_point = PointOf(obs, point);
  // Beyond any field (a lone omni ray's floor point says nothing of a ball in the air).
  const bool point_measured = obs.n_rays == 2 || obs.rays[0].range_m > 0.f;
  if (have_point && point_measured &&
      (point.head<2>().norm() > cfg_.max_range_m || point.z() > cfg_.max_height_m)) {
    return kFlagOutOfField;
  }
  have_time_ = true;
  last_t_us_ = obs.t_us;
  for (int i = 0; i < obs.n_rays; ++i) origin_[obs.rays[i].camera] = obs.rays[i].origin;

  if (!tracking_ || obs.t_us > t_ref_us_ + cfg_.coast_us) {
    if (!have_point) return kFlagOutlierRejected;
    StartTrack(obs);
    if (!tracking_) return kFlagOutlierRejected;
    LearnRayNoise();
    return UpdateObservable();
  }
  BallObservation kept;
  const float off = GateRays(obs, kept);
  if (kept.n_rays == 0) return ConfirmJump(obs, have_point, point);
  cand_valid_ = false;

  Push(kept);
  const bool bounced = TryBounce(obs.t_us);
  // Nominal at the new reference time: the current model moved forward. A flight that took no
  // bounce goes on as the arc the refit fits, through the floor if need be: a frame at the
  // contact itself can fit it as well as the rebound, and a nominal past the rebound (as the
  // prediction evolves it) sent the refit to a false minimum (bounce seed 139: vz -5.3 for -4.5
  // m/s at the first contact, so b was fitted 0.64 for 0.74).
  if (fit_.ok && !bounced) {
    Eigen::Vector3f p1, v1;
    BallMode m1;
    if (seg_.motion == Motion::kAir) {
      Eigen::Vector3f a, adot;
      const float dt = Seconds(obs.t_us, t_ref_us_);
      Accel(Motion::kAir, fit_.x.tail<3>(), dt, a, adot);
      fit_.x.head<3>() += fit_.x.tail<3>() * dt + a;
      fit_.x.tail<3>() += adot;
    } else if (StateAt(obs.t_us, p1, v1, m1)) {
      fit_.x.head<3>() = p1;
      fit_.x.tail<3>() = v1;
    }
  }
  t_ref_us_ = obs.t_us;
  Refit();
  CheckModel(off);
  LearnRayNoise();
  if (!fit_.x.allFinite() || !fit_.cov.allFinite()) {
    Reset();
    return kFlagOutlierRejected;
  }
  if (fit_.x.tail<3>().norm() > cfg_.max_speed_mps) {
    // No ball moves like that. A floor fit of one camera's rays of a ball in the air runs away
    // along them: a flight over the same frames may explain them. Otherwise the frames disagree
    // beyond any motion (a wrong detection before): start again from this frame.
    if (!SwitchToFlight(cfg_.max_speed_mps)) {
      RetractSegmentNoise();
      StartTrack(kept);
    }
  }
  return UpdateObservable();
}

// Model checks on the segment's frames after the refit; `off` is the new frame's distance from
// the prediction (ray sigmas).
void BallFilter::CheckModel(float off) {
  int seg_frames = 0;
  for (int i = 0; i < count_ && Newest(i).t_us >= seg_.start_us; ++i) ++seg_frames;
  off_count_ = off > kOffSigma ? off_count_ + 1 : 0;
  bool switched = SwitchRollingFlying(seg_frames);
  if (!switched && off_count_ >= 2 && seg_frames > 2) switched = RestartSegment(seg_frames);
  if (!switched) CheckAtRest(seg_frames);
  EstimateRestitution(seg_frames);
}

// Rolling vs flying over the same frames: a ball that left the floor (or a flight that turns out
// to hug it). Checked only when the current model fits worse than the ray noise, or when a flight
// is near the floor and slow (cheap tests first: each fit is a few hundred rays).
bool BallFilter::SwitchRollingFlying(int seg_frames) {
  const float r = cfg_.ball_radius_m;
  const int dof = fit_.rows - (seg_.motion == Motion::kAir ? 6 : 4);
  const bool poor_fit = fit_.chi2 > kModelCheckChi2PerDof * static_cast<float>(std::max(dof, 1));
  const bool low_flight = seg_.motion == Motion::kAir && fit_.x(2) < r + cfg_.roll_tolerance_m &&
                          std::fabs(fit_.x(5)) < cfg_.min_bounce_vz_mps;
  // One camera's rays of a rising ball can fit the floor model well: checked every frame.
  const bool one_camera = Newest(0).n == 1;
  if (seg_frames < 2 || !(seg_.motion == Motion::kRolling ? poor_fit || one_camera : low_flight)) {
    return false;
  }
  Segment other = seg_;
  other.motion = seg_.motion == Motion::kRolling ? Motion::kAir : Motion::kRolling;
  other.at_rest = false;
  if (other.motion == Motion::kRolling) {
    other.has_prior = false;
    other.bounced = false;
  }
  const Fit fo = other.motion == Motion::kAir ? SolveFlight(other) : Solve(other, fit_.x);
  if (!Plausible(fo)) return false;
  if (other.motion == Motion::kAir) {
    if (fo.chi2 + cfg_.model_switch_chi2 < fit_.chi2 && fo.x(2) > r + cfg_.roll_tolerance_m) {
      seg_ = other;
      fit_ = fo;
      RetractSegmentNoise();
      return true;
    }
  }
  // A rebound's apex is a low, slow flight too, and one camera's rays fit the floor nearly as
  // well (sliding ~20 cm along them at 3 m): the contacts say when it stops bouncing, so only a
  // clearly better floor fit ends it early.
  const float roll_gain = seg_.bounced ? -cfg_.model_switch_chi2 : 2.f;
  if (other.motion == Motion::kRolling && seg_frames >= 4 && fo.chi2 <= fit_.chi2 + roll_gain &&
      std::fabs(fit_.x(5)) < cfg_.min_bounce_vz_mps && fit_.x(2) < r + cfg_.roll_tolerance_m) {
    seg_ = other;
    fit_ = fo;
    b_pending_ = false;
    RetractSegmentNoise();
    return true;
  }
  return false;
}

// Has the motion changed (kick, deflection, an unseen bounce)? A likelihood-ratio test on the
// frames since the first that disagreed: a new segment there (continuous in position, free in
// velocity; rolling unless flying is clearly better) must explain them much better.
bool BallFilter::RestartSegment(int seg_frames) {
  Segment cand[2];
  Fit fits[2];
  const int n_off = std::min(off_count_, seg_frames - 1);
  const uint64_t start = Newest(n_off - 1).t_us;
  // The segment as it is, against the segment cut before `start` plus a new one after it.
  const Fit before = Solve(seg_, fit_.x, Newest(n_off).t_us);
  for (int m = 0; m < 2; ++m) {
    cand[m].motion = m == 0 ? Motion::kRolling : Motion::kAir;
    cand[m].start_us = start;
    fits[m] = Solve(cand[m], fit_.x);
  }
  // Flying needs a clear gain, and enough rows to be determined at all (6 unknowns + 2).
  const bool air_ok = Plausible(fits[1]) && fits[1].rows >= 8;
  const int pick =
      fits[0].ok && (!air_ok || fits[0].chi2 <= fits[1].chi2 + cfg_.model_switch_chi2) ? 0 : 1;
  const float chi_old = fit_.chi2, chi_split = before.chi2 + fits[pick].chi2;
  if (!(before.ok && Plausible(fits[pick]) && fits[pick].rows >= 6 &&
        chi_split + cfg_.restart_chi2 < chi_old)) {
    return false;
  }
  seg_ = cand[pick];
  fit_ = fits[pick];
  b_pending_ = false;
  off_count_ = 0;
  RetractRecentNoise(n_off - 1);  // the newest frame, off too, is not learned yet
  return true;
}

// Has a slow rolling ball stopped? Over its last frames (>= kRestFrames, >= 0.25 s), a ball at
// rest must fit as well as a free rolling one (two parameters fewer).
void BallFilter::CheckAtRest(int seg_frames) {
  if (seg_.motion != Motion::kRolling || seg_.at_rest ||
      !(std::hypot(fit_.x(3), fit_.x(4)) < kStopCheckSpeedMps)) {
    return;
  }
  int k = 0;
  while (k < seg_frames && (k < kRestFrames || Seconds(t_ref_us_, Newest(k).t_us) < 0.25f)) ++k;
  if (k < seg_frames || k == count_) {
    Segment rest = seg_, roll = seg_;
    rest.at_rest = true;
    rest.has_prior = roll.has_prior = false;
    rest.start_us = roll.start_us = Newest(k - 1).t_us;
    const Fit fr = Solve(rest, fit_.x);
    const Fit fm = Solve(roll, fit_.x);
    if (fr.ok && fm.ok && fr.chi2 <= fm.chi2 + 6.f) {
      seg_ = rest;
      fit_ = fr;
    }
  }
}

// Restitution from a rebound seen long enough: its fitted take-off speed over the speed in.
void BallFilter::EstimateRestitution(int seg_frames) {
  if (!(b_pending_ && seg_.bounced && seg_frames >= 5 && cfg_.estimate_bounce_factor)) return;
  const float since = Seconds(t_ref_us_, seg_.start_us);
  const float vz_out = fit_.x(5) + cfg_.gravity_mps2 * since;
  const float b_est = vz_out / seg_.v_in_z;
  if (b_est > cfg_.min_bounce_factor && b_est < cfg_.max_bounce_factor) {
    // The first observed rebound replaces the configured value; later ones are averaged in, the
    // last kRestitutionMemory of them (a new ball or a softer one is followed within a match).
    const float n = static_cast<float>(std::min(b_samples_, kRestitutionMemory - 1));
    b_ = (b_ * n + b_est) / (n + 1.f);
    ++b_samples_;
    // The spin the rebound carries to the next contact, from its fitted horizontal take-off
    // velocity (drag undone to first order): a contact that gripped leaves the ball rolling
    // (spin = that velocity, whatever spin it came in with); a sliding one gave it the friction
    // impulse, the change in horizontal velocity, over the inertia ratio.
    const Eigen::Vector2f v_h = fit_.x.segment<2>(3);
    const Eigen::Vector2f v_out = v_h * (1.f + cfg_.drag_per_m * fit_.x.tail<3>().norm() * since);
    seg_.spin_known = true;
    seg_.spin = seg_.grip
                    ? v_out
                    : Eigen::Vector2f(seg_.spin_in + (seg_.v_in_xy - v_out) /
                                                         std::max(cfg_.ball_inertia_ratio, 0.1f));
  }
  b_pending_ = false;
}

// Vertically v_out = b |v_in|. Horizontally the contact point slips at v - spin; friction
// (impulse up to mu (1 + b) m |vz|) cuts the slip, at most until the ball rolls: with
// I = alpha m r^2 that takes the velocity change alpha / (1 + alpha) of the slip, and leaves
// v_out = spin_out = (v + alpha spin) / (1 + alpha) (3/5 of the velocity for a thin shell
// without spin, all of it for a ball that already rolls).
bool BallFilter::Rebound(const Eigen::Vector3f& v_in, const Eigen::Vector2f& spin_in,
                         Eigen::Vector3f& v_out, Eigen::Vector2f& spin_out) const {
  const float alpha = std::max(cfg_.ball_inertia_ratio, 0.1f);
  const Eigen::Vector2f slip = v_in.head<2>() - spin_in;
  const float s = slip.norm();
  const float dv_roll = s * alpha / (1.f + alpha);
  const float dv_max = std::max(cfg_.bounce_friction_mu, 0.f) * (1.f + b_) * std::fabs(v_in.z());
  const bool grip = dv_roll <= dv_max;
  const Eigen::Vector2f dv =
      s > 1e-6f ? Eigen::Vector2f(slip * (std::min(dv_roll, dv_max) / s)) : Eigen::Vector2f::Zero();
  v_out.head<2>() = v_in.head<2>() - dv;
  v_out.z() = b_ * std::fabs(v_in.z());
  spin_out = grip ? Eigen::Vector2f(v_out.head<2>()) : Eigen::Vector2f(spin_in + dv / alpha);
  return grip;
}

// Forward in time from the reference state, piecewise closed form: arcs (gravity, drag at the
// midpoint velocity) to each floor contact, the rebound, then rolling with deceleration to rest.
void BallFilter::Evolve(float dt_s, Eigen::Vector3f& p, Eigen::Vector3f& v, BallMode& mode,
                        uint64_t* contacts, float* cx, float* cy, int max_contacts,
                        int& n_contacts) const {
  n_contacts = 0;
  p = fit_.x.head<3>();
  v = fit_.x.tail<3>();
  Motion motion = seg_.motion;
  bool bounced = seg_.bounced;
  Eigen::Vector2f spin = seg_.spin;
  const float r = cfg_.ball_radius_m, g = cfg_.gravity_mps2;
  float t = 0;
  for (int k = 0; k <= kMaxContacts; ++k) {
    const float left = dt_s - t;
    if (motion == Motion::kAir) {
      // Time to the floor: the parabola's root, refined twice with the drag at that time. A fit
      // at or just below the floor and not rising is at its contact now (its parabola may have
      // no root above the floor at all).
      float az = -g, tc = -1;
      if (p.z() <= r && v.z() <= 0.f) {
        tc = 0.f;
      } else {
        for (int it = 0; it < 3; ++it) {
          const float disc = v.z() * v.z() - 2.f * az * (p.z() - r);
          if (disc < 0.f || az >= 0.f) break;
          const float t_new = (-v.z() - std::sqrt(disc)) / az;
          if (!(t_new >= 0.f)) break;
          tc = t_new;
          Eigen::Vector3f a, dv;
          Accel(Motion::kAir, v, tc, a, dv);
          az = tc > 1e-4f ? 2.f * a.z() / (tc * tc) : -g;
        }
      }
      if (tc < 0.f || left < tc || k == kMaxContacts) {
        Eigen::Vector3f a, adot;
        Accel(Motion::kAir, v, left, a, adot);
        p += v * left + a;
        v += adot;
        // Never through the floor: a ball below it has met it (the contact was not found).
        if (p.z() < r) p.z() = r;
        mode = bounced ? BallMode::kBouncing : BallMode::kFlying;
        return;
      }
      Eigen::Vector3f a, adot;
      Accel(Motion::kAir, v, tc, a, adot);
      p += v * tc + a;
      v += adot;
      p.z() = r;
      t += tc;
      if (n_contacts < max_contacts) {
        contacts[n_contacts] = AddSeconds(t_ref_us_, t);
        cx[n_contacts] = p.x();
        cy[n_contacts] = p.y();
      }
      ++n_contacts;
      Eigen::Vector3f v_out;
      const Eigen::Vector2f spin_in = spin;
      Rebound(v, spin_in, v_out, spin);
      v = v_out;
      if (v.z() < cfg_.min_bounce_vz_mps) {
        motion = Motion::kRolling;
        v.z() = 0;
      } else {
        bounced = true;
      }
      continue;
    }
    mode = BallMode::kRolling;
    p.z() = r;
    v.z() = 0;
    const float s = std::hypot(v.x(), v.y());
    if (s < kRestSpeedMps) {
      v.setZero();
      return;
    }
    const float d = cfg_.rolling_decel_mps2 + cfg_.drag_per_m * s * s;
    const Eigen::Vector3f u(v.x() / s, v.y() / s, 0.f);
    const float stop = s / d;
    if (left >= stop) {
      p += u * (0.5f * s * stop);
      v.setZero();
    } else {
      p += u * (s * left - 0.5f * d * left * left);
      v = u * (s - d * left);
    }
    return;
  }
}

bool BallFilter::StateAt(uint64_t t_us, Eigen::Vector3f& p_m, Eigen::Vector3f& v_mps,
                         BallMode& mode) const {
  if (!tracking_ || !fit_.ok) {
    mode = BallMode::kNone;
    return false;
  }
  const float dt = Seconds(t_us, t_ref_us_);
  if (dt <= 0.f) {
    Eigen::Vector3f a, adot;
    Accel(seg_.motion, fit_.x.tail<3>(), dt, a, adot);
    p_m = fit_.x.head<3>() + fit_.x.tail<3>() * dt + a;
    v_mps = fit_.x.tail<3>() + adot;
    mode = seg_.motion == Motion::kRolling ? BallMode::kRolling
           : seg_.bounced                  ? BallMode::kBouncing
                                           : BallMode::kFlying;
    return true;
  }
  int n = 0;
  uint64_t tc;
  float x, y;
  Evolve(dt, p_m, v_mps, mode, &tc, &x, &y, 0, n);
  return true;
}

// The newest frame's whitened residuals against the fit that includes it: each row's expected
// square is the rays' variance factor times (1 - its leverage), so their sums estimate how noisy
// the rays really are against the model. The rig's and the venue's, not a track's: kept across
// tracks and segments (Configure clears them). A row counts at most 3 sigmas of the level so far:
// a model change's misfit within the model's wide noise is not the rays' noise.
void BallFilter::LearnRayNoise() {
  recent_head_ = (recent_head_ + 1) % kNoiseRecent;
  NoiseShare& frame = recent_noise_[recent_head_];
  frame = NoiseShare{};
  if (!tracking_ || !fit_.ok || count_ == 0 || Newest(0).t_us != t_ref_us_) return;
  int seg_frames = 0;
  while (seg_frames < count_ && Newest(seg_frames).t_us >= seg_.start_us) ++seg_frames;
  // A track's own first segment has no contact prior and no model change to misfit: its frames
  // count from the first (a static still, one frame a track, measures the noise too).
  if (seg_frames < kNoiseSegmentFrames && seg_.start_us != track_start_us_) return;
  const Stored& s = Newest(0);
  const Eigen::Matrix3f c = fit_.cov.topLeftCorner<3, 3>() / fit_.inflation;
  const float cap = kHuberSigma * kHuberSigma * noise_level();
  noise_chi2_ *= kNoiseForget;
  noise_dof_ *= kNoiseForget;
  auto forget = [](NoiseShare& n) {
    n.chi2 *= kNoiseForget;
    n.dof *= kNoiseForget;
  };
  forget(seg_noise_);
  for (NoiseShare& n : recent_noise_) forget(n);
  for (int k = 0; k < s.n; ++k) {
    const StoredRay& r = s.rays[k];
    RayRows rr;
    RayRowsAt(fit_.x.head<3>() - origin_[r.camera], r.dir, r.sigma_h, r.sigma_v, r.range,
              r.range_sigma, rr);
    for (int j = 0; j < rr.n; ++j) {
      const float free = 1.f - rr.jac[j].dot(c * rr.jac[j]);
      const float z2 = rr.res[j] * rr.res[j];
      if (!std::isfinite(free) || !std::isfinite(z2)) continue;
      const float add_chi2 = std::min(z2, cap), add_dof = std::clamp(free, 0.f, 1.f);
      noise_chi2_ += add_chi2;
      noise_dof_ += add_dof;
      seg_noise_.chi2 += add_chi2;
      seg_noise_.dof += add_dof;
      frame.chi2 += add_chi2;
      frame.dof += add_dof;
    }
  }
}

void BallFilter::RetractNoise(NoiseShare& share) {
  noise_chi2_ = std::max(noise_chi2_ - share.chi2, 0.f);
  noise_dof_ = std::max(noise_dof_ - share.dof, 0.f);
  share = NoiseShare{};
}

void BallFilter::RetractSegmentNoise() {
  RetractNoise(seg_noise_);
  for (NoiseShare& n : recent_noise_) n = NoiseShare{};  // all within the segment's
}

void BallFilter::RetractRecentNoise(int frames) {
  for (int i = 0; i < std::min(frames, kNoiseRecent); ++i) {
    RetractNoise(recent_noise_[(recent_head_ - i + kNoiseRecent) % kNoiseRecent]);
  }
  seg_noise_ = NoiseShare{};  // a new segment starts
}

float BallFilter::NoisePrior() const {
  return std::isfinite(cfg_.ray_noise_prior) ? std::clamp(cfg_.ray_noise_prior, kMinQuietScale, 1.f)
                                             : 1.f;
}

float BallFilter::ReportSigmaScale() const {
  return std::isfinite(cfg_.report_sigma_scale) && cfg_.report_sigma_scale > 0.f
             ? std::min(cfg_.report_sigma_scale, 4.f)
             : 1.f;
}

float BallFilter::noise_level() const {
  return noise_dof_ > 0.f ? std::clamp(noise_chi2_ / noise_dof_, kMinQuietScale, 1.f)
                          : NoisePrior();
}

bool BallFilter::SigmaAt(uint64_t t_us, Eigen::Vector3f& sigma_m, bool reported) const {
  return Sigma(t_us, t_us, sigma_m, reported);
}

bool BallFilter::PredictionSigma(uint64_t now_us, uint64_t t_us, Eigen::Vector3f& sigma_m) const {
  return Sigma(t_us, std::min(now_us, t_us), sigma_m, true);
}

// The fit's covariance moved to t_us; an unmodelled acceleration (a kick unseen) over the time
// without rays from the newest frame to `unseen_until_us` (either way); reported: plus the shared
// errors and the motion model's misfit, an acceleration a it lacks, which a fit over a window of
// span T extrapolates tau ahead off by a (T^2 / 12 + T tau / 2 + tau^2 / 2).
bool BallFilter::Sigma(uint64_t t_us, uint64_t unseen_until_us, Eigen::Vector3f& sigma_m,
                       bool reported) const {
  if (!tracking_ || !fit_.ok) return false;
  const float tau = Seconds(t_us, t_ref_us_);
  const float unseen = std::fabs(Seconds(unseen_until_us, t_ref_us_));
  const float q = cfg_.accel_noise_mps2 * cfg_.accel_noise_mps2;
  const float k = reported ? fit_.quiet_scale : 1.f;
  const float span = fit_.span_s, ahead = std::max(tau, 0.f);
  const float model =
      cfg_.model_accel_mps2 * (span * span / 12.f + 0.5f * span * ahead + 0.5f * ahead * ahead);
  // A contact within the horizon: its rebound's velocity error for the time after it (the first
  // contact only; the horizons the packet carries hold one).
  Eigen::Vector3f rebound = Eigen::Vector3f::Zero();
  if (reported && ahead > 0.f) {
    Eigen::Vector3f p, v;
    BallMode mode;
    uint64_t tc;
    float cx, cy;
    int n = 0;
    Evolve(ahead, p, v, mode, &tc, &cx, &cy, 1, n);
    if (n > 0) {
      // The first contact ends the current arc: the velocity into it in closed form, as
      // TryBounce has it.
      Eigen::Vector3f a, adot;
      Accel(Motion::kAir, fit_.x.tail<3>(), Seconds(tc, t_ref_us_), a, adot);
      const Eigen::Vector3f vin = fit_.x.tail<3>() + adot;
      const float after = Seconds(t_us, tc);
      const float sb = b_samples_ > 0 ? cfg_.fitted_bounce_factor_sigma : cfg_.bounce_factor_sigma;
      const float sh = seg_.spin_known ? cfg_.rebound_h_sigma_spin_known : cfg_.rebound_h_sigma;
      rebound.head<2>().setConstant(sh * std::hypot(vin.x(), vin.y()) * after);
      rebound.z() = sb * std::fabs(vin.z()) * after;
    }
  }
  for (int j = 0; j < 3; ++j) {
    float var =
        k * (fit_.cov(j, j) + 2.f * tau * fit_.cov(j, 3 + j) + tau * tau * fit_.cov(3 + j, 3 + j)) +
        q * unseen * unseen * unseen / 3.f;
    if (reported) {
      var += (fit_.bias.row(j) + tau * fit_.bias.row(3 + j)).squaredNorm();
      if (!seg_.at_rest && (j < 2 || seg_.motion == Motion::kAir)) var += model * model;
      var += rebound(j) * rebound(j);
    }
    sigma_m(j) = std::sqrt(std::max(var, 0.f));
  }
  return true;
}

int BallFilter::ContactsAfter(uint64_t t_us, uint64_t* t_out, float* x_out, float* y_out,
                              int max) const {
  if (!tracking_ || !fit_.ok || max <= 0) return 0;
  // Follow the model for 2.5 s beyond t_us (the paper's Fig. 5 horizon).
  const float horizon = std::max(Seconds(t_us, t_ref_us_), 0.f) + 2.5f;
  uint64_t tc[kMaxContacts];
  float cx[kMaxContacts], cy[kMaxContacts];
  Eigen::Vector3f p, v;
  BallMode mode;
  int n = 0;
  Evolve(horizon, p, v, mode, tc, cx, cy, kMaxContacts, n);
  n = std::min(n, static_cast<int>(kMaxContacts));
  int out = 0;
  for (int i = 0; i < n && out < max; ++i) {
    if (tc[i] <= t_us) continue;
    t_out[out] = tc[i];
    x_out[out] = cx[i];
    y_out[out] = cy[i];
    ++out;
  }
  return out;
}

bool BallFilter::HasStateAt(uint64_t t_us) const {
  return tracking_ && fit_.ok && t_us <= t_ref_us_ + cfg_.coast_us;
}

void BallFilter::FillState(uint64_t t_us, uint32_t ahead_us, BallState& out) const {
  out.found = false;
  out.mode = BallMode::kNone;
  out.flags &=
      static_cast<uint16_t>(~(kFlagCoasting | kFlagLost | kFlagHasBounce | kFlagHasPrediction |
                              kFlagUnobservable | kFlagPredictionUncertain));
  if (!tracking_ || !fit_.ok) return;
  if (!HasStateAt(t_us)) {
    out.flags |= kFlagLost;
    return;
  }
  if (t_us != t_ref_us_) out.flags |= kFlagCoasting;
  Eigen::Vector3f p, v, s;
  BallMode mode;
  StateAt(t_us, p, v, mode);
  SigmaAt(t_us, s);
  const float report = ReportSigmaScale();
  s *= report;
  out.found = true;
  out.x_m = p.x();
  out.y_m = p.y();
  out.z_m = p.z();
  out.vx_mps = v.x();
  out.vy_mps = v.y();
  out.vz_mps = v.z();
  out.sigma_x_m = s.x();
  out.sigma_y_m = s.y();
  out.sigma_z_m = s.z();
  out.mode = mode;
  if (!observable_) out.flags |= kFlagUnobservable;
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
  PredictionSigma(t_us, t_us + ahead_us, s);
  if (!(s.norm() <= cfg_.unobservable_sigma_m)) out.flags |= kFlagPredictionUncertain;
  s *= report;
  out.psigma_x_m = s.x();
  out.psigma_y_m = s.y();
  out.psigma_z_m = s.z();
}

}  // namespace bv
