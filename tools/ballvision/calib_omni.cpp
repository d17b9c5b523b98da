// Model-free omni calibration (paper section III-B) from a carpet run:
//  1. image centre = centre of the mirror rim circle (mean image, radial edge points, circle fit);
//  2. per frame, the carpet's image direction (most white/blue transitions along a ray); with
//     the known bearing per frame this gives the image-angle <-> robot-azimuth relation;
//  3. along rays near the carpet centre line, the colour transitions between patches
//     (sub-pixel), numbered by the uniquely coloured (red) patch and the colour sequence;
//  4. per 8° sector, k-means (12 clusters, one per edge) over the samples of the 12 innermost
//     visible edges; cluster medians (corrected to the edge's exact ground distance) are the
//     support vectors;
//  5. sectors with too few samples (mirror struts) are interpolated and flagged; then median
//     and moving-average smoothing across neighbouring directions per edge.
// The carpet top is `thickness_m` above the floor: sample distances are projected to z = 0
// through the viewpoint f_O.
#include "tools/ballvision/calib_omni.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <numeric>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/calibration/calibration.h"
#include "hal/host/sequence.h"
#include "tools/ballvision/calib_io.h"
#include "tools/ballvision/carpet_json.h"
#include "tools/ballvision/cli_args.h"
#include "tools/ballvision/safe_write.h"
#include "tools/ballvision/signals.h"

