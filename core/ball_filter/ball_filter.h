#pragma once
// 3D ball tracking and prediction from viewing rays (issue 12). The paper triangulates two rays
// per frame and fits the motion afterwards; here the motion is fitted to the rays themselves, so a
// frame with one ray (omni only, persp only + its apparent size) still counts, and a ball in flight
// seen by one camera is placed in 3D by gravity. Sliding-window weighted least squares over the
// rays of the current motion segment (rolling / flying / bouncing), re-linearised twice; see
// README.md for why this estimator. Time comes only from the exposure timestamps; no clock, no
// heap, bounded work per update.
#include <cstdint>

#include <Eigen/Core>

#include "core/common/ball_state.h"

namespace bv {

struct BallFilterConfig {
  float ball_radius_m = 0.11f;
  float gravity_mps2 = 9.81f;
  // Quadratic air drag, acceleration -k |v| v: k = rho Cd A / (2 m); 1.2 kg/m^3, Cd 0.25 (super-
  // critical), A = pi 0.11^2, 0.43 kg (../shared/data/ball_physics).
  float drag_per_m = 0.0133f;
  float rolling_decel_mps2 = 0.6f;     // rolling resistance (+ drag) on carpet
  float bounce_factor = 0.7f;          // b, initial value (vertical restitution)
  bool estimate_bounce_factor = true;  // refine b from each observed bounce
  float min_bounce_factor = 0.3f, max_bounce_factor = 0.95f;
  // A contact's horizontal impulse: Coulomb friction on the contact point's slip, up to the
  // impulse that makes the ball roll. An inflated ball is a thin shell: I = 2/3 m r^2.
  float bounce_friction_mu = 0.5f;
  float ball_inertia_ratio = 2.f / 3.f;  // I / (m r^2)
  float min_bounce_vz_mps = 0.5f;        // a rebound slower than this ends in rolling
  int max_window = 12;                   // frames in the fit, 4..kMaxWindow
  // A ray further from the prediction than gate_min_m + gate_sigmas * (prediction and ray sigma)
  // + outlier_growth_mps * time since the last frame is rejected; two such frames that agree with
  // each other within outlier_error_m start a new track.
  float gate_min_m = 0.3f, gate_sigmas = 4.f;
  float outlier_error_m = 1.0f;
  float outlier_growth_mps = 3.0f;
  float max_speed_mps = 15.f;      // a fit faster than this is a wrong detection
  float model_switch_chi2 = 16.f;  // chi^2 gain that makes the filter change the motion model
  float restart_chi2 = 25.f;       // chi^2 gain that makes frames off the model a new segment
  float roll_tolerance_m = 0.05f;  // a flying fit this close to the floor is rolling
  float accel_noise_mps2 = 1.5f;   // unmodelled acceleration: grows the uncertainty when coasting
  // A constant acceleration the model does not have (rolling resistance off its value, spin)
  // moves the end of a window fit of span T by a T^2 / 12: part of the reported sigma.
  float model_accel_mps2 = 0.1f;
  // A floor contact predicted within the horizon: how well its rebound is known, for the reported
  // sigma after it. b before any rebound was fitted (turf 0.55-0.65, steel 0.82-0.88 in
  // ../shared/data/ball_physics: the configured 0.7 +-2 sigma), and after; the horizontal
  // velocity out as a fraction of the velocity in, with the spin unknown (a kick's first contact:
  // sliding or gripping changes it by up to 2/5) and known.
  float bounce_factor_sigma = 0.08f, fitted_bounce_factor_sigma = 0.03f;
  float rebound_h_sigma = 0.1f, rebound_h_sigma_spin_known = 0.03f;
  // The rays' noise level before any has been measured (a variance factor of their stated noise,
  // see noise_level()): where the first track's first frame starts, as if 2 rows had shown it.
  // The stated noise is 1.5-2x what the rays showed on renders (PipelineConfig), so (1/1.75)^2.
  float ray_noise_prior = 0.33f;
  uint32_t coast_us = 500000;  // prediction only, then lost
  float max_range_m = 25.f;    // beyond: far outside any field
  float max_height_m = 6.f;
  // What the state publishes (sigma, psigma) is the covariance's 1-sigma times this, the bound
  // that holds 68 % of the errors per axis. The covariance's 1-sigma held ~78 % on renders while
  // its 2 and 3 held about 95 and 99.7: the errors are heavier-tailed than a Gaussian (a mixture
  // of scales; each sequence's shared error is one draw). Measured on 4 sets: the pooled 68th
  // percentile of |error| / sigma, 0.79 (core/ball_filter/README.md). Gates and flags use the
  // covariance.
  float report_sigma_scale = 0.8f;
  // A position sigma above this is flagged kFlagUnobservable; a look-ahead's,
  // kFlagPredictionUncertain.
  float unobservable_sigma_m = 0.5f;
  float robot_radius_m = 0.25f;  // a ray meeting the floor inside this radius sees the robot
};

/// One camera's viewing ray through the ball centre, with its angular uncertainty.
struct BallRay {
  Eigen::Vector3f origin = Eigen::Vector3f::Zero();
  Eigen::Vector3f dir = Eigen::Vector3f::UnitY();  // unit
  // 1-sigma angular error across the ray: horizontal (azimuth) and in the vertical plane.
  float sigma_h_rad = 0.002f, sigma_v_rad = 0.002f;
  // The part of that error neighbouring frames share (the same occluder, border cut, shading,
  // calibration), 1-sigma: the window cannot average it down. It widens the reported sigma only.
  float bias_h_rad = 0, bias_v_rad = 0;
  // A range cue along the ray (apparent size): > 0 when present, with its 1-sigma.
  float range_m = 0, range_sigma_m = 0;
  uint8_t camera = 0;  // 0 omni, 1 perspective (origins are per camera)
};

/// What one frame pair contributes: 0, 1 or 2 rays.
struct BallObservation {
  static constexpr int kMaxRays = 2;
  uint64_t t_us = 0;
  BallRay rays[kMaxRays];
  int n_rays = 0;
};

class BallFilter {
 public:
  static constexpr int kMaxWindow = 12;  // 0.4 s at 30 Hz; static RAM is the limit (DESIGN.md §5)
  static constexpr int kMaxContacts = 16;  // floor contacts followed when predicting

