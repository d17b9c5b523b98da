#include "core/ball_filter/candidate_tracks.h"

#include <cmath>

namespace bv {
namespace {

// Smoothing of the light tracks (alpha-beta): position follows the point closely, velocity
// settles over a few frames.
constexpr float kAlpha = 0.7f, kBeta = 0.3f;
constexpr int kMaxPoints = 8;

}  // namespace

void CandidateTracks::Reset() {
  for (Track& t : tracks_) t = Track{};
  main_at_rest_ = false;
}

void CandidateTracks::Associate(uint64_t t_us, std::span<const FloorPoint> seen) {
  bool taken[kMaxPoints] = {};
  const size_t n = seen.size() < kMaxPoints ? seen.size() : kMaxPoints;
  for (Track& t : tracks_) {
    if (!t.used) continue;
    const float dt = static_cast<float>(t_us - t.last_us) * 1e-6f;
    const float px = t.x + t.vx * dt, py = t.y + t.vy * dt;
    int best = -1;
    float best_d = config_.gate_m;
    for (size_t i = 0; i < n; ++i) {
      const float d = std::hypot(seen[i].x_m - px, seen[i].y_m - py);
      if (!taken[i] && d < best_d) {
        best_d = d;
        best = static_cast<int>(i);
      }
    }
    if (best < 0) {
      if (t_us - t.last_us > config_.drop_after_us) t.used = false;
      if (t.missed_in_row < 255) ++t.missed_in_row;
      continue;
    }
    taken[best] = true;
    const float rx = seen[best].x_m - px, ry = seen[best].y_m - py;
    t.x = px + kAlpha * rx;
    t.y = py + kAlpha * ry;
    if (dt > 1e-4f) {
      t.vx += kBeta * rx / dt;
      t.vy += kBeta * ry / dt;
    }
    t.last_us = t_us;
    if (t.hits < UINT16_MAX) ++t.hits;
    if (t.missed_in_row > 1) t.hits = 1;  // a broken run starts counting again
    t.missed_in_row = 0;
  }
  for (size_t i = 0; i < n; ++i) {  // new tracks in free slots
    if (taken[i]) continue;
    for (Track& t : tracks_) {
      if (t.used) continue;
      t = Track{true,        seen[i].x_m, seen[i].y_m, 0.f, 0.f, seen[i].x_m,
                seen[i].y_m, t_us,        t_us,        1,   0};
      break;
    }
  }
}

const CandidateTracks::Track* CandidateTracks::Challenger(uint64_t t_us, float main_x,
                                                          float main_y) const {
  const Track* best = nullptr;
  float best_speed = 0;
  for (const Track& t : tracks_) {
    if (!t.used || t.last_us != t_us || t.hits < config_.min_hits) continue;
    const float speed = std::hypot(t.vx, t.vy);
    if (speed < config_.min_speed_mps || speed > 15.f) continue;
    if (std::hypot(t.x - t.x0, t.y - t.y0) < config_.min_travel_m) continue;
    if (std::hypot(t.x - main_x, t.y - main_y) < config_.separation_m) continue;
    if (speed > best_speed) {
      best_speed = speed;
      best = &t;
    }
  }
  return best;
}

const CandidateTracks::Track* CandidateTracks::Update(uint64_t t_us,
                                                      std::span<const FloorPoint> seen,
                                                      bool have_main, float main_x, float main_y,
                                                      float main_speed_mps) {
  Associate(t_us, seen);
  const bool rest = have_main && main_speed_mps < config_.main_rest_mps;
  if (rest && !main_at_rest_) main_rest_since_us_ = t_us;
  main_at_rest_ = rest;
  if (!rest || t_us - main_rest_since_us_ < config_.main_rest_us) return nullptr;
  return Challenger(t_us, main_x, main_y);
}

}  // namespace bv
