#include "tools/ballvision/calib_omni_steps.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <sstream>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include "hal/host/sequence.h"
#include "tools/ballvision/calib_io.h"
#include "tools/ballvision/safe_write.h"
#include "tools/ballvision/signals.h"
#include "tools/ballvision/stats.h"

namespace bv::cli::omni {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr double kPi = 3.14159265358979323846;
constexpr double kSectorRad = 2 * kPi / kSectors;
constexpr double kRayStepPx = 0.25;
constexpr int kMinSamplesPerEdge = 2;  // fewer in a sector: occluded, interpolated

struct Rgb {
  float r = 0, g = 0, b = 0;
};

Rgb operator-(Rgb a, Rgb b) { return {a.r - b.r, a.g - b.g, a.b - b.b}; }
float Dot(Rgb a, Rgb b) { return a.r * b.r + a.g * b.g + a.b * b.b; }

double Wrap2Pi(double a) {
  a = std::fmod(a, 2 * kPi);
  return a < 0 ? a + 2 * kPi : a;
}
double WrapPi(double a) { return Wrap2Pi(a + kPi) - kPi; }

// Bilinear; black outside the image.
Rgb At(const cv::Mat3b& bgr, double u, double v) {
  const int x0 = static_cast<int>(std::floor(u)), y0 = static_cast<int>(std::floor(v));
  if (x0 < 0 || y0 < 0 || x0 + 1 >= bgr.cols || y0 + 1 >= bgr.rows) return {};
  const float fx = static_cast<float>(u - x0), fy = static_cast<float>(v - y0);
  Rgb out;
  const float w[4] = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
  const cv::Vec3b p[4] = {bgr(y0, x0), bgr(y0, x0 + 1), bgr(y0 + 1, x0), bgr(y0 + 1, x0 + 1)};
  for (int i = 0; i < 4; ++i) {
    out.b += w[i] * p[i][0];
    out.g += w[i] * p[i][1];
    out.r += w[i] * p[i][2];
  }
  return out;
}

// An empty sector or edge counts as radius 0 (never used: it is flagged and interpolated, or
// weighted out), where Median's NaN would poison the weighted fits.
double MedianOrZero(const std::vector<double>& v) { return v.empty() ? 0 : Median(v); }

// d radius / d ground distance at edge k, from the neighbouring edges.
double Slope(const double* centre, const std::array<double, kEdges>& edge_m, int k) {
  const int a = std::max(k - 1, 0), b = std::min(k + 1, kEdges - 1);
  return (centre[b] - centre[a]) / (edge_m[b] - edge_m[a]);
}

int SectorOf(double phi) { return static_cast<int>(phi / kSectorRad) % kSectors; }

}  // namespace

bool LoadFrames(const std::string& seq, std::vector<Frame>& frames, std::string& error) {
  host::Sequence sequence;
  if (!host::LoadSequence(seq, sequence, error)) return false;
  int first_w = 0, first_h = 0;
  for (const host::SequenceEntry& e : sequence.entries) {
    if (e.omni_path.empty()) continue;
    if (cli::InterruptSignal()) {
      error = "interrupted";
      return false;
    }
    Frame fr;
    fr.index = static_cast<long>(e.index);
    fr.name = fs::path(e.omni_path).filename().string();
    // Through the same loader as the pipeline: PNG (via BT.601 YUYV) or raw .yuyv.
    std::vector<uint8_t> yuyv;
    int w = 0, h = 0;
    if (!host::LoadYuyv(e.omni_path, yuyv, w, h, error)) return false;
    if (first_w == 0) first_w = w, first_h = h;
    if (w != first_w || h != first_h) {
      error = e.omni_path + ": image is " + std::to_string(w) + "x" + std::to_string(h) +
              ", expected " + std::to_string(first_w) + "x" + std::to_string(first_h) +
              " (the sequence's first omni image)";
      return false;
    }
    cv::Mat3b rgb(h, w);
    host::YuyvToRgb(yuyv.data(), w, h, rgb.data);
    cv::cvtColor(rgb, fr.bgr, cv::COLOR_RGB2BGR);
    frames.push_back(std::move(fr));
  }
  if (frames.empty()) {
    error = seq + ": no omni frames";
    return false;
  }
  return true;
}

CarpetColorCode ClassifyCarpetColor(float r, float g, float b) {
  const float mx = std::max({r, g, b}), mn = std::min({r, g, b});
  if (b - std::max(r, g) > 35 && b > 70) return kCarpetBlue;
  if (r - std::max(g, b) > 40 && r > 80) return kCarpetRed;
  if (mn > 110 && mx - mn < 40) return kCarpetWhite;
  return kCarpetOther;
}