  explicit BallFilter(const BallFilterConfig& config = {}) { Configure(config); }
  /// Clamps the window to 4..kMaxWindow and resets the track.
  void Configure(const BallFilterConfig& config);
  void Reset();

  /// Feeds one frame's rays. Returns the BallFlags describing what happened (0 = used;
  /// kFlagBadTimestamp / kFlagOutOfField / kFlagOutlierRejected = ignored, kFlagUnobservable).
  uint16_t Update(const BallObservation& obs);

  /// Model state at any time (past or future, bounces included); false when there is no track.
  bool StateAt(uint64_t t_us, Eigen::Vector3f& p_m, Eigen::Vector3f& v_mps, BallMode& mode) const;
  /// 1-sigma position uncertainty per axis at t_us (grows while coasting). `reported`: as the
  /// state reports it, the fit's covariance scaled down when its residuals are smaller than the
  /// ray noise model says (calibrated on renders); false: the model's own (gating).
  bool SigmaAt(uint64_t t_us, Eigen::Vector3f& sigma_m, bool reported = true) const;
  /// 1-sigma of the position predicted at t_us from now_us: the fit and its model carried ahead;
  /// an unmodelled acceleration (SigmaAt's growth) only over the time already without rays. What
  /// someone may do to the ball in the horizon is not in it.
  bool PredictionSigma(uint64_t now_us, uint64_t t_us, Eigen::Vector3f& sigma_m) const;
  /// Predicted floor contacts strictly after t_us (time, x, y), in order; returns the count.
  int ContactsAfter(uint64_t t_us, uint64_t* t_out, float* x_out, float* y_out, int max) const;
  /// Whether FillState reports a ball at t_us: a track with a fit, not coasted past its limit.
  bool HasStateAt(uint64_t t_us) const;
  /// Fills position, velocity, sigma, mode, found, coasting/lost flags, next bounce and the
  /// prediction `ahead_us` later for time t_us (the frame time). Leaves detections and ray_gap.
  void FillState(uint64_t t_us, uint32_t ahead_us, BallState& out) const;

