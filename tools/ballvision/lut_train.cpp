#include "tools/ballvision/lut_train.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>

#include <opencv2/imgproc.hpp>

#include "core/color_lut/color_model.h"

#include "hal/host/sequence.h"
#include "tools/ballvision/annotate_frontend.h"
#include "tools/ballvision/box_file.h"
#include "tools/ballvision/signals.h"
#include "tools/ballvision/still_image.h"
#include "tools/ballvision/truth_csv.h"

namespace bv::lut {

bool LoadImage(const std::string& path, Image& out, std::string& error) {
  if (path.size() > 5 && path.substr(path.size() - 5) == ".yuyv") {
    return host::LoadYuyv(path, out.yuyv, out.width, out.height, error);
  }
  cli::Still still;
  if (!cli::LoadStill(path, still, error)) return false;
  out = std::move(still.image);
  return true;
}

Trainer::Trainer(const TrainOptions& options)
    : opt_(options), ball_(ColorLut::kEntries, 0.0f), other_(ColorLut::kEntries, 0.0f) {}

void Trainer::AddBall(uint8_t y, uint8_t u, uint8_t v, float weight) {
  const int n = std::max(1, opt_.shade_steps);
  for (int i = 0; i < n; ++i) {
    const float k =
        n == 1 ? 1.0f : opt_.shade_min + (opt_.shade_max - opt_.shade_min) * i / (n - 1);
    const float ys = y * k, us = 128 + (u - 128) * k, vs = 128 + (v - 128) * k;
    if (ys > 255 || us < 0 || us > 255 || vs < 0 || vs > 255) continue;
    ball_[ColorLut::Index(static_cast<uint8_t>(ys), static_cast<uint8_t>(us),
                          static_cast<uint8_t>(vs))] += weight / n;
  }
  ball_total_ += weight;
  const double d = y + 16.0, a = (u - 128) / d, b = (v - 128) / d;
  sa_ += weight * a;
  sb_ += weight * b;
  saa_ += weight * a * a;
  sab_ += weight * a * b;
  sbb_ += weight * b * b;
  sn_ += weight;
  ball_y_hist_[y] += weight;
}

void Trainer::AddOther(uint8_t y, uint8_t u, uint8_t v, float weight) {
  other_[ColorLut::Index(y, u, v)] += weight;
  other_total_ += weight;
}

void Trainer::AddClass(ColorClass c, uint8_t y, uint8_t u, uint8_t v) {
  if (c == ColorClass::kBall) {
    AddBall(y, u, v);
    return;
  }
  AddOther(y, u, v);
  taught_[static_cast<int>(c)].push_back(ColorLut::Index(y, u, v));
}

void Trainer::AddMask(const Image& img, const std::vector<uint8_t>& mask) {
  const YuyvImage view = img.view();
  for (int v = 0; v < img.height; ++v) {
    for (int u = 0; u < img.width; ++u) {
      const uint8_t m = mask[static_cast<size_t>(v) * img.width + u];
      const Yuv p = view.at(u, v);
      if (m == 1) AddBall(p.y, p.u, p.v);
      if (m == 0 && (u % opt_.other_stride) == 0 && (v % opt_.other_stride) == 0) {
        AddOther(p.y, p.u, p.v);
      }
    }
  }
}

void Trainer::AddBoxes(const Image& img, const std::vector<Box>& balls, float shrink, int margin) {
  std::vector<uint8_t> mask(static_cast<size_t>(img.width) * img.height, 0);
  for (const Box& b : balls) {
    const float cu = 0.5f * (b.u0 + b.u1), cv = 0.5f * (b.v0 + b.v1);
    const float ru = std::max(0.5f, 0.5f * (b.u1 - b.u0) * shrink);
    const float rv = std::max(0.5f, 0.5f * (b.v1 - b.v0) * shrink);
    for (int v = std::max(0, static_cast<int>(b.v0) - margin);
         v <= std::min(img.height - 1, static_cast<int>(b.v1) + margin); ++v) {
      for (int u = std::max(0, static_cast<int>(b.u0) - margin);
           u <= std::min(img.width - 1, static_cast<int>(b.u1) + margin); ++u) {
        const float du = (u - cu) / ru, dv = (v - cv) / rv;
        uint8_t& m = mask[static_cast<size_t>(v) * img.width + u];
        if (du * du + dv * dv <= 1.0f) {
          m = 1;
        } else if (m != 1) {
          m = 2;
        }
      }
    }
  }
  AddMask(img, mask);
}

int Trainer::Teach(const Image& img, int u0, int v0, ColorClass cls, float tolerance,
                   int max_pixels) {
  const YuyvImage view = img.view();
  if (!view.contains(u0, v0)) return 0;
  // Shade-normalised chroma: (U-128)/(Y+16), (V-128)/(Y+16) is unchanged by a brightness factor.
  const auto chroma = [&view](int u, int v, float& a, float& b) {
    const Yuv p = view.at(u, v);
    const float d = static_cast<float>(p.y) + 16.0f;
    a = (p.u - 128.0f) / d;
    b = (p.v - 128.0f) / d;
  };
  std::vector<uint8_t> seen(static_cast<size_t>(img.width) * img.height, 0);
  std::vector<std::pair<int, int>> stack{{u0, v0}};
  seen[static_cast<size_t>(v0) * img.width + u0] = 1;
  float ma = 0, mb = 0;
  chroma(u0, v0, ma, mb);
  double sa = 0, sb = 0;
  int n = 0;
  while (!stack.empty() && n < max_pixels) {
    const auto [u, v] = stack.back();
    stack.pop_back();
    float a, b;
    chroma(u, v, a, b);
    if (std::hypot(a - ma, b - mb) > tolerance) continue;
    const Yuv p = view.at(u, v);
    AddClass(cls, p.y, p.u, p.v);
    ++n;
    sa += a;
    sb += b;
    ma = static_cast<float>(sa / n);
    mb = static_cast<float>(sb / n);
    const int nu[4] = {u + 1, u - 1, u, u}, nv[4] = {v, v, v + 1, v - 1};
    for (int k = 0; k < 4; ++k) {
      if (!view.contains(nu[k], nv[k])) continue;
      uint8_t& s = seen[static_cast<size_t>(nv[k]) * img.width + nu[k]];
      if (!s) {
        s = 1;
        stack.push_back({nu[k], nv[k]});
      }
    }
  }
  return n;
}

namespace {
// Box blur of a Y4/U6/V6 cell grid: +-ry cells in Y, +-r in U and V.
std::vector<float> BlurCells(const std::vector<float>& in, int ry, int r) {
  constexpr int ny = 16, nu = 64, nv = 64;
  std::vector<float> a = in, b(in.size());
  auto pass = [&](int stride, int n, int rad) {
    for (uint32_t i = 0; i < ColorLut::kEntries; ++i) {
      const int k = static_cast<int>(i / stride) % n;
      float sum = 0;
      for (int d = -rad; d <= rad; ++d) {
        if (k + d >= 0 && k + d < n) sum += a[i + d * stride];
      }
      b[i] = sum;
    }
    a.swap(b);
  };
  pass(nu * nv, ny, ry);
  pass(nv, nu, r);
  pass(1, nv, r);
  return a;
}
}  // namespace

ColorLut Trainer::Build() const {
  ColorLut lut;
  const double bt = std::max(1.0, ball_total_), ot = std::max(1.0, other_total_);
  const std::vector<float> ball = opt_.smooth > 0 ? BlurCells(ball_, 1, opt_.smooth) : ball_;
  const std::vector<float> other = opt_.smooth > 0 ? BlurCells(other_, 1, opt_.smooth) : other_;
  for (uint32_t i = 0; i < ColorLut::kEntries; ++i) {
    uint8_t y, u, v;
    ColorLut::CellCenter(i, y, u, v);
    lut.Set(i, BackgroundClass(y, u, v));
    if (ball[i] >= opt_.min_ball_weight && ball[i] / bt > opt_.ratio * other[i] / ot) {
      lut.Set(i, ColorClass::kBall);
    }
  }
  if (opt_.gauss_d2 > 0 && sn_ > 10) {
    const double ma = sa_ / sn_, mb = sb_ / sn_;
    const double caa = saa_ / sn_ - ma * ma + 1e-5, cab = sab_ / sn_ - ma * mb,
                 cbb = sbb_ / sn_ - mb * mb + 1e-5;
    const double det = caa * cbb - cab * cab;
    double acc = 0;
    int y_lo = 0;
    for (; y_lo < 255 && acc + ball_y_hist_[y_lo] < 0.02 * sn_; ++y_lo) acc += ball_y_hist_[y_lo];
    y_lo = static_cast<int>(y_lo * 0.6);
    for (uint32_t i = 0; i < ColorLut::kEntries; ++i) {
      uint8_t y, u, v;
      ColorLut::CellCenter(i, y, u, v);
      if (y < y_lo || other_[i] / ot >= opt_.gauss_veto) continue;
      const double d = y + 16.0, a = (u - 128) / d - ma, b = (v - 128) / d - mb;
      const double d2 = (cbb * a * a - 2 * cab * a * b + caa * b * b) / det;
      if (d2 <= opt_.gauss_d2) lut.Set(i, ColorClass::kBall);
    }
  }
  for (int c = 0; c < kColorClassCount; ++c) {
    if (c == static_cast<int>(ColorClass::kBall)) continue;
    for (uint32_t i : taught_[c]) {
      if (lut.at(i) != ColorClass::kBall) lut.Set(i, static_cast<ColorClass>(c));
    }
  }
  return lut;
}

// ---------------------------------------------------------------------------------------------

void PrintRegions(const BallFinder& finder) {
  const auto regions = finder.regions().regions();
  for (size_t i = 0; i < regions.size(); ++i) {
    const Region& r = regions[i];
    if (r.hole) continue;
    std::printf(
        "     %c region (%.1f, %.1f) area %.0f hull roundness %.2f width ratio %.2f chain "
        "roundness %.2f bbox u %d..%d v %d..%d\n",
        static_cast<int>(i) == finder.chosen_region() ? '*' : ' ', r.cu_px, r.cv_px, r.area_px,
        r.hull_roundness, r.width_ratio, r.roundness, r.u_min, r.u_max, r.v_min, r.v_max);
  }
}

namespace {

// One camera's columns of a truth row; empty numeric fields mean "no ball there" (0).
bool ReadSimCamera(const cli::TruthCsv& csv, size_t i, const std::string& cam, SimTruth& t, int c,
                   std::string& error) {
  t.has[c] = !csv.Empty(i, "u_" + cam);
  const std::string& vis = csv.Text(i, "visible_" + cam);
  if (vis != "0" && vis != "1") {
    error = csv.Where(i) + ": column visible_" + cam + ": got '" + vis + "', expected 0 or 1";
    return false;
  }
  t.visible[c] = vis == "1";
  const std::pair<const char*, float*> cols[] = {
      {"cu_", &t.cu[c]},          {"cv_", &t.cv[c]},
      {"area_", &t.area[c]},      {"fullarea_", &t.fullarea[c]},
      {"fullcu_", &t.fullcu[c]},  {"fullcv_", &t.fullcv[c]},
      {"visfrac_", &t.visfrac[c]}};
  for (const auto& [prefix, dst] : cols) {
    double v = 0;
    if (!csv.Number(i, prefix + cam, v, /*allow_empty=*/true, error)) return false;
    *dst = static_cast<float>(v);
  }
  const std::string& bb = csv.Text(i, "bbox_" + cam);
  if (bb.empty()) return true;
  std::istringstream in(bb);
  std::string rest;
  for (float& b : t.bbox[c]) in >> b;
  if (!in || (in >> rest)) {
    error = csv.Where(i) + ": column bbox_" + cam + ": got '" + bb +
            "', expected four numbers 'u0 v0 u1 v1'";
    return false;
  }
  return true;
}

}  // namespace

bool LoadSimTruth(const std::string& dir, std::vector<SimTruth>& out, std::string& error) {
  std::vector<std::string> need = {"index"};
  for (const char* cam : {"omni", "persp"}) {
    for (const char* p : {"u_", "visible_", "cu_", "cv_", "area_", "fullarea_", "fullcu_",
                          "fullcv_", "visfrac_", "bbox_"}) {
      need.push_back(std::string(p) + cam);
    }
  }
  cli::TruthCsv csv;
  if (!csv.Load(dir + "/truth.csv", need, error)) return false;
  out.clear();
  for (size_t i = 0; i < csv.rows(); ++i) {
    SimTruth t;
    if (!csv.Integer(i, "index", INT64_MIN, INT64_MAX, t.index, error) ||
        !ReadSimCamera(csv, i, "omni", t, 0, error) ||
        !ReadSimCamera(csv, i, "persp", t, 1, error)) {
      return false;
    }
    out.push_back(t);
  }
  return true;
}

int AddSimSequence(Trainer& t, const std::string& dir, Camera cam, int every, int phase,
                   std::string& error) {
  host::Sequence seq;
  if (!host::LoadSequence(dir, seq, error)) return -1;
  std::vector<SimTruth> truth;
  if (!LoadSimTruth(dir, truth, error)) return -1;  // without it nothing would be ball
  const bool have_truth = true;
  std::map<int64_t, const SimTruth*> by_index;
  for (const auto& tr : truth) by_index[tr.index] = &tr;
  const int c = static_cast<int>(cam);
  int used = 0;
  for (const auto& e : seq.entries) {
    if (cli::InterruptSignal()) break;
    if (every > 1 && static_cast<int>(e.index % every) != phase) continue;
    const std::string& path = cam == Camera::kOmni ? e.omni_path : e.persp_path;
    if (path.empty()) continue;
    Image img;
    if (!LoadImage(path, img, error)) return -1;
    std::vector<uint8_t> mask(static_cast<size_t>(img.width) * img.height, 0);
    const SimTruth* tr = have_truth && by_index.count(e.index) ? by_index[e.index] : nullptr;
    if (tr != nullptr && tr->has[c] && tr->fullarea[c] > 0) {
      // Ignore a generous square around the ball; learn ball pixels only from unoccluded balls.
      const float r = std::sqrt(tr->fullarea[c] / 3.14159f);
      const float rin = r - 1.5f;
      const bool learn = tr->visfrac[c] >= 0.95f && rin >= 1.0f;
      for (int v = std::max(0, static_cast<int>(tr->fullcv[c] - r - 4));
           v <= std::min(img.height - 1, static_cast<int>(tr->fullcv[c] + r + 4)); ++v) {
        for (int u = std::max(0, static_cast<int>(tr->fullcu[c] - r - 4));
             u <= std::min(img.width - 1, static_cast<int>(tr->fullcu[c] + r + 4)); ++u) {
          const float d = std::hypot(u - tr->fullcu[c], v - tr->fullcv[c]);
          mask[static_cast<size_t>(v) * img.width + u] = (learn && d <= rin) ? 1 : 2;
        }
      }
    }
    t.AddMask(img, mask);
    ++used;
  }
  return used;
}

bool EvalSim(const std::string& dir, Camera cam, const ColorLut& lut, const FinderSetup& setup,
             int every, int phase, EvalCounts& out, std::string& error) {
  host::Sequence seq;
  if (!host::LoadSequence(dir, seq, error)) return false;
  std::vector<SimTruth> truth;
  if (!LoadSimTruth(dir, truth, error)) return false;
  std::map<int64_t, const SimTruth*> by_index;
  for (const auto& tr : truth) by_index[tr.index] = &tr;
  auto table = std::make_unique<ScanlineTable<kOmniScanPixels>>();
  const Status st = cam == Camera::kOmni
                        ? table->BuildOmni(setup.omni, kFrameWidth, kFrameHeight)
                        : table->BuildPersp(setup.persp, kFrameWidth, kFrameHeight);
  if (!st.ok()) {
    error = std::string("scanlines: ") + st.message();
    return false;
  }
  auto finder = std::make_unique<BallFinder>();
  if (!finder->Init(*table, setup.finder).ok()) {
    error = "BallFinder::Init failed";
    return false;
  }
  const int c = static_cast<int>(cam);
  bool have_pred = false;
  Prediction pred;
  for (const auto& e : seq.entries) {
    if (cli::InterruptSignal()) break;
    if (every > 1 && static_cast<int>(e.index % every) != phase) continue;
    const std::string& path = cam == Camera::kOmni ? e.omni_path : e.persp_path;
    if (path.empty()) continue;
    Image img;
    if (!LoadImage(path, img, error)) return false;
    BallDetection det;
    FrontEndStats stats;
    const Prediction* used_pred = (setup.track && have_pred) ? &pred : nullptr;
    const Status fs = finder->Find(img.view(), lut, used_pred, det, stats);
    if (!fs.ok()) {
      error = path + ": " + fs.message();
      return false;
    }
    if (!setup.annotate_dir.empty()) {
      char name[64];
      std::snprintf(name, sizeof(name), "/%s_%06lld.png", cam == Camera::kOmni ? "omni" : "persp",
                    static_cast<long long>(e.index));
      if (!AnnotateFrontEnd(img.view(), lut, *table, *finder, used_pred, det,
                            setup.annotate_dir + name, &error, 2)) {
        return false;
      }
    }
    ++out.frames;
    out.pixels_read_sum += stats.pixels_read;
    out.overflows += stats.overflows;
    have_pred = det.found;
    if (det.found) pred = Prediction{det.u_px, det.v_px, std::max(4.0f, det.radius_px)};
    const SimTruth* tr = by_index.count(e.index) ? by_index[e.index] : nullptr;
    if (setup.verbose) {
      std::printf(
          "  %s #%lld: det %d (%.2f, %.2f) r %.1f round %.2f conf %.2f cand %u | truth vis %d "
          "(%.2f, %.2f) area %.0f\n",
          cam == Camera::kOmni ? "omni" : "persp", static_cast<long long>(e.index), det.found,
          det.u_px, det.v_px, det.radius_px, det.roundness, det.confidence, stats.candidates,
          tr ? tr->visible[c] : 0, tr ? tr->cu[c] : 0.f, tr ? tr->cv[c] : 0.f,
          tr ? tr->area[c] : 0.f);
    }
    if (setup.dump_regions) PrintRegions(*finder);
    const bool ball =
        tr != nullptr && tr->visible[c] && 2.0f * std::sqrt(tr->fullarea[c] / 3.14159f) >= 4.0f;
    if (ball) {
      ++out.ball_frames;
      if (!det.found) {
        ++out.missed;
        continue;
      }
      const float err = std::hypot(det.u_px - tr->cu[c], det.v_px - tr->cv[c]);
      const float tol = std::max(3.0f, std::sqrt(tr->fullarea[c] / 3.14159f));
      if (err <= tol) {
        ++out.found_on_ball;
        out.within_1px += err <= 1.0f;
        out.err_sum_px += err;
        out.errors_px.push_back(err);
      } else {
        ++out.false_det;
      }
    } else if (det.found) {
      // A detection on an occluded (< 20 % visible) ball at its true place is not false.
      const bool on_hidden_ball = tr != nullptr && tr->has[c] &&
                                  std::hypot(det.u_px - tr->fullcu[c], det.v_px - tr->fullcv[c]) <=
                                      std::max(3.0f, std::sqrt(tr->fullarea[c] / 3.14159f));
      if (!on_hidden_ball) ++out.false_det;
    }
  }
  return true;
}

bool LoadBoxFile(const std::string& file, const std::string& image_dir, std::vector<BoxImage>& out,
                 std::string& error) {
  std::vector<cli::AnnotatedImage> images;
  if (!cli::LoadAnnotations(file, image_dir, images, error)) return false;
  out.clear();
  for (const cli::AnnotatedImage& im : images) {
    BoxImage bi{im.path, {}};
    for (const cli::AnnotatedBox& b : im.boxes) {
      if (b.class_id == 0) bi.balls.push_back({b.u0, b.v0, b.u1, b.v1});
    }
    out.push_back(bi);
  }
  return true;
}

bool EvalBoxes(const std::vector<BoxImage>& images, const ColorLut& lut, const FinderSetup& setup,
               BoxEvalCounts& out, std::string& error, bool verbose) {
  auto table = std::make_unique<ScanlineTable<65535>>();  // stills up to 1280x720
  auto finder = std::make_unique<BallFinder>();
  for (const BoxImage& bi : images) {
    Image img;
    if (!LoadImage(bi.path, img, error)) return false;
    const Status st = table->BuildPersp(setup.persp, img.width, img.height);
    if (!st.ok() || !finder->Init(*table, setup.finder).ok()) {
      error = bi.path + ": cannot build scanlines";
      return false;
    }
    BallDetection det;
    FrontEndStats stats;
    if (!finder->Find(img.view(), lut, nullptr, det, stats).ok()) {
      error = bi.path + ": Find failed";
      return false;
    }
    if (!setup.annotate_dir.empty()) {
      const std::string base = bi.path.substr(bi.path.find_last_of('/') + 1);
      if (!AnnotateFrontEnd(img.view(), lut, *table, *finder, nullptr, det,
                            setup.annotate_dir + "/" + base + ".png", &error, 1)) {
        return false;
      }
    }
    ++out.images;
    out.balls += static_cast<int>(bi.balls.size());
    out.images_with_ball += !bi.balls.empty();
    bool inside = false;
    for (const auto& b : bi.balls) {
      inside |= det.u_px >= b.u0 - 2 && det.u_px <= b.u1 + 2 && det.v_px >= b.v0 - 2 &&
                det.v_px <= b.v1 + 2;
    }
    if (det.found && inside) ++out.hit;
    if (det.found && !inside) ++out.false_det;
    if (!det.found && !bi.balls.empty()) ++out.missed;
    if (verbose) {
      // Pixel-level view of the table (full frame, host only): how much of the ball's inscribed
      // ellipse is ball-coloured, and how many ball-coloured pixels lie outside every box.
      int in_ball = 0, in_total = 0, outside = 0;
      const YuyvImage view = img.view();
      for (int v = 0; v < img.height; ++v) {
        for (int u = 0; u < img.width; ++u) {
          const Yuv p = view.at(u, v);
          const bool is_ball = lut.Classify(p.y, p.u, p.v) == ColorClass::kBall;
          bool in_box = false, in_ellipse = false;
          for (const auto& b : bi.balls) {
            const float cu = 0.5f * (b.u0 + b.u1), cv = 0.5f * (b.v0 + b.v1);
            const float du = (u - cu) / (0.5f * (b.u1 - b.u0) * 0.8f + 0.5f);
            const float dv = (v - cv) / (0.5f * (b.v1 - b.v0) * 0.8f + 0.5f);
            in_ellipse |= du * du + dv * dv <= 1.0f;
            in_box |= u >= b.u0 - 4 && u <= b.u1 + 4 && v >= b.v0 - 4 && v <= b.v1 + 4;
          }
          if (in_ellipse) {
            ++in_total;
            in_ball += is_ball;
          } else if (!in_box) {
            outside += is_ball;
          }
        }
      }
      std::printf(
          "  %s: ball px %.0f %% of box ellipse, %d outside boxes; seeds %u regions %u "
          "candidates %u overflows %u\n",
          bi.path.c_str(), in_total ? 100.0 * in_ball / in_total : 0.0, outside, stats.seeds,
          stats.regions, stats.candidates, stats.overflows);
      if (setup.dump_regions) PrintRegions(*finder);
      std::printf("  %s: balls %zu, %s (%.1f, %.1f) r=%.1f round=%.2f -> %s\n", bi.path.c_str(),
                  bi.balls.size(), det.found ? "found" : "none", det.u_px, det.v_px, det.radius_px,
                  det.roundness,
                  det.found ? (inside ? "hit" : "FALSE") : (bi.balls.empty() ? "ok" : "MISS"));
    }
  }
  return true;
}

}  // namespace bv::lut