std::vector<Transition> ScanRay(const cv::Mat3b& bgr, double cu, double cv, double phi, double r0,
                                double r1) {
  const double c = std::cos(phi), s = std::sin(phi);
  const int n = static_cast<int>((r1 - r0) / kRayStepPx);
  std::vector<Rgb> col(n);
  std::vector<CarpetColorCode> lab(n);
  for (int i = 0; i < n; ++i) {
    const double r = r0 + i * kRayStepPx;
    col[i] = At(bgr, cu + r * c, cv + r * s);
    lab[i] = ClassifyCarpetColor(col[i].r, col[i].g, col[i].b);
  }
  struct Run {
    CarpetColorCode l;
    int a, b;  // [a, b)
  };
  std::vector<Run> runs;
  for (int i = 0; i < n;) {
    int j = i;
    while (j < n && lab[j] == lab[i]) ++j;
    if (lab[i] != kCarpetOther && j - i >= 6) runs.push_back({lab[i], i, j});  // >= 1.5 px
    i = j;
  }
  std::vector<Transition> out;
  for (size_t k = 0; k + 1 < runs.size(); ++k) {
    const Run& A = runs[k];
    const Run& B = runs[k + 1];
    if (A.l == B.l || B.a - A.b > 12) continue;  // same class, or > 3 px of something else
    Rgb ca{}, cb{};
    for (int i = 0; i < 4; ++i) {
      const Rgb x = col[A.b - 1 - std::min(i, A.b - A.a - 1)];
      const Rgb y = col[B.a + std::min(i, B.b - B.a - 1)];
      ca = {ca.r + x.r / 4, ca.g + x.g / 4, ca.b + x.b / 4};
      cb = {cb.r + y.r / 4, cb.g + y.g / 4, cb.b + y.b / 4};
    }
    const Rgb d = cb - ca;
    const float dd = Dot(d, d);
    if (dd < 400) continue;
    double pos = -1;
    float prev = 0;
    for (int i = A.b - 2; i <= B.a + 1; ++i) {
      const float t = Dot(col[i] - ca, d) / dd;
      if (i > A.b - 2 && prev < 0.5f && t >= 0.5f) {
        pos = (i - 1) + (0.5f - prev) / (t - prev);
        break;
      }
      prev = t;
    }
    if (pos < 0) continue;
    out.push_back({r0 + pos * kRayStepPx, A.l, B.l});
  }
  return out;
}

std::vector<std::pair<int, int>> NumberTransitions(const std::vector<Transition>& tr,
                                                   const Carpet& carpet, int anchor_patch) {
  std::vector<std::pair<int, int>> out;
  const int n_edges = static_cast<int>(carpet.edges_m.size());
  int a = -1;
  for (size_t k = 0; k < tr.size(); ++k) {
    if (tr[k].from == carpet.colors[anchor_patch - 1] && tr[k].to == carpet.colors[anchor_patch]) {
      a = static_cast<int>(k);
    }
  }
  if (a < 0) return out;
  for (int k = a, m = anchor_patch; k >= 0 && m >= 1; --k, --m) {
    if (tr[k].from != carpet.colors[m - 1] || tr[k].to != carpet.colors[m]) break;
    if (k < a && tr[k].r_px >= tr[k + 1].r_px) break;
    out.emplace_back(k, m);
  }
  for (int k = a + 1, m = anchor_patch + 1; k < static_cast<int>(tr.size()) && m < n_edges - 1;
       ++k, ++m) {
    if (tr[k].from != carpet.colors[m - 1] || tr[k].to != carpet.colors[m]) break;
    out.emplace_back(k, m);
  }
  return out;
}

int AnchorPatch(const Carpet& carpet) {
  int anchor_patch = -1;
  for (size_t p = 0; p < carpet.colors.size(); ++p) {
    if (std::count(carpet.colors.begin(), carpet.colors.end(), carpet.colors[p]) == 1) {
      anchor_patch = static_cast<int>(p);
    }
  }
  return anchor_patch < 1 ? -1 : anchor_patch;
}