  bool tracking() const { return tracking_; }
  int window_size() const { return count_; }
  float bounce_factor() const { return b_; }
  uint64_t last_measurement_us() const { return t_ref_us_; }
  /// The position along the rays is determined (false: e.g. one camera, no motion yet).
  bool observable() const { return observable_; }
  /// How noisy the rays have measured against their noise model over recent frames, as a
  /// variance factor in [1/64, 1] (ray_noise_prior until rays have been seen).
  float noise_level() const;

 private:
  float NoisePrior() const;        // ray_noise_prior, clamped to what noise_level() can be
  float ReportSigmaScale() const;  // report_sigma_scale, 1 when not finite and positive
  bool Sigma(uint64_t t_us, uint64_t unseen_until_us, Eigen::Vector3f& sigma_m,
             bool reported) const;
  struct StoredRay {
    Eigen::Vector3f dir;
    float sigma_h, sigma_v, range, range_sigma, bias_h, bias_v;
    uint8_t camera;
  };
  struct Stored {
    uint64_t t_us;
    StoredRay rays[BallObservation::kMaxRays];
    uint8_t n;
  };
  enum class Motion : uint8_t { kRolling, kAir };
  // A motion segment: the model, where it starts, and what the previous segment says about its
  // state at the start (a floor contact: position, rebound velocity), as a Gaussian.
  struct Segment {
    Motion motion = Motion::kRolling;
    bool bounced = false;  // air segment that started at a floor contact
    bool at_rest = false;  // rolling segment of a ball that has stopped (v = 0)
    uint64_t start_us = 0;
    bool has_prior = false;
    uint64_t prior_us = 0;
    float prior_mean[6] = {};
    float prior_sigma[6] = {};
    float v_in_z = 0;                                   // vertical speed into the contact (b)
    Eigen::Vector2f v_in_xy = Eigen::Vector2f::Zero();  // horizontal velocity into it
    // The ball's spin as the horizontal speed of its surface at the bottom (a ball rolling without
    // slip: its velocity), constant in flight; unknown (a kick) counts as none. spin_in and grip
    // describe the contact that started the segment.
    Eigen::Vector2f spin = Eigen::Vector2f::Zero(), spin_in = Eigen::Vector2f::Zero();
    bool grip = false;        // the contact made the ball roll (friction did not saturate)
    bool spin_known = false;  // spin follows from a contact that gripped or from a fitted rebound
  };
  struct Fit {
    bool ok = false;
    Eigen::Matrix<float, 6, 1> x = Eigen::Matrix<float, 6, 1>::Zero();  // p, v at t_ref_us_
    // Scaled by the residual when that exceeds the noise model.
    Eigen::Matrix<float, 6, 6> cov = Eigen::Matrix<float, 6, 6>::Zero();
    float chi2 = 0;
    int rows = 0;
    // (chi2 + 8 level) / (dof + 8), at most 1: the residuals' own variance factor where they
    // are quieter than the (deliberately wide) ray noise model, pulled towards the level the
    // rays have measured over recent frames (noise_level()); the state reports it.
    float quiet_scale = 1;
    float inflation = 1;  // chi2 / dof where the residuals exceed the model: cov includes it
    // The state's response (p, v at t_ref) to each camera's shared angular error, 1-sigma
    // (columns: omni h, omni v, persp h, persp v): the reported covariance adds bias bias^T.
    Eigen::Matrix<float, 6, 4> bias = Eigen::Matrix<float, 6, 4>::Zero();
    float span_s = 0;        // from the oldest frame fitted to t_ref
    bool ambiguous = false;  // another flight explains the rays nearly as well elsewhere
  };

