#pragma once
// 3D ball tracking and prediction (paper IV-C): the Lauer/Lange/Riedmiller sliding-window
// regression for x, y (constant velocity, least squares over the last n observations, the
// window shrinks after repeated large prediction errors) extended to z with three models:
// rolling (z = r), flying (parabola under gravity), bouncing (v_out = -b v_in).
// Time comes only from the measurements (exposure timestamps); no clock, no heap.
#include <cstdint>

#include <Eigen/Core>

#include "core/common/ball_state.h"

namespace bv {

struct BallFilterConfig {
  float ball_radius_m = 0.11f;
  float gravity_mps2 = 9.81f;
  float bounce_factor = 0.7f;          // b, initial value
  bool estimate_bounce_factor = true;  // refine b from each observed bounce
  float min_bounce_factor = 0.3f, max_bounce_factor = 0.95f;
  float min_bounce_vz_mps = 0.5f;      // a rebound slower than this ends in rolling
  int max_window = 10;                 // n, 3..kMaxWindow
  float large_error_m = 0.15f;         // prediction error counted as "large" (shrinks the window)
  int shrink_after = 2;                // consecutive large errors before the window shrinks
  float outlier_error_m = 1.0f;        // a single measurement further off than this is rejected
  float outlier_growth_mps = 3.0f;     // ... gate grows with the time since the last measurement
  float roll_tolerance_m = 0.05f;      // |z - r| still counted as on the floor
  float roll_tolerance_per_m = 0.01f;  // ... plus this per metre of range (triangulation noise)
  uint32_t coast_us = 500000;          // prediction only, then lost
  float max_range_m = 25.f;            // beyond: far outside any field, rejected
  float max_height_m = 6.f, min_height_m = -0.5f;
};

struct BallMeasurement {
  uint64_t t_us = 0;
  Eigen::Vector3f p_m = Eigen::Vector3f::Zero();
  bool z_valid = true;  // false: z is an assumption (e.g. omni ray at the predicted height)
};

class BallFilter {
 public:
  static constexpr int kMaxWindow = 10;
  static constexpr int kMaxContacts = 16;  // floor contacts followed when predicting

  explicit BallFilter(const BallFilterConfig& config = {}) { Configure(config); }
  /// Clamps the window to 3..kMaxWindow and resets the track.
  void Configure(const BallFilterConfig& config);
  void Reset();

  /// Feeds one measurement. Returns the BallFlags describing what happened with it
  /// (0 = accepted; kFlagBadTimestamp / kFlagOutOfField / kFlagOutlierRejected = ignored).
  uint16_t Update(const BallMeasurement& m);

  /// Model state at any time (past or future); false when there is no track.
  bool StateAt(uint64_t t_us, Eigen::Vector3f& p_m, Eigen::Vector3f& v_mps, BallMode& mode) const;
  /// Predicted floor contacts strictly after t_us (time, x, y), in order; returns the count.
  int ContactsAfter(uint64_t t_us, uint64_t* t_out, float* x_out, float* y_out, int max) const;
  /// Fills position, velocity, mode, found, coasting/lost flags, next bounce and the prediction
  /// `ahead_us` later for time t_us (the frame time). Leaves detections and ray_gap alone.
  void FillState(uint64_t t_us, uint32_t ahead_us, BallState& out) const;

  bool tracking() const { return tracking_; }
  int window_size() const { return count_; }
  float bounce_factor() const { return b_; }
  uint64_t last_measurement_us() const { return last_meas_us_; }

 private:
  struct Obs {
    uint64_t t_us;
    Eigen::Vector3f p;
    bool z_valid;
  };
  enum class Vertical : uint8_t { kRolling, kAirborne };

  void StartTrack(const BallMeasurement& m);
  void Push(const BallMeasurement& m);
  void KeepNewest(int n);
  const Obs& Newest(int k) const;  // k = 0 newest
  void Refit();
  void ZAt(float dt_s, float& z, float& vz, bool& rolling, int& bounces) const;
  float RollTolerance(const Eigen::Vector3f& p) const;

  BallFilterConfig cfg_;
  Obs obs_[kMaxWindow] = {};
  int head_ = 0, count_ = 0;  // ring buffer of the window
  bool tracking_ = false;
  bool have_time_ = false;
  uint64_t last_t_us_ = 0;     // newest timestamp seen (ordering check)
  uint64_t last_meas_us_ = 0;  // newest accepted measurement
  // Horizontal model at t_ref_us_.
  uint64_t t_ref_us_ = 0;
  float x0_ = 0, y0_ = 0, vx_ = 0, vy_ = 0;
  // Vertical model at t_ref_us_.
  Vertical vert_ = Vertical::kRolling;
  bool bounced_ = false;  // airborne after a floor contact (mode "bouncing")
  float z0_ = 0, vz0_ = 0;
  uint64_t seg_start_us_ = 0;  // z observations older than this belong to an earlier arc
  bool anchor_ = false;        // floor contact (seg_start_us_, z = r) constrains the arc
  float v_in_mps_ = 0;         // |vz| before that contact (for estimating b)
  bool b_pending_ = false;
  int lift_count_ = 0;
  float b_ = 0.7f;
  int large_count_ = 0;
  bool cand_valid_ = false;
  BallMeasurement cand_;
};

}  // namespace bv