// Mirror rim circle: outermost bright radius along 360 rays of the mean image, circle fit.
bool FindCentre(const std::vector<Frame>& frames, RimFit& rim, std::string& error) {
  cv::Mat1f mean(frames[0].bgr.rows, frames[0].bgr.cols, 0.0f);
  const size_t step = std::max<size_t>(1, frames.size() / 30);
  int n = 0;
  for (size_t i = 0; i < frames.size(); i += step, ++n) {
    cv::Mat gray;
    cv::cvtColor(frames[i].bgr, gray, cv::COLOR_BGR2GRAY);
    cv::Mat1f g;
    gray.convertTo(g, CV_32F);
    mean += g;
  }
  mean /= static_cast<float>(n);
  const double u0 = mean.cols / 2.0, v0 = mean.rows / 2.0;
  const float thr = 40;
  std::vector<Eigen::Vector2d> pts;
  for (int a = 0; a < 360; ++a) {
    const double c = std::cos(a * kPi / 180), s = std::sin(a * kPi / 180);
    double prev_val = 0;
    for (double r = std::min(u0, v0) + 200; r > 20; r -= 0.5) {
      const double u = u0 + r * c, v = v0 + r * s;
      if (u < 1 || v < 1 || u >= mean.cols - 2 || v >= mean.rows - 2) {
        prev_val = 0;
        continue;
      }
      const int x = static_cast<int>(u), y = static_cast<int>(v);
      const double fx = u - x, fy = v - y;
      const double val = (1 - fx) * (1 - fy) * mean(y, x) + fx * (1 - fy) * mean(y, x + 1) +
                         (1 - fx) * fy * mean(y + 1, x) + fx * fy * mean(y + 1, x + 1);
      if (val >= thr) {
        const double rr = r + 0.5 * (val - thr) / std::max(val - prev_val, 1e-3);
        pts.emplace_back(u0 + rr * c, v0 + rr * s);
        break;
      }
      prev_val = val;
    }
  }
  if (pts.size() < 100) {
    error = "mirror rim not found (too few bright/dark boundary points)";
    return false;
  }
  double cu = 0, cv = 0, radius = 0;
  std::vector<Eigen::Vector2d> use = pts;
  for (int pass = 0; pass < 3; ++pass) {
    Eigen::MatrixXd A(use.size(), 3);
    Eigen::VectorXd b(use.size());
    for (size_t i = 0; i < use.size(); ++i) {
      A.row(i) << 2 * use[i].x(), 2 * use[i].y(), 1;
      b[i] = use[i].squaredNorm();
    }
    const Eigen::Vector3d x = A.colPivHouseholderQr().solve(b);
    cu = x[0];
    cv = x[1];
    radius = std::sqrt(x[2] + cu * cu + cv * cv);
    std::vector<double> res;
    for (const auto& p : pts)
      res.push_back(std::fabs((p - Eigen::Vector2d(cu, cv)).norm() - radius));
    std::vector<double> sorted = res;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    const double mad = std::max(sorted[sorted.size() / 2], 0.1);
    use.clear();
    for (size_t i = 0; i < pts.size(); ++i)
      if (res[i] < 3 * mad) use.push_back(pts[i]);
  }
  rim = {cu, cv, radius};
  if (!(std::isfinite(cu) && std::isfinite(cv))) {
    error = "mirror rim circle fit did not converge";
    return false;
  }
  return true;
}

bool FitImageAngle(const std::vector<Frame>& frames, const Carpet& carpet,
                   const std::string& carpet_path, const RimFit& rim, AngleFit& fit,
                   std::string& error) {
  const double r_min = 20, r_max = rim.radius - 3;
  std::vector<double> phi_c(frames.size(), -1);
  fit.theta_rad.assign(frames.size(), 0);
  for (size_t f = 0; f < frames.size(); ++f) {
    const auto bearing = carpet.azimuth_rad.find(frames[f].index);
    if (bearing == carpet.azimuth_rad.end()) {
      error =
          "frame " + std::to_string(frames[f].index) + " has no carpet bearing in " + carpet_path;
      return false;
    }
    fit.theta_rad[f] = bearing->second;
    std::vector<double> score(720, 0);
    for (int a = 0; a < 720; ++a) {
      const auto tr = ScanRay(frames[f].bgr, rim.cu, rim.cv, a * kPi / 360, r_min, r_max);
      for (const auto& t : tr) score[a] += (t.from != kCarpetOther && t.to != kCarpetOther) ? 1 : 0;
    }
    int best = 0;
    double best_s = -1;
    for (int a = 0; a < 720; ++a) {
      double s = 0;
      for (int k = -4; k <= 4; ++k) s += score[(a + k + 720) % 720];
      if (s > best_s) {
        best_s = s;
        best = a;
      }
    }
    if (best_s < 9 * 3) continue;  // carpet not seen in this frame
    double sx = 0, sy = 0;
    for (int k = -16; k <= 16; ++k) {
      const double w = score[(best + k + 720) % 720];
      const double a = (best + k) * kPi / 360;
      sx += w * std::cos(a);
      sy += w * std::sin(a);
    }
    phi_c[f] = Wrap2Pi(std::atan2(sy, sx));
  }
  fit.consistency = -1;
  for (int sg : {1, -1}) {
    double sx = 0, sy = 0;
    int n = 0;
    for (size_t f = 0; f < frames.size(); ++f) {
      if (phi_c[f] < 0) continue;
      const double d = phi_c[f] - sg * fit.theta_rad[f];
      sx += std::cos(d);
      sy += std::sin(d);
      ++n;
    }
    const double len = n ? std::hypot(sx, sy) / n : 0;
    if (len > fit.consistency) {
      fit.consistency = len;
      fit.sign = sg;
      fit.offset_rad = std::atan2(sy, sx);
    }
  }
  if (fit.consistency < 0.9) {
    char buf[160];
    std::snprintf(buf, sizeof buf,
                  "carpet directions do not follow the bearings (consistency %.2f)",
                  fit.consistency);
    error = buf;
    return false;
  }
  return true;
}