namespace bv::cli {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr double kPi = 3.14159265358979323846;
constexpr int kS = OmniCalibration::kDirections;
constexpr int kE = OmniCalibration::kEdges;
constexpr double kSectorRad = 2 * kPi / kS;
constexpr double kRayStepPx = 0.25;
constexpr int kMinSamplesPerEdge = 2;  // fewer in a sector: occluded, interpolated

// Same codes as Carpet::colors (carpet_json.h).
enum Label : uint8_t {
  kOther = kCarpetOther,
  kWhite = kCarpetWhite,
  kBlue = kCarpetBlue,
  kRed = kCarpetRed
};

struct Rgb {
  float r = 0, g = 0, b = 0;
};

Rgb operator-(Rgb a, Rgb b) { return {a.r - b.r, a.g - b.g, a.b - b.b}; }
float Dot(Rgb a, Rgb b) { return a.r * b.r + a.g * b.g + a.b * b.b; }

Label Classify(Rgb c) {
  const float mx = std::max({c.r, c.g, c.b}), mn = std::min({c.r, c.g, c.b});
  if (c.b - std::max(c.r, c.g) > 35 && c.b > 70) return kBlue;
  if (c.r - std::max(c.g, c.b) > 40 && c.r > 80) return kRed;
  if (mn > 110 && mx - mn < 40) return kWhite;
  return kOther;
}

double Wrap2Pi(double a) {
  a = std::fmod(a, 2 * kPi);
  return a < 0 ? a + 2 * kPi : a;
}
double WrapPi(double a) { return Wrap2Pi(a + kPi) - kPi; }

struct Image {
  cv::Mat3b bgr;
  Rgb At(double u, double v) const {
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
};

struct Transition {
  double r_px;
  Label from, to;
};

// Colour transitions between carpet classes along the ray at image angle phi.
std::vector<Transition> ScanRay(const Image& im, double cu, double cv, double phi, double r0,
                                double r1) {
  const double c = std::cos(phi), s = std::sin(phi);
  const int n = static_cast<int>((r1 - r0) / kRayStepPx);
  std::vector<Rgb> col(n);
  std::vector<Label> lab(n);
  for (int i = 0; i < n; ++i) {
    const double r = r0 + i * kRayStepPx;
    col[i] = im.At(cu + r * c, cv + r * s);
    lab[i] = Classify(col[i]);
  }
  struct Run {
    Label l;
    int a, b;  // [a, b)
  };
  std::vector<Run> runs;
  for (int i = 0; i < n;) {
    int j = i;
    while (j < n && lab[j] == lab[i]) ++j;
    if (lab[i] != kOther && j - i >= 6) runs.push_back({lab[i], i, j});  // >= 1.5 px
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

// Numbers the transitions of one ray by the carpet's uniquely coloured patch: the transition
// into it is edge `anchor_patch`; walking inwards and outwards, each transition must match the
// carpet's colour sequence. Returns (transition index, carpet edge index) pairs.
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

struct Frame {
  long index;
  std::string name;
  Image im;
};

// frames.csv through the strict sequence reader (hal/host/sequence.h); every omni image must
// have the first one's size.
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
    cv::cvtColor(rgb, fr.im.bgr, cv::COLOR_RGB2BGR);
    frames.push_back(std::move(fr));
  }
  if (frames.empty()) {
    error = seq + ": no omni frames";
    return false;
  }
  return true;
}

// Mirror rim circle: outermost bright radius along 360 rays of the mean image, circle fit.
bool FindCentre(const std::vector<Frame>& frames, double& cu, double& cv, double& radius,
                std::string& error) {
  cv::Mat1f mean(frames[0].im.bgr.rows, frames[0].im.bgr.cols, 0.0f);
  const size_t step = std::max<size_t>(1, frames.size() / 30);
  int n = 0;
  for (size_t i = 0; i < frames.size(); i += step, ++n) {
    cv::Mat gray;
    cv::cvtColor(frames[i].im.bgr, gray, cv::COLOR_BGR2GRAY);
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
  return std::isfinite(cu) && std::isfinite(cv);
}

struct Sample {
  double phi;       // image angle of the ray, [0, 2pi)
  double r_px;      // image distance from the centre
  int edge;         // index into the chosen 12 edges (after k-means)
  int carpet_edge;  // index into carpet edges_m (from the colour numbering)
  double d_m;       // true ground distance (z = 0) of the sample
  long frame;
};

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  double m = v[v.size() / 2];
  if (v.size() % 2 == 0) {
    m = 0.5 * (m + *std::max_element(v.begin(), v.begin() + v.size() / 2));
  }
  return m;
}

void Usage() {
  std::fprintf(stderr,
               "usage: ballvision calibrate omni SEQ --carpet SEQ/carpet.json --viewpoint-z F_O\n"
               "         --out CALIB.json [--report DIR]\n"
               "  F_O: mirror viewpoint height (m), a mechanical constant of the rig\n"
               "  --report DIR: samples, support vectors, residuals as CSV (plot with\n"
               "                tools/python/plot_omni_calib.py DIR)\n");
}

}  // namespace

int CalibrateOmni(int argc, char** argv) {
  std::string seq, carpet_path, out, report;
  double f_o = 0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      Usage();
      return 0;
    }
    if (a.rfind("--", 0) == 0) {
      if (i + 1 >= argc) {
        Usage();
        return 2;
      }
      const std::string v = argv[++i];
      if (a == "--carpet") {
        carpet_path = v;
      } else if (a == "--viewpoint-z") {
        std::string e;
        if (!ArgNumber(a, v, 0.05, 5, f_o, e)) {
          std::fprintf(stderr, "calibrate omni: %s (the mirror viewpoint height in metres)\n",
                       e.c_str());
          return 2;
        }
      } else if (a == "--out") {
        out = v;
      } else if (a == "--report") {
        report = v;
      } else {
        std::fprintf(stderr, "calibrate omni: unknown option %s\n", a.c_str());
        return 2;
      }
    } else if (seq.empty()) {
      seq = a;
    } else {
      Usage();
      return 2;
    }
  }
  if (seq.empty() || out.empty()) {
    Usage();
    return 2;
  }
  if (carpet_path.empty()) carpet_path = (fs::path(seq) / "carpet.json").string();
  if (!(f_o > 0.05 && f_o < 5)) {
    std::fprintf(stderr,
                 "calibrate omni: --viewpoint-z must be the mirror viewpoint height in "
                 "metres (0.05..5)\n");
    return 2;
  }
  std::string error;
  Carpet carpet;
  std::vector<Frame> frames;
  if (!LoadCarpet(carpet_path, carpet, error) || !LoadFrames(seq, frames, error)) {
    std::fprintf(stderr, "calibrate omni: %s; no calibration written\n", error.c_str());
    return 1;
  }
  // Red (unique colour) patch numbers the edges.
  int anchor_patch = -1;
  for (size_t p = 0; p < carpet.colors.size(); ++p) {
    if (std::count(carpet.colors.begin(), carpet.colors.end(), carpet.colors[p]) == 1) {
      anchor_patch = static_cast<int>(p);
    }
  }
  if (anchor_patch < 1) {
    std::fprintf(stderr,
                 "calibrate omni: the carpet needs one uniquely coloured patch (after "
                 "the first) to number the edges; no calibration written\n");
    return 1;
  }

  // 1. centre
  double cu = 0, cv = 0, rim = 0;
  if (!FindCentre(frames, cu, cv, rim, error)) {
    std::fprintf(stderr, "calibrate omni: %s; no calibration written\n", error.c_str());
    return 1;
  }
  std::printf("image centre (mirror rim circle): (%.2f, %.2f) px, rim radius %.1f px\n", cu, cv,
              rim);
  const double r_min = 20, r_max = rim - 3;

  // 2. carpet direction per frame -> image angle relation
  std::vector<double> phi_c(frames.size(), -1), theta_c(frames.size(), 0);
  for (size_t f = 0; f < frames.size(); ++f) {
    if (!carpet.azimuth_rad.count(frames[f].index)) {
      std::fprintf(stderr, "calibrate omni: frame %ld has no carpet bearing in %s\n",
                   frames[f].index, carpet_path.c_str());
      return 1;
    }
    theta_c[f] = carpet.azimuth_rad[frames[f].index];
    std::vector<double> score(720, 0);
    for (int a = 0; a < 720; ++a) {
      const auto tr = ScanRay(frames[f].im, cu, cv, a * kPi / 360, r_min, r_max);
      for (const auto& t : tr) score[a] += (t.from != kOther && t.to != kOther) ? 1 : 0;
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
  int sign = 1;
  double offset = 0, best_len = -1;
  for (int sg : {1, -1}) {
    double sx = 0, sy = 0;
    int n = 0;
    for (size_t f = 0; f < frames.size(); ++f) {
      if (phi_c[f] < 0) continue;
      const double d = phi_c[f] - sg * theta_c[f];
      sx += std::cos(d);
      sy += std::sin(d);
      ++n;
    }
    const double len = n ? std::hypot(sx, sy) / n : 0;
    if (len > best_len) {
      best_len = len;
      sign = sg;
      offset = std::atan2(sy, sx);
    }
  }
  if (best_len < 0.9) {
    std::fprintf(stderr,
                 "calibrate omni: carpet directions do not follow the bearings (consistency "
                 "%.2f); no calibration written\n",
                 best_len);
    return 1;
  }
  std::printf("image angle = %+d * robot azimuth %+.2f deg (consistency %.4f over %zu frames)\n",
              sign, offset * 180 / kPi, best_len, frames.size());

  // Refine the offset: seen from the centre, the strip's two sides are symmetric about its
  // centre line, so per frame and edge (>= 1.8 m, where the strip spans < ±10°) the middle of
  // the fan of rays that see that edge is the centre line's image angle.
  {
    constexpr int kHalfFan = 80;  // rays of 0.25°: ±20°
    std::vector<double> corr;
    for (size_t f = 0; f < frames.size(); ++f) {
      const double phi0 = sign * theta_c[f] + offset;
      std::map<int, std::pair<int, int>> fan;  // carpet edge -> (first ray, last ray)
      for (int j = -kHalfFan; j <= kHalfFan; ++j) {
        const double phi = Wrap2Pi(phi0 + j * 0.25 * kPi / 180);
        const auto tr = ScanRay(frames[f].im, cu, cv, phi, r_min, r_max);
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
      }
    }
    if (corr.size() >= 20) {
      const double c = Median(corr);
      offset = WrapPi(offset + c);
      std::printf("angle offset refined by %+.3f deg from the strip sides (%zu fans): %+.3f deg\n",
                  c * 180 / kPi, corr.size(), offset * 180 / kPi);
    }
  }

  // 3. samples along rays near the carpet centre line
  const int n_edges_all = static_cast<int>(carpet.edges_m.size());
  std::vector<Sample> raw;
  int rays = 0, rays_numbered = 0;
  const double zscale = f_o / (f_o - carpet.thickness_m);
  for (size_t f = 0; f < frames.size(); ++f) {
    const double phi0 = sign * theta_c[f] + offset;
    for (int j = -12; j <= 12; ++j) {
      const double phi = Wrap2Pi(phi0 + j * 0.5 * kPi / 180);
      const double delta = WrapPi(sign * (phi - offset) - theta_c[f]);
      ++rays;
      const auto tr = ScanRay(frames[f].im, cu, cv, phi, r_min, r_max);
      const auto numbered = NumberTransitions(tr, carpet, anchor_patch);
      if (numbered.empty()) continue;
      ++rays_numbered;
      for (const auto& [k, m] : numbered) {
        const double e = carpet.edges_m[m];
        if (std::fabs(e * std::tan(delta)) > carpet.width_m / 2 - 0.1) continue;
        const double d = e / std::cos(delta) * zscale;
        raw.push_back({phi, tr[k].r_px, -1, m, d, frames[f].index});
      }
    }
  }
  // the 12 consecutive carpet edges with the most samples
  std::vector<int> per_edge(n_edges_all, 0);
  for (const auto& s : raw) ++per_edge[s.carpet_edge];
  int first = -1, best_count = -1;
  for (int m = 0; m + kE <= n_edges_all; ++m) {
    int c = 0;
    for (int k = 0; k < kE; ++k) c += per_edge[m + k];
    if (c > best_count) {
      best_count = c;
      first = m;
    }
  }
  if (first < 0) {
    std::fprintf(stderr,
                 "calibrate omni: the carpet has fewer than 12 edges; no calibration "
                 "written\n");
    return 1;
  }
  std::vector<Sample> samples;
  for (const auto& s : raw)
    if (s.carpet_edge >= first && s.carpet_edge < first + kE) samples.push_back(s);
  std::printf("%d rays, %d numbered by the red patch, %zu samples of edges %.2f..%.2f m\n", rays,
              rays_numbered, samples.size(), carpet.edges_m[first], carpet.edges_m[first + kE - 1]);
  for (int k = 0; k < kE; ++k) {
    if (per_edge[first + k] < 10) {
      std::fprintf(stderr,
                   "calibrate omni: edge %.2f m found only %d times: the run misses "
                   "directions or edges; no calibration written\n",
                   carpet.edges_m[first + k], per_edge[first + k]);
      return 1;
    }
  }
  if (samples.size() < 1000) {
    std::fprintf(stderr, "calibrate omni: warning: only %zu samples (paper: over 1000)\n",
                 samples.size());
  }

  // 4. per sector k-means, support vectors
  OmniCalibration cal;
  cal.valid = true;
  cal.center_u = static_cast<float>(cu);
  cal.center_v = static_cast<float>(cv);
  cal.viewpoint_z_m = static_cast<float>(f_o);
  cal.image_angle_sign = static_cast<int8_t>(sign);
  cal.image_angle_offset_rad = static_cast<float>(offset);
  double edge_m[kE];
  for (int k = 0; k < kE; ++k) {
    edge_m[k] = carpet.edges_m[first + k];
    cal.edge_ground_m[k] = static_cast<float>(edge_m[k]);
  }
  // global medians per edge: k-means seeds and slopes
  double global[kE];
  for (int k = 0; k < kE; ++k) {
    std::vector<double> v;
    for (const auto& s : samples)
      if (s.carpet_edge == first + k) v.push_back(s.r_px);
    global[k] = Median(v);
  }
  auto slope_at = [&](const double* centre, int k) {
    const int a = std::max(k - 1, 0), b = std::min(k + 1, kE - 1);
    return (centre[b] - centre[a]) / (edge_m[b] - edge_m[a]);
  };
  double support[kS][kE] = {};
  bool have[kS][kE] = {};
  int moved = 0;
  for (int s = 0; s < kS; ++s) {
    std::vector<Sample*> in;
    for (auto& x : samples)
      if (static_cast<int>(x.phi / kSectorRad) % kS == s) in.push_back(&x);
    // seeds: per-edge medians of the numbered samples in the sector, else global
    double centre[kE];
    for (int k = 0; k < kE; ++k) {
      std::vector<double> v;
      for (auto* x : in)
        if (x->carpet_edge == first + k) v.push_back(x->r_px);
      centre[k] = v.empty() ? global[k] : Median(v);
    }
    std::vector<int> assign(in.size(), -1);
    for (int it = 0; it < 30; ++it) {
      bool changed = false;
      for (size_t i = 0; i < in.size(); ++i) {
        int best = 0;
        for (int k = 1; k < kE; ++k)
          if (std::fabs(in[i]->r_px - centre[k]) < std::fabs(in[i]->r_px - centre[best])) best = k;
        if (assign[i] != best) changed = true;
        assign[i] = best;
      }
      for (int k = 0; k < kE; ++k) {
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
    std::sort(centre, centre + kE);
    for (int k = 0; k < kE; ++k) {
      std::vector<double> v;
      const double slope = slope_at(centre, k);
      for (size_t i = 0; i < in.size(); ++i) {
        if (assign[i] != k) continue;
        in[i]->edge = k;
        if (in[i]->carpet_edge != first + k) ++moved;
        // correct the sample to the edge's exact ground distance
        v.push_back(in[i]->r_px - slope * (in[i]->d_m - edge_m[k]));
      }
      have[s][k] = static_cast<int>(v.size()) >= kMinSamplesPerEdge;
      support[s][k] = Median(v);
    }
    for (int k = 1; k < kE; ++k) {
      if (have[s][k] && have[s][k - 1] && !(support[s][k] > support[s][k - 1])) {
        for (auto& h : have[s]) h = false;  // inconsistent sector: treat as occluded
      }
    }
  }
  // Consistency across directions: a misaligned mirror makes each edge's radius a smooth,
  // low-harmonic function of the direction. Support vectors far off a robust 2-harmonic fit
  // come from misnumbered samples (field lines, strut shadows) and are re-interpolated.
  int rejected = 0;
  for (int k = 0; k < kE; ++k) {
    std::vector<bool> use(kS);
    for (int s = 0; s < kS; ++s) use[s] = have[s][k];
    for (int pass = 0; pass < 3; ++pass) {
      Eigen::MatrixXd A(kS, 5);
      Eigen::VectorXd b(kS), w(kS);
      for (int s = 0; s < kS; ++s) {
        const double a = (s + 0.5) * kSectorRad;
        A.row(s) << 1, std::cos(a), std::sin(a), std::cos(2 * a), std::sin(2 * a);
        b[s] = support[s][k];
        w[s] = use[s] ? 1 : 0;
      }
      if (w.sum() < 10) break;
      const Eigen::MatrixXd Aw = w.asDiagonal() * A;
      const Eigen::VectorXd coef = Aw.colPivHouseholderQr().solve(w.asDiagonal() * b);
      const Eigen::VectorXd res = (A * coef - b).cwiseAbs();
      std::vector<double> rv;
      for (int s = 0; s < kS; ++s)
        if (use[s]) rv.push_back(res[s]);
      const double limit = std::max(1.5, 5 * Median(rv));
      for (int s = 0; s < kS; ++s) {
        if (have[s][k] && res[s] > limit) use[s] = false;
      }
    }
    for (int s = 0; s < kS; ++s) {
      if (have[s][k] && !use[s]) {
        have[s][k] = false;
        ++rejected;
      }
    }
  }
  std::printf("%d support vectors rejected as inconsistent with their neighbours\n", rejected);
  // 5. occluded sectors / edges: linear interpolation between the nearest good neighbours of
  // the same edge; a sector with any interpolated edge is flagged.
  int n_good = 0;
  for (int s = 0; s < kS; ++s) {
    bool all = true;
    for (int k = 0; k < kE; ++k) all = all && have[s][k];
    n_good += all ? 1 : 0;
  }
  if (n_good < kS / 2) {
    std::fprintf(stderr,
                 "calibrate omni: only %d of %d directions have samples of all 12 "
                 "edges (the run misses directions); no calibration written\n",
                 n_good, kS);
    return 1;
  }
  for (int k = 0; k < kE; ++k) {
    for (int s = 0; s < kS; ++s) {
      if (have[s][k]) continue;
      cal.sector_flags[s] |= kOmniSectorInterpolated;
      int a = s, b = s, da = 0, db = 0;
      while (!have[a][k]) {
        a = (a + kS - 1) % kS;
        ++da;
      }
      while (!have[b][k]) {
        b = (b + 1) % kS;
        ++db;
      }
      const double w = static_cast<double>(da) / (da + db);
      support[s][k] = (1 - w) * support[a][k] + w * support[b][k];
    }
  }
  // smoothing: median of 3, then moving average of 3, circular, per edge
  double med[kS][kE];
  for (int s = 0; s < kS; ++s)
    for (int k = 0; k < kE; ++k) {
      double v[3] = {support[(s + kS - 1) % kS][k], support[s][k], support[(s + 1) % kS][k]};
      std::sort(v, v + 3);
      med[s][k] = v[1];
    }
  for (int s = 0; s < kS; ++s)
    for (int k = 0; k < kE; ++k) {
      const double v = (med[(s + kS - 1) % kS][k] + med[s][k] + med[(s + 1) % kS][k]) / 3.0;
      cal.support_px[s][k] = static_cast<float>(v);
    }
  // symmetric (one-direction) fit for comparison
  double sym[kE];
  for (int k = 0; k < kE; ++k) {
    std::vector<double> v;
    for (const auto& x : samples)
      if (x.edge == k) v.push_back(x.r_px - slope_at(global, k) * (x.d_m - edge_m[k]));
    sym[k] = Median(v);
  }
  OmniCalibration symcal = cal;
  for (int s = 0; s < kS; ++s)
    for (int k = 0; k < kE; ++k) symcal.support_px[s][k] = static_cast<float>(sym[k]);

  // residuals per direction (ground distance of each sample through the final map)
  std::printf("%zu samples; k-means moved %d samples to another edge than the colour numbering\n",
              samples.size(), moved);
  std::printf(
      "sector  deg        n  flag  rms_px  rms_ground_%%  max_ground_%%  symmetric_rms_%%\n");
  json residuals = json::array();
  double tot2 = 0, tot2_sym = 0;
  int tot_n = 0;
  for (int s = 0; s < kS; ++s) {
    double e2 = 0, p2 = 0, emax = 0, s2 = 0;
    int n = 0;
    for (const auto& x : samples) {
      if (static_cast<int>(x.phi / kSectorRad) % kS != s || x.edge < 0) continue;
      const double u = cu + x.r_px * std::cos(x.phi), v = cv + x.r_px * std::sin(x.phi);
      float gx, gy, ux, vx;
      if (!OmniPixelToGround(cal, static_cast<float>(u), static_cast<float>(v), gx, gy).ok())
        continue;
      const double rel = (std::hypot(gx, gy) - x.d_m) / x.d_m;
      // pixel residual: the model's image radius of the sample's ground point
      const double th = sign * (x.phi - offset);
      if (OmniGroundToPixel(cal, static_cast<float>(x.d_m * std::cos(th)),
                            static_cast<float>(x.d_m * std::sin(th)), ux, vx)
              .ok()) {
        p2 += std::pow(std::hypot(ux - cu, vx - cv) - x.r_px, 2);
      }
      float sx, sy;
      if (OmniPixelToGround(symcal, static_cast<float>(u), static_cast<float>(v), sx, sy).ok()) {
        s2 += std::pow((std::hypot(sx, sy) - x.d_m) / x.d_m, 2);
      }
      e2 += rel * rel;
      emax = std::max(emax, std::fabs(rel));
      ++n;
    }
    const double rms = n ? std::sqrt(e2 / n) : 0, prms = n ? std::sqrt(p2 / n) : 0;
    const double srms = n ? std::sqrt(s2 / n) : 0;
    tot2 += e2;
    tot2_sym += s2;
    tot_n += n;
    std::printf("%4d  %3d-%3d  %5d  %4s  %6.3f  %11.3f  %12.3f  %15.3f\n", s, s * 8, s * 8 + 8, n,
                cal.sector_flags[s] ? "int" : "", prms, 100 * rms, 100 * emax, 100 * srms);
    residuals.push_back({{"sector", s},
                         {"samples", n},
                         {"interpolated", cal.sector_flags[s] != 0},
                         {"rms_px", prms},
                         {"rms_ground_rel", rms},
                         {"max_ground_rel", emax},
                         {"symmetric_rms_ground_rel", srms}});
  }
  const double all_rms = tot_n ? std::sqrt(tot2 / tot_n) : 0;
  const double all_sym = tot_n ? std::sqrt(tot2_sym / tot_n) : 0;
  std::printf("all samples: ground-distance rms %.3f %% (model-free) vs %.3f %% (symmetric fit)\n",
              100 * all_rms, 100 * all_sym);

  if (!report.empty()) {
    fs::create_directories(report);
    std::ostringstream fs_;
    fs_ << "phi_deg,r_px,edge,edge_m,d_m,frame\n";
    for (const auto& x : samples) {
      fs_ << x.phi * 180 / kPi << ',' << x.r_px << ',' << x.edge << ','
          << (x.edge >= 0 ? edge_m[x.edge] : 0) << ',' << x.d_m << ',' << x.frame << '\n';
    }
    std::ostringstream fv;
    fv << "sector,phi_centre_deg,interpolated";
    for (int k = 0; k < kE; ++k) fv << ",r_" << edge_m[k];
    fv << "\n";
    for (int s = 0; s < kS; ++s) {
      fv << s << ',' << (s + 0.5) * 8 << ',' << int(cal.sector_flags[s]);
      for (int k = 0; k < kE; ++k) fv << ',' << cal.support_px[s][k];
      fv << '\n';
    }
    std::ostringstream fy;
    fy << "edge_m,r_px\n";
    for (int k = 0; k < kE; ++k) fy << edge_m[k] << ',' << sym[k] << '\n';
    std::ostringstream fr;
    fr << residuals.dump(1) << '\n';
    const std::pair<const char*, const std::ostringstream*> files[] = {
        {"omni_samples.csv", &fs_},
        {"omni_support.csv", &fv},
        {"omni_symmetric.csv", &fy},
        {"omni_residuals.json", &fr}};
    for (const auto& [name, text] : files) {
      std::string e;
      if (!WriteFileAtomic((fs::path(report) / name).string(), text->str(), e)) {
        std::fprintf(stderr, "calibrate omni: report: %s\n", e.c_str());
        return 1;
      }
    }
    std::printf("report written to %s\n", report.c_str());
  }

  json section = OmniToJson(cal);
  section["samples"] = static_cast<int>(samples.size());
  section["rim_radius_px"] = rim;
  section["symmetric_support_px"] = std::vector<double>(sym, sym + kE);
  section["rms_ground_rel"] = all_rms;
  section["symmetric_rms_ground_rel"] = all_sym;
  if (InterruptSignal()) return 1;  // CmdCalibrate reports it; nothing written
  if (!UpdateCalibrationSection(out, "omni", section, error)) {
    std::fprintf(stderr, "calibrate omni: %s\n", error.c_str());
    return 1;
  }
  std::printf("wrote omni section of %s\n", out.c_str());
  return 0;
}

}  // namespace bv::cli