  const Stored& Newest(int k) const;  // k = 0 newest
  void Push(const BallObservation& obs);
  // Fits the segment's frames up to end_us (the state at t_ref_us_).
  Fit Solve(const Segment& seg, const Eigen::Matrix<float, 6, 1>& nominal,
            uint64_t end_us = UINT64_MAX, int iterations = 3) const;
  // Solve's normal equations h, g at state x beyond the rays: the prior, the rolling constraints
  // and the damping.
  void AddPriorAndConstraints(const Segment& seg, const Eigen::Matrix<float, 6, 1>& x,
                              Eigen::Matrix<float, 6, 6>& h, Eigen::Matrix<float, 6, 1>& g) const;
  float ObsChi2(const Stored& s, const Segment& seg, const Eigen::Matrix<float, 6, 1>& x,
                uint64_t t_ref) const;
  void Accel(Motion m, const Eigen::Vector3f& v_ref, float tau, Eigen::Vector3f& a,
             Eigen::Vector3f& dv) const;
  bool PointOf(const BallObservation& obs, Eigen::Vector3f& p) const;
  bool Plausible(const Fit& f) const;
  Fit SolveFlight(const Segment& seg) const;
  // The segment as a flight, if a plausible one no faster than max_speed_mps explains its rays.
  bool SwitchToFlight(float max_speed_mps);
  void StartTrack(const BallObservation& obs);
  bool TryBounce(uint64_t t_new_us);
  void Refit();
  // Update()'s steps, in its order.
  void ValidRays(const BallObservation& in, BallObservation& obs) const;
  float GateRays(const BallObservation& obs, BallObservation& kept) const;
  uint16_t ConfirmJump(const BallObservation& obs, bool have_point, const Eigen::Vector3f& point);
  void CheckModel(float off);
  bool SwitchRollingFlying(int seg_frames);
  bool RestartSegment(int seg_frames);
  void CheckAtRest(int seg_frames);
  void EstimateRestitution(int seg_frames);
  // A floor contact: vertical rebound b |vz|, friction on the slip; returns whether it gripped.
  bool Rebound(const Eigen::Vector3f& v_in, const Eigen::Vector2f& spin_in, Eigen::Vector3f& v_out,
               Eigen::Vector2f& spin_out) const;
  uint16_t UpdateObservable();  // sets observable_; returns kFlagUnobservable or 0
  void LearnRayNoise();
  void Evolve(float dt_s, Eigen::Vector3f& p, Eigen::Vector3f& v, BallMode& mode,
              uint64_t* contacts, float* cx, float* cy, int max_contacts, int& n_contacts) const;

  BallFilterConfig cfg_;
  Eigen::Vector3f origin_[2] = {Eigen::Vector3f::Zero(), Eigen::Vector3f::Zero()};
  Stored obs_[kMaxWindow] = {};
  int head_ = 0, count_ = 0;
  bool tracking_ = false;
  bool have_time_ = false;
  bool observable_ = false;
  uint64_t last_t_us_ = 0;       // newest timestamp seen (ordering check)
  uint64_t t_ref_us_ = 0;        // time of the estimate = newest accepted observation
  uint64_t track_start_us_ = 0;  // the track's first frame
  Segment seg_;
  Fit fit_;
  float b_ = 0.7f;
  int b_samples_ = 0;
  bool b_pending_ = false;
  int off_count_ = 0;  // consecutive observations far from the model (segment restart)
  bool cand_valid_ = false;
  BallObservation cand_;  // a rejected jump, kept to see whether the next frame confirms it
  // The newest frames' whitened squared residuals and their expected share (1 - leverage), with
  // forgetting: noise_level().
  float noise_chi2_ = 0, noise_dof_ = 0;  // Configure() starts both at kNoiseStartRows
  // What the current segment's frames added to them, and each of the newest kNoiseRecent frames
  // (forgotten alike): taken back when a model change shows they were measured against the wrong
  // model. A floor fit to a lob's rising rays (one camera) put the level at 1 for seconds, 16x
  // the rays' noise.
  struct NoiseShare {
    float chi2 = 0, dof = 0;
  };
  static constexpr int kNoiseRecent = 4;
  NoiseShare seg_noise_, recent_noise_[kNoiseRecent];
  int recent_head_ = 0;
  void RetractNoise(NoiseShare& share);
  void RetractSegmentNoise();           // the segment's model was wrong for all its frames
  void RetractRecentNoise(int frames);  // ... for the newest `frames` learned (a restart)
};

}  // namespace bv