namespace {
using Vec5 = Eigen::Matrix<double, 5, 1>;
Vec5 HarmonicBasis(double p) {
  Vec5 row;
  row << 1, std::cos(p), std::sin(p), std::cos(2 * p), std::sin(2 * p);
  return row;
}

// corr = c0 + a1 cos + b1 sin + a2 cos 2 + b2 sin 2 of the fan's image angle: least squares, then
// again without the fans beyond 3 robust sigma. False unless finite with harmonics <= 0.1 rad.
bool FitHarmonics(const std::vector<double>& corr, const std::vector<double>& phi,
                  AngleRefinement& out, Vec5& x) {
  std::vector<bool> use(corr.size(), true);
  for (int pass = 0; pass < 2; ++pass) {
    Eigen::Matrix<double, 5, 5> ata = Eigen::Matrix<double, 5, 5>::Zero();
    Vec5 atb = Vec5::Zero();
    for (size_t i = 0; i < corr.size(); ++i) {
      if (!use[i]) continue;
      const Vec5 row = HarmonicBasis(phi[i]);
      ata += row * row.transpose();
      atb += row * corr[i];
    }
    x = ata.ldlt().solve(atb);
    std::vector<double> res(corr.size()), abs_res(corr.size());
    for (size_t i = 0; i < corr.size(); ++i) {
      res[i] = corr[i] - x.dot(HarmonicBasis(phi[i]));
      abs_res[i] = std::fabs(res[i]);
    }
    const double sigma = std::max(1.4826 * Median(abs_res), 1e-3);
    out.harmonic_outliers = 0;
    double ss = 0;
    size_t n = 0;
    for (size_t i = 0; i < corr.size(); ++i) {
      use[i] = abs_res[i] <= 3 * sigma;
      out.harmonic_outliers += use[i] ? 0 : 1;
      if (use[i]) {
        ss += res[i] * res[i];
        ++n;
      }
    }
    out.rms_after_rad = n > 0 ? std::sqrt(ss / n) : 0;
  }
  bool sane = x.allFinite();
  for (int k = 1; k < 5; ++k) sane = sane && std::fabs(x(k)) <= 0.1;
  return sane;
}
}  // namespace

