#include "core/field/localise.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

namespace bv {
namespace {

constexpr float kPi = 3.14159265358979f;
constexpr int kScorePoints = 24;    // points per coarse evaluation
constexpr int kRefinePerFrame = 4;  // global search candidates refined per frame (~30 k instr each)
// The coarse grid is scored with a wide error function (c = 2 grid steps): a grid point 0.25 m
// from the true pose must still score better than a wrong pose that happens to sit on lines.
constexpr float kSearchCPerGrid = 2.0f;
// Candidates closer than this many grid steps (same heading) are one: a basin spans a few.
constexpr float kDistinctPerGrid = 2.0f;
constexpr int kHeadingBins = 45;     // 2 deg bins over 90 deg
constexpr float kMinSigmaM = 0.02f;  // floor: calibration and line-centre error
constexpr float kMinSigmaRad = 0.005f;

float WrapPi(float a) { return std::remainder(a, 2.0f * kPi); }  // no loop on huge values

bool Finite(const LinePoint& p) { return std::isfinite(p.x_m) && std::isfinite(p.y_m); }

// Robot-frame point -> field frame (heading = field angle of robot +y).
inline void ToField(float x, float y, float h, float rx, float ry, float& fx, float& fy) {
  const float s = std::sin(h), c = std::cos(h);
  fx = x + rx * s + ry * c;
  fy = y - rx * c + ry * s;
}

}  // namespace

Status Localiser::Init(const FieldModel* field, const LocaliserConfig& config) {
  field_ = nullptr;
  if (field == nullptr || !field->ready()) {
    return Status(StatusCode::kFailedPrecondition, "localiser: field model not ready");
  }
  if (!(config.c_m > 0.0f) || config.track_iterations < 1 || config.track_iterations > 20 ||
      config.min_points < 3 || config.evals_per_frame < 1 ||
      config.search_points_per_frame < kScorePoints || !(config.grid_m >= 0.1f) ||
      !(config.inlier_m > 0.0f) || config.lost_after_bad_frames < 1) {
    return Status(StatusCode::kInvalidArgument, "localiser: bad configuration");
  }
  field_ = field;
  config_ = config;
  Reset();
  return Status::Ok();
}

void Localiser::Reset() {
  pose_ = PoseEstimate{};
  hint_ = PoseHint{};
  hint_pending_ = false;
  searching_ = false;
  bad_frames_ = 0;
  best_count_ = 0;
  last_t_us_ = 0;
}

Status Localiser::SetHint(const PoseHint& hint) {
  if (!std::isfinite(hint.x_m) || !std::isfinite(hint.y_m) || !std::isfinite(hint.heading_rad) ||
      hint.half < -1 || hint.half > 1) {
    return Status(StatusCode::kInvalidArgument, "localiser: hint not finite or half not -1/0/1");
  }
  hint_ = hint;
  hint_pending_ = hint.has_pose;
  if (hint.half != 0) ApplyHalf();
  return Status::Ok();
}

// The point-symmetric twin with field x on the hinted side.
void Localiser::ApplyHalf() {
  if (hint_.half == 0 || !pose_.usable()) return;
  if ((pose_.x_m < 0.0f ? -1 : 1) != hint_.half) {
    pose_.x_m = -pose_.x_m;
    pose_.y_m = -pose_.y_m;
    pose_.heading_rad = WrapPi(pose_.heading_rad + kPi);
  }
  pose_.ambiguous = false;
}

float Localiser::Score(const FieldFeatures& f, float x, float y, float h, int max_points) const {
  const int stride = std::max(1, (f.line_count + max_points - 1) / std::max(1, max_points));
  return Score(f, x, y, std::sin(h), std::cos(h), stride, FinitePoints(f, stride), 1e30f);
}

int Localiser::FinitePoints(const FieldFeatures& f, int stride) {
  int n = 0;
  for (int i = 0; i < f.line_count; i += stride) n += Finite(f.lines[i]) ? 1 : 0;
  return n;
}

// Mean error over every stride-th point (`points` of them finite). The terms are >= 0, so once
// the running sum passes `give_up` (times the points) the pose cannot beat it: returned as is
// (> give_up), the rest not scored.
float Localiser::Score(const FieldFeatures& f, float x, float y, float s, float co, int stride,
                       int points, float give_up, int* scored) const {
  if (points == 0) return 1.0f;
  const float c = kSearchCPerGrid * config_.grid_m, c2 = c * c;
  const float limit = give_up * static_cast<float>(points);
  float sum = 0.0f;
  for (int i = 0; i < f.line_count; i += stride) {
    if (!Finite(f.lines[i])) continue;
    const float rx = f.lines[i].x_m, ry = f.lines[i].y_m;
    sum += 1.0f - c2 / (c2 + field_->Distance2(x + rx * s + ry * co, y - rx * co + ry * s));
    if (scored != nullptr) ++*scored;
    if (sum > limit) break;
  }
  return sum / static_cast<float>(points);
}

Localiser::FitResult Localiser::Refine(const FieldFeatures& f, float x, float y, float h,
                                       int iterations, float c, int stride, bool covariance) const {
  FitResult r{x, y, h, 0, 0, 1.0f, 1.0f, 1.0f, 1.0f};
  const float c2 = c * c;
  Eigen::Matrix3f H;
  Eigen::Vector3f b;
  for (int it = 0; it <= iterations; ++it) {
    H.setZero();
    b.setZero();
    float wsum = 0.0f, wd2 = 0.0f;
    int inliers = 0;
    const float s = std::sin(r.h), co = std::cos(r.h);
    int used = 0;
    for (int i = 0; i < f.line_count; i += stride) {
      if (!Finite(f.lines[i])) continue;  // never from the extractor; a bad caller's point
      ++used;
      const float rx = f.lines[i].x_m, ry = f.lines[i].y_m;
      const float fx = r.x + rx * s + ry * co, fy = r.y - rx * co + ry * s;
      float gx, gy;
      const float d = field_->Distance(fx, fy, gx, gy);
      const float q = c2 / (c2 + d * d);
      const float w = q * q;
      const Eigen::Vector3f J(gx, gy, gx * (rx * co - ry * s) + gy * (rx * s + ry * co));
      H.noalias() += w * J * J.transpose();
      b += w * d * J;
      wsum += w;
      wd2 += w * d * d;
      inliers += d < config_.inlier_m;
    }
    r.inliers = inliers;
    r.used = used;
    r.s2 = wsum > 3.0f ? wd2 / (wsum - 3.0f) : 1.0f;
    if (it == iterations) break;
    Eigen::Matrix3f A = H;
    A.diagonal() += Eigen::Vector3f::Constant(1e-3f) + 0.01f * H.diagonal();
    Eigen::Vector3f delta = -A.ldlt().solve(b);
    if (!delta.allFinite()) break;
    const float step = std::hypot(delta.x(), delta.y());
    if (step > 0.5f) delta.head<2>() *= 0.5f / step;
    delta.z() = std::clamp(delta.z(), -0.2f, 0.2f);
    r.x += delta.x();
    r.y += delta.y();
    r.h = WrapPi(r.h + delta.z());
  }
  if (!covariance) return r;  // an intermediate step: only the pose is used
  H.diagonal() += Eigen::Vector3f::Constant(1e-6f);
  const Eigen::Matrix3f cov = H.inverse() * r.s2;
  r.h00 = cov(0, 0);
  r.h11 = cov(1, 1);
  r.h22 = cov(2, 2);
  return r;
}

// Field lines are axis-parallel: the directions between line points on neighbouring rays pile
// up at one angle modulo 90 deg, and the heading is that angle's complement.
bool Localiser::EstimateHeading(const FieldFeatures& f, float& h0) const {
  float hist[kHeadingBins] = {};
  int pairs = 0;
  for (int i = 0; i < f.line_count; ++i) {
    if (!Finite(f.lines[i])) continue;
    // Points are stored ray by ray: only the next two rays can pair.
    for (int j = i + 1; j < f.line_count; ++j) {
      const int dr = static_cast<int>(f.lines[j].ray) - static_cast<int>(f.lines[i].ray);
      if (dr > 2) break;
      if (dr < 1) continue;
      const float dx = f.lines[j].x_m - f.lines[i].x_m, dy = f.lines[j].y_m - f.lines[i].y_m;
      const float len = std::hypot(dx, dy);
      if (!(len >= 0.1f && len <= 0.8f)) continue;  // also drops NaN
      float a = std::atan2(dy, dx);
      a = std::fmod(a + 4.0f * kPi, 0.5f * kPi);
      const int bin = std::min(kHeadingBins - 1, static_cast<int>(a / (0.5f * kPi) * kHeadingBins));
      hist[bin] += 1.0f;
      ++pairs;
    }
  }
  if (pairs < 4) return false;
  int best = 0;
  float best_v = -1.0f;
  for (int k = 0; k < kHeadingBins; ++k) {
    const float v =
        hist[(k + kHeadingBins - 1) % kHeadingBins] + 2.0f * hist[k] + hist[(k + 1) % kHeadingBins];
    if (v > best_v) {
      best_v = v;
      best = k;
    }
  }
  // Circular mean of 4a over the peak and its neighbours.
  float sx = 0.0f, sy = 0.0f;
  for (int k = -1; k <= 1; ++k) {
    const int bin = (best + k + kHeadingBins) % kHeadingBins;
    const float a = (static_cast<float>(bin) + 0.5f) * (0.5f * kPi) / kHeadingBins;
    sx += hist[bin] * std::cos(4.0f * a);
    sy += hist[bin] * std::sin(4.0f * a);
  }
  const float alpha = std::atan2(sy, sx) / 4.0f;
  h0 = WrapPi(-alpha);
  return true;
}

void Localiser::StartSearch(const FieldFeatures& f) {
  float h0;
  searching_ = false;
  if (f.line_count < config_.min_points || !EstimateHeading(f, h0)) return;
  search_h_[0] = h0;
  search_h_[1] = WrapPi(h0 + 0.5f * kPi);
  const FieldConfig& fc = field_->config();
  search_nx_ = static_cast<int>((fc.length_m + 1.0f) / config_.grid_m) + 1;
  search_ny_ = static_cast<int>((fc.width_m + 1.0f) / config_.grid_m) + 1;
  search_total_ = 2 * search_nx_ * search_ny_;
  search_next_ = 0;
  refine_next_ = 0;
  best_count_ = 0;
  searching_ = true;
  pose_.state = PoseEstimate::kSearching;
}

// Keeps the best few distinct candidates (sorted by score): a neighbour of a kept candidate
// replaces it only when better, so the list does not fill with one basin.
void Localiser::Keep(const Candidate& c) {
  int slot = -1;
  for (int k = 0; k < best_count_; ++k) {
    if (best_[k].h == c.h &&
        std::hypot(best_[k].x - c.x, best_[k].y - c.y) < kDistinctPerGrid * config_.grid_m) {
      if (best_[k].score <= c.score) return;
      slot = k;
      break;
    }
  }
  if (slot < 0) {
    if (best_count_ < kMaxCandidates) {
      slot = best_count_++;
    } else if (c.score < best_[kMaxCandidates - 1].score) {
      slot = kMaxCandidates - 1;
    } else {
      return;
    }
  }
  best_[slot] = c;
  for (int k = slot; k > 0 && best_[k - 1].score > best_[k].score; --k) {
    const Candidate t = best_[k - 1];
    best_[k - 1] = best_[k];
    best_[k] = t;
  }
}

void Localiser::ContinueSearch(const FieldFeatures& f) {
  const FieldConfig& fc = field_->config();
  // The budget is in scored points, not poses: early on every pose is scored in full, later
  // the kept list prunes most poses after a few points and more of them fit in a frame.
  const int end = std::min(search_total_, search_next_ + config_.evals_per_frame);
  const bool evaluated = search_next_ < end;
  int points_left = config_.search_points_per_frame;
  float sin_h[2], cos_h[2];
  for (int k = 0; k < 2; ++k) {
    sin_h[k] = std::sin(search_h_[k]);
    cos_h[k] = std::cos(search_h_[k]);
  }
  const int score_stride = std::max(1, (f.line_count + kScorePoints - 1) / kScorePoints);
  const int score_points = FinitePoints(f, score_stride);
  for (; search_next_ < end && points_left > 0; ++search_next_) {
    const int hk = search_next_ / (search_nx_ * search_ny_);
    const int rest = search_next_ % (search_nx_ * search_ny_);
    const float x =
        -0.5f * fc.length_m - 0.5f + static_cast<float>(rest % search_nx_) * config_.grid_m;
    const float y =
        -0.5f * fc.width_m - 0.5f + static_cast<float>(rest / search_nx_) * config_.grid_m;
    // Only a pose better than the worst kept candidate can enter (Keep): stop scoring one that
    // cannot. The kept list is the same as with full scores.
    const float give_up = best_count_ == kMaxCandidates ? best_[kMaxCandidates - 1].score : 1e30f;
    int scored = 0;
    const float s =
        Score(f, x, y, sin_h[hk], cos_h[hk], score_stride, score_points, give_up, &scored);
    points_left -= scored;
    ++pose_.evaluations;
    if (s < give_up) Keep(Candidate{x, y, search_h_[hk], s});
  }
  // The refinement below costs more than a frame of the grid: it gets frames of its own, a few
  // candidates each (each refined on that frame's points; they are compared by inlier ratio).
  if (search_next_ < search_total_ || evaluated) return;
  const int stride = std::max(1, (f.line_count + kScorePoints - 1) / kScorePoints);
  const int end_k = std::min(best_count_, refine_next_ + kRefinePerFrame);
  for (; refine_next_ < end_k; ++refine_next_) {
    Candidate& c = best_[refine_next_];
    FitResult r = Refine(f, c.x, c.y, c.h, 2, 1.0f, stride, false);
    r = Refine(f, r.x, r.y, r.h, 2, 0.5f, stride, false);
    r = Refine(f, r.x, r.y, r.h, 1, config_.c_m, stride, false);
    pose_.evaluations += 5;
    c.x = r.x;
    c.y = r.y;
    c.h = r.h;
    c.score = r.used > 0 ? static_cast<float>(r.inliers) / static_cast<float>(r.used) : 0.0f;
    refined_inliers_[refine_next_] = static_cast<uint8_t>(std::min(r.inliers, 255));
  }
  if (refine_next_ < best_count_) return;
  searching_ = false;
  // The best fit; if another pose (not the symmetric twin) fits nearly as well, the lines seen do
  // not tell where the robot is (two lines fit at many places): no pose, try again.
  int best = -1;
  for (int k = 0; k < best_count_; ++k) {
    if (best < 0 || best_[k].score > best_[best].score ||
        (best_[k].score == best_[best].score && refined_inliers_[k] > refined_inliers_[best])) {
      best = k;
    }
  }
  const auto fit = [&](int k) {
    FitResult r{};
    r.x = best_[k].x;
    r.y = best_[k].y;
    r.h = best_[k].h;
    return r;
  };
  FitResult win{};
  if (best >= 0) {
    // From the candidate's frame to this one the robot may have moved: a wider step first.
    win = Refine(f, best_[best].x, best_[best].y, best_[best].h, 2, 0.5f, 1, false);
    win = Refine(f, win.x, win.y, win.h, 2, config_.c_m);
  }
  // A rival that fitted nearly as well on its subsample is refitted on all of this frame's
  // points, so that both are judged on the same points.
  bool unique = best >= 0;
  for (int k = 0; k < best_count_ && unique; ++k) {
    if (k == best || best_[k].score < 0.9f * best_[best].score || SamePose(fit(k), fit(best))) {
      continue;
    }
    const FitResult r = Refine(f, best_[k].x, best_[k].y, best_[k].h, 2, config_.c_m, 1, false);
    pose_.evaluations += 3;
    unique =
        static_cast<float>(r.inliers) < 0.9f * static_cast<float>(win.inliers) || SamePose(r, win);
  }
  const bool fits_well = best >= 0 && win.inliers >= config_.min_points &&
                         static_cast<float>(win.inliers) >=
                             config_.global_inlier_ratio * static_cast<float>(win.used) &&
                         Constrained(win);
  if (unique && fits_well) {
    Accept(win);
    pose_.ambiguous = true;
    ApplyHalf();
  } else {
    pose_.state = PoseEstimate::kUnknown;  // try again from the next frame
  }
}

// Lines in one direction only (one line, or parallel ones) leave the pose free along them: the
// fit's covariance says so, and such a fit does not count.
bool Localiser::Constrained(const FitResult& r) const {
  return r.h00 < config_.max_fit_sigma_m * config_.max_fit_sigma_m &&
         r.h11 < config_.max_fit_sigma_m * config_.max_fit_sigma_m &&
         r.h22 < config_.max_fit_sigma_rad * config_.max_fit_sigma_rad;
}

// Equal up to the field's point symmetry (x, y, h) ~ (-x, -y, h + pi).
bool Localiser::SamePose(const FitResult& a, const FitResult& b) {
  constexpr float kM = 0.5f, kRad = 0.2f;
  const bool same = std::hypot(a.x - b.x, a.y - b.y) < kM && std::fabs(WrapPi(a.h - b.h)) < kRad;
  const bool twin =
      std::hypot(a.x + b.x, a.y + b.y) < kM && std::fabs(WrapPi(a.h - b.h - kPi)) < kRad;
  return same || twin;
}

void Localiser::Accept(const FitResult& r) {
  pose_.state = PoseEstimate::kTracking;
  pose_.x_m = r.x;
  pose_.y_m = r.y;
  pose_.heading_rad = WrapPi(r.h);
  pose_.sigma_x_m = std::max(kMinSigmaM, std::sqrt(std::max(0.0f, r.h00)));
  pose_.sigma_y_m = std::max(kMinSigmaM, std::sqrt(std::max(0.0f, r.h11)));
  pose_.sigma_heading_rad = std::max(kMinSigmaRad, std::sqrt(std::max(0.0f, r.h22)));
  const float ratio = r.used > 0 ? static_cast<float>(r.inliers) / static_cast<float>(r.used) : 0;
  pose_.quality = ratio * std::min(1.0f, static_cast<float>(r.inliers) / 20.0f);
  pose_.points_used = static_cast<uint16_t>(r.used);
  pose_.inliers = static_cast<uint16_t>(r.inliers);
  bad_frames_ = 0;
}

void Localiser::Coast(uint64_t t_us) {
  if (!pose_.usable()) return;
  const float dt = t_us > last_t_us_ ? static_cast<float>(t_us - last_t_us_) * 1e-6f : 0.0f;
  pose_.state = PoseEstimate::kCoasting;
  pose_.sigma_x_m += config_.coast_pos_mps * dt;
  pose_.sigma_y_m += config_.coast_pos_mps * dt;
  pose_.sigma_heading_rad += config_.coast_heading_radps * dt;
  pose_.quality = 0.0f;
}

void Localiser::Update(const FieldFeatures& f, uint64_t t_us, const float* odometry) {
  pose_.evaluations = 0;
  pose_.hint_rejected = false;
  if (field_ == nullptr) return;
  if (odometry != nullptr && pose_.usable() && std::isfinite(odometry[0]) &&
      std::isfinite(odometry[1]) && std::isfinite(odometry[2])) {
    float fx, fy;
    ToField(pose_.x_m, pose_.y_m, pose_.heading_rad, odometry[0], odometry[1], fx, fy);
    pose_.x_m = fx;
    pose_.y_m = fy;
    pose_.heading_rad = WrapPi(pose_.heading_rad + odometry[2]);
  }
  const bool enough = f.line_count >= config_.min_points;
  const auto good = [&](const FitResult& r) {
    return r.inliers >= config_.min_points &&
           static_cast<float>(r.inliers) >=
               config_.good_inlier_ratio * static_cast<float>(r.used) &&
           Constrained(r);
  };
  if (hint_pending_ && enough) {
    hint_pending_ = false;
    FitResult r = Refine(f, hint_.x_m, hint_.y_m, hint_.heading_rad, 4, 0.5f);
    r = Refine(f, r.x, r.y, r.h, config_.track_iterations, config_.c_m);
    // The hint seeds the pose only if the lines confirm it where it is (a fit that had to move
    // the pose far found some other place that the lines also match).
    FitResult h = r;
    h.x = hint_.x_m;
    h.y = hint_.y_m;
    h.h = hint_.heading_rad;
    if (good(r) && SamePose(r, h)) {
      searching_ = false;
      Accept(r);
      pose_.ambiguous = false;
      last_t_us_ = t_us;
      return;
    }
    pose_.hint_rejected = true;
  }
  if (!enough) {
    Coast(t_us);
    last_t_us_ = t_us;
    return;
  }
  if (pose_.usable() && !searching_) {
    const FitResult r =
        Refine(f, pose_.x_m, pose_.y_m, pose_.heading_rad, config_.track_iterations, config_.c_m);
    pose_.evaluations += static_cast<uint32_t>(config_.track_iterations);
    if (good(r)) {
      const bool ambiguous = pose_.ambiguous;
      Accept(r);
      pose_.ambiguous = ambiguous;
      last_t_us_ = t_us;
      return;
    }
    Coast(t_us);
    if (++bad_frames_ < config_.lost_after_bad_frames) {
      last_t_us_ = t_us;
      return;
    }
    pose_.state = PoseEstimate::kUnknown;  // kidnapped or lost: search again
  }
  last_t_us_ = t_us;
  if (!searching_) StartSearch(f);
  if (searching_) ContinueSearch(f);
}

}  // namespace bv
