#pragma once
// Every ball-coloured, ball-shaped floor candidate the omni camera sees, tracked at once (a few
// light constant-velocity tracks beside the full ray-space filter), so a stationary decoy cannot
// hold the filter while a moving ball is seen elsewhere: when the filter's ball has been at rest
// for a while and another candidate moves like a ball, that candidate is handed to the filter.
// Positions are in the field frame when the pose is known (a driving robot sees a decoy at rest
// move in its own frame), else in the robot frame. Fixed size, no heap.
#include <cstdint>
#include <span>

namespace bv {

struct CandidateTracksConfig {
  float gate_m = 0.6f;              // association radius around a track's prediction
  float min_speed_mps = 0.5f;       // a challenger moves at least this fast ...
  float min_travel_m = 0.4f;        // ... and has moved this far since first seen
  int min_hits = 6;                 // ... seen in this many frames (at most one missed in a row)
  float main_rest_mps = 0.15f;      // the filter's ball counts as at rest below this speed ...
  uint32_t main_rest_us = 700000;   // ... for this long
  float separation_m = 0.8f;        // a challenger is this far from the filter's ball at least
  uint32_t drop_after_us = 200000;  // a track unseen this long is dropped
};

/// A candidate on the floor this frame.
struct FloorPoint {
  float x_m = 0, y_m = 0;
};

class CandidateTracks {
 public:
  static constexpr int kMaxTracks = 4;
  struct Track {
    bool used = false;
    float x = 0, y = 0, vx = 0, vy = 0;  // m, m/s (the frame of Update's points)
    float x0 = 0, y0 = 0;                // where first seen
    uint64_t first_us = 0, last_us = 0;
    uint16_t hits = 0;
    uint8_t missed_in_row = 0;
  };

  void Configure(const CandidateTracksConfig& config) { config_ = config; }
  /// Forgets every track (a new frame of reference, a reset).
  void Reset();
  /// One frame: the candidates seen, and the filter's ball (`have_main`: tracked this frame) with
  /// its floor speed. Returns the track to hand to the filter, or nullptr.
  const Track* Update(uint64_t t_us, std::span<const FloorPoint> seen, bool have_main, float main_x,
                      float main_y, float main_speed_mps);
  std::span<const Track> tracks() const { return tracks_; }

 private:
  void Associate(uint64_t t_us, std::span<const FloorPoint> seen);
  const Track* Challenger(uint64_t t_us, float main_x, float main_y) const;

  CandidateTracksConfig config_;
  Track tracks_[kMaxTracks];
  uint64_t main_rest_since_us_ = 0;
  bool main_at_rest_ = false;
};

}  // namespace bv