AngleRefinement RefineAngleOffset(const std::vector<Frame>& frames, const Carpet& carpet,
                                  int anchor_patch, const RimFit& rim, AngleFit& fit) {
  constexpr int kHalfFan = 80;  // rays of 0.25°: ±20°
  const double r_min = 20, r_max = rim.radius - 3;
  std::vector<double> corr, fan_phi;  // per fan: residual, image angle of the centre line
  for (size_t f = 0; f < frames.size(); ++f) {
    const double phi0 = fit.sign * fit.theta_rad[f] + fit.offset_rad;
    std::map<int, std::pair<int, int>> fan;  // carpet edge -> (first ray, last ray)
    for (int j = -kHalfFan; j <= kHalfFan; ++j) {
      const double phi = Wrap2Pi(phi0 + j * 0.25 * kPi / 180);
      const auto tr = ScanRay(frames[f].bgr, rim.cu, rim.cv, phi, r_min, r_max);
      for (const auto& km : NumberTransitions(tr, carpet, anchor_patch)) {
        auto it = fan.find(km.second);
        if (it == fan.end()) {
          fan[km.second] = {j, j};
        } else {
          it->second.second = j;
        }
      }
    }
    for (const auto& [m, ext] : fan) {
      if (carpet.edges_m[m] < 1.8 || ext.first <= -kHalfFan || ext.second >= kHalfFan) continue;
      if (ext.second - ext.first < 4) continue;  // a few stray rays, not the strip
      corr.push_back(0.5 * (ext.first + ext.second) * 0.25 * kPi / 180);
      fan_phi.push_back(Wrap2Pi(phi0 + corr.back()));
    }
  }
  AngleRefinement out;
  out.fans = corr.size();
  if (corr.size() < 20) return out;
  out.applied = true;
  out.correction_rad = Median(corr);
  std::vector<double> dirs = fan_phi;
  std::sort(dirs.begin(), dirs.end());
  out.max_gap_rad = dirs.front() + 2 * kPi - dirs.back();
  for (size_t i = 1; i < dirs.size(); ++i)
    out.max_gap_rad = std::max(out.max_gap_rad, dirs[i] - dirs[i - 1]);
  double ss = 0;
  for (double c : corr) ss += (c - out.correction_rad) * (c - out.correction_rad);
  out.rms_before_rad = out.rms_after_rad = std::sqrt(ss / corr.size());
  Vec5 x;
  if (corr.size() >= 60 && out.max_gap_rad <= 45 * kPi / 180) {
    if (FitHarmonics(corr, fan_phi, out, x)) {
      out.harmonics = true;
      out.correction_rad = x(0);
      for (int k = 0; k < 4; ++k) fit.harmonics_rad[k] = x(k + 1);
    } else {
      out.rms_after_rad = out.rms_before_rad;
      out.harmonic_outliers = 0;
    }
  }
  fit.offset_rad = WrapPi(fit.offset_rad + out.correction_rad);
  return out;
}

double AzimuthCorrection(const AngleFit& fit, double phi) {
  const Vec5 h(0, fit.harmonics_rad[0], fit.harmonics_rad[1], fit.harmonics_rad[2],
               fit.harmonics_rad[3]);
  return h.dot(HarmonicBasis(phi));
}

RawSamples CollectSamples(const std::vector<Frame>& frames, const Carpet& carpet, int anchor_patch,
                          const RimFit& rim, const AngleFit& fit, double viewpoint_z_m) {
  const double r_min = 20, r_max = rim.radius - 3;
  const int sign = fit.sign;
  const double offset = fit.offset_rad;
  RawSamples out;
  const double zscale = viewpoint_z_m / (viewpoint_z_m - carpet.thickness_m);
  for (size_t f = 0; f < frames.size(); ++f) {
    const double phi0 = sign * fit.theta_rad[f] + offset;
    for (int j = -12; j <= 12; ++j) {
      const double phi = Wrap2Pi(phi0 + j * 0.5 * kPi / 180);
      const double delta =
          WrapPi(sign * (phi - offset - AzimuthCorrection(fit, phi)) - fit.theta_rad[f]);
      ++out.rays;
      const auto tr = ScanRay(frames[f].bgr, rim.cu, rim.cv, phi, r_min, r_max);
      const auto numbered = NumberTransitions(tr, carpet, anchor_patch);
      if (numbered.empty()) continue;
      ++out.rays_numbered;
      for (const auto& [k, m] : numbered) {
        const double e = carpet.edges_m[m];
        if (std::fabs(e * std::tan(delta)) > carpet.width_m / 2 - 0.1) continue;
        const double d = e / std::cos(delta) * zscale;
        out.samples.push_back({phi, tr[k].r_px, -1, m, d, frames[f].index});
      }
    }
  }
  return out;
}

bool ChooseEdges(const RawSamples& raw, const Carpet& carpet, EdgeChoice& out, std::string& error) {
  const int n_edges_all = static_cast<int>(carpet.edges_m.size());
  out.per_edge.assign(n_edges_all, 0);
  for (const auto& s : raw.samples) ++out.per_edge[s.carpet_edge];
  int best_count = -1;
  out.first = -1;
  for (int m = 0; m + kEdges <= n_edges_all; ++m) {
    int c = 0;
    for (int k = 0; k < kEdges; ++k) c += out.per_edge[m + k];
    if (c > best_count) {
      best_count = c;
      out.first = m;
    }
  }
  if (out.first < 0) {
    error = "the carpet has fewer than 12 edges";
    return false;
  }
  out.samples.clear();
  for (const auto& s : raw.samples)
    if (s.carpet_edge >= out.first && s.carpet_edge < out.first + kEdges) out.samples.push_back(s);
  for (int k = 0; k < kEdges; ++k) out.edge_m[k] = carpet.edges_m[out.first + k];
  return true;
}

bool CheckEdgeCounts(const EdgeChoice& edges, std::string& error) {
  for (int k = 0; k < kEdges; ++k) {
    if (edges.per_edge[edges.first + k] < 10) {
      char buf[200];
      std::snprintf(buf, sizeof buf,
                    "edge %.2f m found only %d times: the run misses directions or edges",
                    edges.edge_m[k], edges.per_edge[edges.first + k]);
      error = buf;
      return false;
    }
  }
  return true;
}

namespace {

// 1-D k-means of the sector's samples into 12 radii, seeded with `centre`; returns the
// cluster of each sample and leaves the sorted centres in `centre`.
std::vector<int> KMeans(const std::vector<Sample*>& in, double* centre) {
  std::vector<int> assign(in.size(), -1);
  for (int it = 0; it < 30; ++it) {
    bool changed = false;
    for (size_t i = 0; i < in.size(); ++i) {
      int best = 0;
      for (int k = 1; k < kEdges; ++k)
        if (std::fabs(in[i]->r_px - centre[k]) < std::fabs(in[i]->r_px - centre[best])) best = k;
      if (assign[i] != best) changed = true;
      assign[i] = best;
    }
    for (int k = 0; k < kEdges; ++k) {
      double sum = 0;
      int n = 0;
      for (size_t i = 0; i < in.size(); ++i)
        if (assign[i] == k) {
          sum += in[i]->r_px;
          ++n;
        }
      if (n) centre[k] = sum / n;
    }
    if (!changed) break;
  }
  std::sort(centre, centre + kEdges);
  return assign;
}

}  // namespace

SectorFit FitSectors(std::vector<Sample>& samples, int first_edge,
                     const std::array<double, kEdges>& edge_m) {
  SectorFit fit;
  // global medians per edge: k-means seeds and slopes
  for (int k = 0; k < kEdges; ++k) {
    std::vector<double> v;
    for (const auto& s : samples)
      if (s.carpet_edge == first_edge + k) v.push_back(s.r_px);
    fit.global[k] = MedianOrZero(v);
  }
  for (int s = 0; s < kSectors; ++s) {
    std::vector<Sample*> in;
    for (auto& x : samples)
      if (SectorOf(x.phi) == s) in.push_back(&x);
    // seeds: per-edge medians of the numbered samples in the sector, else global
    double centre[kEdges];
    for (int k = 0; k < kEdges; ++k) {
      std::vector<double> v;
      for (auto* x : in)
        if (x->carpet_edge == first_edge + k) v.push_back(x->r_px);
      centre[k] = v.empty() ? fit.global[k] : Median(v);
    }
    const std::vector<int> assign = KMeans(in, centre);
    for (int k = 0; k < kEdges; ++k) {
      std::vector<double> v;
      const double slope = Slope(centre, edge_m, k);
      for (size_t i = 0; i < in.size(); ++i) {
        if (assign[i] != k) continue;
        in[i]->edge = k;
        if (in[i]->carpet_edge != first_edge + k) ++fit.moved;
        // correct the sample to the edge's exact ground distance
        v.push_back(in[i]->r_px - slope * (in[i]->d_m - edge_m[k]));
      }
      fit.have[s][k] = static_cast<int>(v.size()) >= kMinSamplesPerEdge;
      fit.support[s][k] = MedianOrZero(v);
    }
    for (int k = 1; k < kEdges; ++k) {
      if (fit.have[s][k] && fit.have[s][k - 1] && !(fit.support[s][k] > fit.support[s][k - 1])) {
        for (auto& h : fit.have[s]) h = false;  // inconsistent sector: treat as occluded
      }
    }
  }
  return fit;
}

// A misaligned mirror makes each edge's radius a smooth, low-harmonic function of the
// direction. Support vectors far off a robust 2-harmonic fit come from misnumbered samples
// (field lines, strut shadows) and are re-interpolated.
int RejectInconsistent(SectorFit& fit) {
  int rejected = 0;
  for (int k = 0; k < kEdges; ++k) {
    std::vector<bool> use(kSectors);
    for (int s = 0; s < kSectors; ++s) use[s] = fit.have[s][k];
    for (int pass = 0; pass < 3; ++pass) {
      Eigen::MatrixXd A(kSectors, 5);
      Eigen::VectorXd b(kSectors), w(kSectors);
      for (int s = 0; s < kSectors; ++s) {
        const double a = (s + 0.5) * kSectorRad;
        A.row(s) << 1, std::cos(a), std::sin(a), std::cos(2 * a), std::sin(2 * a);
        b[s] = fit.support[s][k];
        w[s] = use[s] ? 1 : 0;
      }
      if (w.sum() < 10) break;
      const Eigen::MatrixXd Aw = w.asDiagonal() * A;
      const Eigen::VectorXd coef = Aw.colPivHouseholderQr().solve(w.asDiagonal() * b);
      const Eigen::VectorXd res = (A * coef - b).cwiseAbs();
      std::vector<double> rv;
      for (int s = 0; s < kSectors; ++s)
        if (use[s]) rv.push_back(res[s]);
      const double limit = std::max(1.5, 5 * Median(rv));
      for (int s = 0; s < kSectors; ++s) {
        if (fit.have[s][k] && res[s] > limit) use[s] = false;
      }
    }
    for (int s = 0; s < kSectors; ++s) {
      if (fit.have[s][k] && !use[s]) {
        fit.have[s][k] = false;
        ++rejected;
      }
    }
  }
  return rejected;
}

int CompleteSectors(const SectorFit& fit) {
  int n_good = 0;
  for (int s = 0; s < kSectors; ++s) {
    bool all = true;
    for (int k = 0; k < kEdges; ++k) all = all && fit.have[s][k];
    n_good += all ? 1 : 0;
  }
  return n_good;
}

// Missing support vectors: linear interpolation between the nearest good neighbours of the
// same edge. Smoothing: median of 3, then moving average of 3, circular, per edge.
void InterpolateAndSmooth(SectorFit& fit, OmniCalibration& cal) {
  for (int k = 0; k < kEdges; ++k) {
    for (int s = 0; s < kSectors; ++s) {
      if (fit.have[s][k]) continue;
      cal.sector_flags[s] |= kOmniSectorInterpolated;
      int a = s, b = s, da = 0, db = 0;
      while (!fit.have[a][k]) {
        a = (a + kSectors - 1) % kSectors;
        ++da;
      }
      while (!fit.have[b][k]) {
        b = (b + 1) % kSectors;
        ++db;
      }
      const double w = static_cast<double>(da) / (da + db);
      fit.support[s][k] = (1 - w) * fit.support[a][k] + w * fit.support[b][k];
    }
  }
  double med[kSectors][kEdges];
  for (int s = 0; s < kSectors; ++s)
    for (int k = 0; k < kEdges; ++k) {
      double v[3] = {fit.support[(s + kSectors - 1) % kSectors][k], fit.support[s][k],
                     fit.support[(s + 1) % kSectors][k]};
      std::sort(v, v + 3);
      med[s][k] = v[1];
    }
  for (int s = 0; s < kSectors; ++s)
    for (int k = 0; k < kEdges; ++k) {
      const double v =
          (med[(s + kSectors - 1) % kSectors][k] + med[s][k] + med[(s + 1) % kSectors][k]) / 3.0;
      cal.support_px[s][k] = static_cast<float>(v);
    }
}

std::array<double, kEdges> SymmetricSupport(const std::vector<Sample>& samples,
                                            const std::array<double, kEdges>& global,
                                            const std::array<double, kEdges>& edge_m) {
  std::array<double, kEdges> sym{};
  for (int k = 0; k < kEdges; ++k) {
    std::vector<double> v;
    for (const auto& x : samples)
      if (x.edge == k) v.push_back(x.r_px - Slope(global.data(), edge_m, k) * (x.d_m - edge_m[k]));
    sym[k] = MedianOrZero(v);
  }
  return sym;
}

// Per sample: the ground distance through each map, and the model's image radius of its true
// ground point.
Residuals ComputeResiduals(const OmniCalibration& cal, const OmniCalibration& symmetric,
                           const std::vector<Sample>& samples, const RimFit& rim,
                           const AngleFit& fit) {
  const double cu = rim.cu, cv = rim.cv;
  const int sign = fit.sign;
  const double offset = fit.offset_rad;
  Residuals out;
  double tot2 = 0, tot2_sym = 0;
  int tot_n = 0;
  for (int s = 0; s < kSectors; ++s) {
    double e2 = 0, p2 = 0, emax = 0, s2 = 0;
    int n = 0;
    for (const auto& x : samples) {
      if (SectorOf(x.phi) != s || x.edge < 0) continue;
      const double u = cu + x.r_px * std::cos(x.phi), v = cv + x.r_px * std::sin(x.phi);
      float gx, gy, ux, vx;
      if (!OmniPixelToGround(cal, static_cast<float>(u), static_cast<float>(v), gx, gy).ok())
        continue;
      const double rel = (std::hypot(gx, gy) - x.d_m) / x.d_m;
      const double th = sign * (x.phi - offset);
      if (OmniGroundToPixel(cal, static_cast<float>(x.d_m * std::cos(th)),
                            static_cast<float>(x.d_m * std::sin(th)), ux, vx)
              .ok()) {
        p2 += std::pow(std::hypot(ux - cu, vx - cv) - x.r_px, 2);
      }
      float sx, sy;
      if (OmniPixelToGround(symmetric, static_cast<float>(u), static_cast<float>(v), sx, sy).ok()) {
        s2 += std::pow((std::hypot(sx, sy) - x.d_m) / x.d_m, 2);
      }
      e2 += rel * rel;
      emax = std::max(emax, std::fabs(rel));
      ++n;
    }
    SectorResidual r;
    r.samples = n;
    r.interpolated = cal.sector_flags[s] != 0;
    r.rms_ground_rel = n ? std::sqrt(e2 / n) : 0;
    r.rms_px = n ? std::sqrt(p2 / n) : 0;
    r.symmetric_rms_ground_rel = n ? std::sqrt(s2 / n) : 0;
    r.max_ground_rel = emax;
    out.sectors.push_back(r);
    tot2 += e2;
    tot2_sym += s2;
    tot_n += n;
  }
  out.rms_ground_rel = tot_n ? std::sqrt(tot2 / tot_n) : 0;
  out.symmetric_rms_ground_rel = tot_n ? std::sqrt(tot2_sym / tot_n) : 0;
  return out;
}

json ResidualsJson(const Residuals& res) {
  json residuals = json::array();
  for (size_t s = 0; s < res.sectors.size(); ++s) {
    const SectorResidual& r = res.sectors[s];
    residuals.push_back({{"sector", static_cast<int>(s)},
                         {"samples", r.samples},
                         {"interpolated", r.interpolated},
                         {"rms_px", r.rms_px},
                         {"rms_ground_rel", r.rms_ground_rel},
                         {"max_ground_rel", r.max_ground_rel},
                         {"symmetric_rms_ground_rel", r.symmetric_rms_ground_rel}});
  }
  return residuals;
}

bool WriteReport(const std::string& dir, const std::vector<Sample>& samples,
                 const OmniCalibration& cal, const std::array<double, kEdges>& edge_m,
                 const std::array<double, kEdges>& symmetric, const Residuals& res,
                 std::string& error) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  std::ostringstream fs_;
  fs_ << "phi_deg,r_px,edge,edge_m,d_m,frame\n";
  for (const auto& x : samples) {
    fs_ << x.phi * 180 / kPi << ',' << x.r_px << ',' << x.edge << ','
        << (x.edge >= 0 ? edge_m[x.edge] : 0) << ',' << x.d_m << ',' << x.frame << '\n';
  }
  std::ostringstream fv;
  fv << "sector,phi_centre_deg,interpolated";
  for (int k = 0; k < kEdges; ++k) fv << ",r_" << edge_m[k];
  fv << "\n";
  for (int s = 0; s < kSectors; ++s) {
    fv << s << ',' << (s + 0.5) * 8 << ',' << int(cal.sector_flags[s]);
    for (int k = 0; k < kEdges; ++k) fv << ',' << cal.support_px[s][k];
    fv << '\n';
  }
  std::ostringstream fy;
  fy << "edge_m,r_px\n";
  for (int k = 0; k < kEdges; ++k) fy << edge_m[k] << ',' << symmetric[k] << '\n';
  std::ostringstream fr;
  fr << ResidualsJson(res).dump(1) << '\n';
  const std::pair<const char*, const std::ostringstream*> files[] = {{"omni_samples.csv", &fs_},
                                                                     {"omni_support.csv", &fv},
                                                                     {"omni_symmetric.csv", &fy},
                                                                     {"omni_residuals.json", &fr}};
  for (const auto& [name, text] : files) {
    if (!WriteFileAtomic((fs::path(dir) / name).string(), text->str(), error)) return false;
  }
  return true;
}

json OmniSection(const OmniCalibration& cal, size_t samples, double rim_radius_px,
                 const std::array<double, kEdges>& symmetric, const Residuals& res) {
  json section = OmniToJson(cal);
  section["samples"] = static_cast<int>(samples);
  section["rim_radius_px"] = rim_radius_px;
  section["symmetric_support_px"] = std::vector<double>(symmetric.begin(), symmetric.end());
  section["rms_ground_rel"] = res.rms_ground_rel;
  section["symmetric_rms_ground_rel"] = res.symmetric_rms_ground_rel;
  return section;
}

}  // namespace bv::cli::omni
