#include "tools/ballvision/lut_teach.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>

#include "core/color_lut/color_teach.h"
#include "core/detect/detect.h"
#include "core/scanline/scanline.h"
#include "hal/host/sequence.h"
#include "tools/ballvision/signals.h"

namespace bv::lut {
namespace {

constexpr float kRadToDeg = 57.2957795f;
constexpr float kGrowHueMarginDeg = 10.0f;  // the grow test is the start window widened by this
constexpr float kGrowChromaMin = 0.10f;     // ... and this relative chroma floor
constexpr int kBackgroundStride = 8;        // background: every 8th pixel of every 8th row
constexpr double kBackgroundSampleWeight = kBackgroundStride * kBackgroundStride;
constexpr float kAcquireHueTolDeg = 8.0f;  // the other camera's ball: mean hue this near

// The relaxed test the ball is grown with: the start model's hue window widened, low chroma floor.
struct GrowTest {
  float hue_lo, hue_hi;
  bool operator()(const Yuv& p) const {
    if (p.y < 12 || RelativeChroma(p) < kGrowChromaMin) return false;
    const float h = UnwrapNear(HueDeg(p), 0.5f * (hue_lo + hue_hi));
    return h >= hue_lo && h <= hue_hi;
  }
};

// Grows the ball from the found centre over the image, inside a disc of twice the found radius.
// Appends its pixels to `ball`, returns how many; `taken` marks them (for background sampling).
size_t GrowBall(const YuyvImage& img, const GrowTest& test, float cu, float cv, float radius,
                std::vector<Yuv>& ball, std::vector<uint8_t>& taken) {
  const float reach = 2.0f * radius + 3.0f;
  const auto inside = [&](int u, int v) {
    return img.contains(u, v) && std::hypot(u - cu, v - cv) <= reach;
  };
  std::vector<std::pair<int, int>> stack;
  const float seed_r = std::max(1.0f, 0.5f * radius);
  for (int v = static_cast<int>(cv - seed_r); v <= static_cast<int>(cv + seed_r) + 1; ++v) {
    for (int u = static_cast<int>(cu - seed_r); u <= static_cast<int>(cu + seed_r) + 1; ++u) {
      if (!inside(u, v) || std::hypot(u - cu, v - cv) > seed_r) continue;
      uint8_t& t = taken[static_cast<size_t>(v) * img.width + u];
      if (!t && test(img.at(u, v))) {
        t = 1;
        stack.push_back({u, v});
      }
    }
  }
  std::vector<std::pair<int, int>> region;
  while (!stack.empty()) {
    const auto [u, v] = stack.back();
    stack.pop_back();
    region.push_back({u, v});
    const int nu[4] = {u + 1, u - 1, u, u}, nv[4] = {v, v, v + 1, v - 1};
    for (int k = 0; k < 4; ++k) {
      if (!inside(nu[k], nv[k])) continue;
      uint8_t& t = taken[static_cast<size_t>(nv[k]) * img.width + nu[k]];
      if (!t && test(img.at(nu[k], nv[k]))) {
        t = 1;
        stack.push_back({nu[k], nv[k]});
      }
    }
  }
  // The outline's pixels mix the ball with what is around it (green, white): left out.
  size_t n = 0;
  for (const auto& [u, v] : region) {
    const auto in = [&](int a, int b) {
      return img.contains(a, b) && taken[static_cast<size_t>(b) * img.width + a];
    };
    if (in(u + 1, v) && in(u - 1, v) && in(u, v + 1) && in(u, v - 1)) {
      ball.push_back(img.at(u, v));
      ++n;
    }
  }
  return n;
}

struct Pass {
  const host::Sequence* seq;
  Camera cam;
  const ColorLut* lut;
  BallFinder* finder;
};

struct Found {
  int64_t index;
  float u, v, r;
};

// Tracks the ball through `order` (entry indices) starting from `pred` (may be null) and
// collects what it finds.
bool Track(const Pass& p, const std::vector<size_t>& order, const Prediction* start,
           float start_radius, std::vector<Found>& found, std::string& error) {
  Prediction pred;
  bool have = start != nullptr;
  float last_r = start_radius;  // 0: unknown
  if (have) pred = *start;
  for (size_t k : order) {
    if (cli::InterruptSignal()) return true;
    const host::SequenceEntry& e = p.seq->entries[k];
    const std::string& path = p.cam == Camera::kOmni ? e.omni_path : e.persp_path;
    if (path.empty()) continue;
    Image img;
    if (!LoadImage(path, img, error)) return false;
    BallDetection det;
    FrontEndStats stats;
    if (const Status st = p.finder->Find(img.view(), *p.lut, have ? &pred : nullptr, det, stats);
        !st.ok()) {
      error = path + ": " + st.message();
      return false;
    }
    if (!det.found) {
      have = false;
      continue;
    }
    // Conservative: a jump or a sudden change of size means the ball merged with, or was
    // swapped for, something else of its colour; the track ends there (a teach needs the ball
    // in fewer frames, not in wrong ones).
    if (have &&
        (std::hypot(det.u_px - pred.u_px, det.v_px - pred.v_px) > 2.0f * pred.sigma_px ||
         (last_r > 0 && (det.radius_px > 1.5f * last_r || det.radius_px < last_r / 1.5f)))) {
      return true;
    }
    have = true;
    last_r = det.radius_px;
    pred = Prediction{det.u_px, det.v_px, std::max(4.0f, det.radius_px)};
    found.push_back({e.index, det.u_px, det.v_px, det.radius_px});
  }
  return true;
}

}  // namespace

bool FitBallColorModel(const std::vector<Yuv>& ball, const BallColorModel& start,
                       BallColorModel& out, std::string& why) {
  auto stats = std::make_unique<BallColorStats>();
  for (const Yuv& p : ball) stats->Add(p);
  const Status st = stats->Fit(start, out);
  if (!st.ok()) why = st.message();
  return st.ok();
}

void NarrowAgainstBackground(const std::vector<Yuv>& ball, const std::vector<Yuv>& background,
                             double background_weight, BallColorModel& m) {
  auto stats = std::make_unique<BallColorStats>();
  for (const Yuv& p : ball) stats->Add(p);
  auto bg = std::make_unique<HueHistogram>();
  const BallColorTest test(m);
  for (const Yuv& p : background) bg->AddIfInModelIgnoringHue(test, p);
  NarrowHueWindow(*stats, *bg, static_cast<float>(background_weight), m);
}

namespace {

struct Collected {
  std::vector<Yuv> ball, background;
  int frames[2] = {0, 0};
  int64_t moved_px = 0;
};

// Circular mean hue of the chromatic pixels inside 0.6 of a candidate's radius.
float MeanHue(const YuyvImage& img, const BallDetection& d) {
  double sc = 0, ss = 0;
  const float r = 0.6f * d.radius_px;
  for (int v = static_cast<int>(d.v_px - r); v <= static_cast<int>(d.v_px + r); ++v) {
    for (int u = static_cast<int>(d.u_px - r); u <= static_cast<int>(d.u_px + r); ++u) {
      if (!img.contains(u, v) || std::hypot(u - d.u_px, v - d.v_px) > r) continue;
      const Yuv p = img.at(u, v);
      if (RelativeChroma(p) < BallColorStats::kHueMinChroma) continue;
      const double h = HueDeg(p) / kRadToDeg;
      sc += std::cos(h);
      ss += std::sin(h);
    }
  }
  return static_cast<float>(std::atan2(ss, sc)) * kRadToDeg;
}

// The scanline table and ball finder of one camera (heap: the table is large).
struct CameraFinder {
  std::unique_ptr<ScanlineTable<kOmniScanPixels>> table;
  std::unique_ptr<BallFinder> finder;

  bool Init(const FinderSetup& setup, Camera cam, std::string& error) {
    table = std::make_unique<ScanlineTable<kOmniScanPixels>>();
    const Status st = cam == Camera::kOmni
                          ? table->BuildOmni(setup.omni, kFrameWidth, kFrameHeight)
                          : table->BuildPersp(setup.persp, kFrameWidth, kFrameHeight);
    finder = std::make_unique<BallFinder>();
    if (!st.ok() || !finder->Init(*table, setup.finder).ok()) {
      error = "scanlines / finder for the " + std::string(cam == Camera::kOmni ? "omni" : "persp") +
              " camera";
      return false;
    }
    return true;
  }
};

// Entry indices of the frames --every selects.
std::vector<size_t> SelectFrames(const host::Sequence& seq, int every) {
  std::vector<size_t> order;
  for (size_t k = 0; k < seq.entries.size(); ++k) {
    if (every <= 1 || seq.entries[k].index % every == 0) order.push_back(k);
  }
  return order;
}

// The clicked camera: the ball at the click, tracked from there forwards and backwards.
bool TrackFromClick(const Pass& pass, const std::vector<size_t>& order, const TeachOptions& opt,
                    std::vector<Found>& found, std::string& error) {
  const host::Sequence& seq = *pass.seq;
  const auto at = std::find_if(order.begin(), order.end(),
                               [&](size_t k) { return seq.entries[k].index == opt.click_index; });
  if (at == order.end()) {
    error = "the click's frame " + std::to_string(opt.click_index) + " is not in " + seq.dir +
            (opt.every > 1 ? " (or not among the frames --every selects)" : "");
    return false;
  }
  const Prediction click{opt.click_u, opt.click_v, 6.0f};
  std::vector<Found> first;
  if (!Track(pass, {*at}, &click, 0.0f, first, error)) return false;
  if (first.empty() ||
      std::hypot(first[0].u - opt.click_u, first[0].v - opt.click_v) > first[0].r + 6.0f) {
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "no ball-coloured region at the click (%s frame %lld, pixel %.0f, %.0f): "
                  "the starting model's table finds nothing there",
                  pass.cam == Camera::kOmni ? "omni" : "persp",
                  static_cast<long long>(opt.click_index), opt.click_u, opt.click_v);
    error = buf;
    return false;
  }
  const Prediction from{first[0].u, first[0].v, std::max(4.0f, first[0].r)};
  std::vector<size_t> fwd(at, order.end()), back(order.begin(), at + 1);
  std::reverse(back.begin(), back.end());
  return Track(pass, fwd, &from, first[0].r, found, error) &&
         Track(pass, back, &from, first[0].r, found, error);
}

// The other camera of a click: start from the first frame with a candidate, at the one whose
// colour is nearest the clicked ball's (a red box beside an orange ball is as round and larger),
// within 8 deg.
bool TrackFromHue(const Pass& pass, const std::vector<size_t>& order, float target_hue,
                  std::vector<Found>& found, std::string& error) {
  for (size_t at = 0; at < order.size(); ++at) {
    const host::SequenceEntry& e = pass.seq->entries[order[at]];
    const std::string& path = pass.cam == Camera::kOmni ? e.omni_path : e.persp_path;
    if (path.empty()) continue;
    Image img;
    if (!LoadImage(path, img, error)) return false;
    BallDetection det;
    FrontEndStats stats;
    if (!pass.finder->Find(img.view(), *pass.lut, nullptr, det, stats).ok()) {
      error = "finder failed on " + path;
      return false;
    }
    BallDetection cand[8];
    const size_t n = pass.finder->Candidates(cand);
    float best = kAcquireHueTolDeg;
    const BallDetection* pick = nullptr;
    for (size_t i = 0; i < n; ++i) {
      const float d = std::fabs(UnwrapNear(MeanHue(img.view(), cand[i]), target_hue) - target_hue);
      if (d < best) {
        best = d;
        pick = &cand[i];
      }
    }
    if (pick == nullptr) continue;
    const Prediction from{pick->u_px, pick->v_px, std::max(4.0f, pick->radius_px)};
    const std::vector<size_t> rest(order.begin() + static_cast<ptrdiff_t>(at), order.end());
    return Track(pass, rest, &from, pick->radius_px, found, error);
  }
  return true;
}

// Grows the ball in every frame it was found in (`found` sorted by index, one per frame) and
// samples the rest of those frames as background.
bool GrowFound(const host::Sequence& seq, Camera cam, const GrowTest& grow,
               const std::vector<Found>& found, Collected& out, std::string& error) {
  const int c = static_cast<int>(cam);
  size_t k_found = 0;
  for (const host::SequenceEntry& e : seq.entries) {
    while (k_found < found.size() && found[k_found].index < e.index) ++k_found;
    if (k_found >= found.size() || found[k_found].index != e.index) continue;
    const Found& f = found[k_found];
    Image img;
    if (!LoadImage(c == 0 ? e.omni_path : e.persp_path, img, error)) return false;
    const YuyvImage view = img.view();
    std::vector<uint8_t> taken(static_cast<size_t>(img.width) * img.height, 0);
    // A ball grown to more than twice the found region's area has leaked into something of its
    // colour behind it (both found and grown are then unreliable): that frame is left out.
    std::vector<Yuv> grown;
    const size_t n = GrowBall(view, grow, f.u, f.v, f.r, grown, taken);
    if (n == 0 || static_cast<float>(n) > 2.0f * 3.14159f * f.r * f.r) continue;
    out.ball.insert(out.ball.end(), grown.begin(), grown.end());
    ++out.frames[c];
    const float keep_out = 3.0f * f.r + 6.0f;
    for (int v = 3; v < img.height; v += kBackgroundStride) {
      for (int u = (v / kBackgroundStride) % kBackgroundStride; u < img.width;
           u += kBackgroundStride) {
        if (std::hypot(u - f.u, v - f.v) > keep_out) out.background.push_back(view.at(u, v));
      }
    }
  }
  return true;
}

// One camera: track the ball with `model`'s table (from the click when it names this camera),
// grow it in every frame it was found in, sample the rest of those frames as background.
bool CollectCamera(const host::Sequence& seq, const FinderSetup& setup, const TeachOptions& opt,
                   const BallColorModel& model, const float* target_hue, Camera cam, Collected& out,
                   std::string& error) {
  static ColorLut lut;
  if (const Status st = BuildLut(model, lut); !st.ok()) {
    error = st.message();
    return false;
  }
  CameraFinder cf;
  if (!cf.Init(setup, cam, error)) return false;
  const std::vector<size_t> order = SelectFrames(seq, opt.every);
  const Pass pass{&seq, cam, &lut, cf.finder.get()};
  std::vector<Found> found;
  bool tracked = false;
  if (opt.click && opt.click_camera == cam) {
    tracked = TrackFromClick(pass, order, opt, found, error);
  } else if (target_hue != nullptr) {
    tracked = TrackFromHue(pass, order, *target_hue, found, error);
  } else {
    tracked = Track(pass, order, nullptr, 0.0f, found, error);
  }
  if (!tracked) return false;
  std::sort(found.begin(), found.end(),
            [](const Found& a, const Found& b) { return a.index < b.index; });
  found.erase(std::unique(found.begin(), found.end(),
                          [](const Found& a, const Found& b) { return a.index == b.index; }),
              found.end());
  for (const Found& f : found) {
    out.moved_px =
        std::max(out.moved_px,
                 static_cast<int64_t>(std::hypot(f.u - found.front().u, f.v - found.front().v)));
  }
  const GrowTest grow{model.hue_min_deg - kGrowHueMarginDeg, model.hue_max_deg + kGrowHueMarginDeg};
  return GrowFound(seq, cam, grow, found, out, error);
}

// The model fitted to `ball` (its statistics gathered once) and narrowed against `background`;
// `hue_mean` gets the ball pixels' circular mean hue.
bool FitAndNarrow(const std::vector<Yuv>& ball, const std::vector<Yuv>& background,
                  const BallColorModel& start, BallColorModel& model, float& hue_mean,
                  std::string& error) {
  auto stats = std::make_unique<BallColorStats>();
  for (const Yuv& p : ball) stats->Add(p);
  if (const Status st = stats->Fit(start, model); !st.ok()) {
    error = st.message();
    return false;
  }
  hue_mean = stats->hue_mean_deg();
  auto bg = std::make_unique<HueHistogram>();
  const BallColorTest test(model);
  for (const Yuv& p : background) bg->AddIfInModelIgnoringHue(test, p);
  NarrowHueWindow(*stats, *bg, static_cast<float>(kBackgroundSampleWeight), model);
  return true;
}

// The fitted model against the background: refused when it takes the field's or lines' pixels.
bool CheckAgainstField(size_t ball_pixels, const std::vector<Yuv>& background, TeachReport& out,
                       std::string& error) {
  out.ball_pixels = ball_pixels;
  out.background = background.size();
  FieldCheck check;
  const BallColorTest test(out.model);
  for (const Yuv& p : background) check.Add(test, p);
  out.field_taken = check.field_taken_fraction();
  out.background_taken = check.all ? static_cast<double>(check.all_taken) / check.all : 0.0;
  if (out.field_taken > kMaxFieldTaken) {
    char buf[160];
    std::snprintf(buf, sizeof buf,
                  "the taught colour would take %.2f %% of the field's and lines' pixels "
                  "(limit %.1f %%): refused",
                  100.0 * out.field_taken, 100.0 * kMaxFieldTaken);
    error = buf;
    return false;
  }
  return true;
}

}  // namespace

bool TeachSequence(const std::string& dir, const FinderSetup& setup, const TeachOptions& opt,
                   TeachReport& out, std::string& error) {
  host::Sequence seq;
  if (!host::LoadSequence(dir, seq, error)) return false;
  if (const Status st = ValidateBallColorModel(opt.start); !st.ok()) {
    error = st.message();
    return false;
  }
  out = TeachReport{};
  // Pass 1 learns from the clicked camera only (or both, without a click); pass 2 finds the
  // ball in every camera again with the narrower model of pass 1, which no longer takes the
  // red and orange things around it that the broad starting model does, and learns from all.
  BallColorModel model = opt.start;
  Collected got;
  float learnt_hue = 0;
  for (int pass = 0; pass < 2; ++pass) {
    got = Collected{};
    for (int c = 0; c < 2; ++c) {
      const bool use =
          opt.cameras[c] && (pass == 1 || !opt.click || static_cast<int>(opt.click_camera) == c);
      // Pass 2, the camera not clicked: acquired by the colour pass 1 learnt.
      const bool by_hue = pass == 1 && opt.click && static_cast<int>(opt.click_camera) != c;
      if (use && !CollectCamera(seq, setup, opt, model, by_hue ? &learnt_hue : nullptr,
                                static_cast<Camera>(c), got, error)) {
        return false;
      }
    }
    if (cli::InterruptSignal()) return true;
    if (got.frames[0] + got.frames[1] == 0) {
      error =
          "the ball was found in no frame of " + dir +
          (opt.click ? std::string() : std::string(" (give a click: --click INDEX:CAMERA:U,V)"));
      return false;
    }
    if (!FitAndNarrow(got.ball, got.background, opt.start, model, learnt_hue, error)) {
      return false;
    }
  }
  out.model = model;
  out.frames[0] = got.frames[0];
  out.frames[1] = got.frames[1];
  out.first_moves_px = got.moved_px;
  return CheckAgainstField(got.ball.size(), got.background, out, error);
}

}  // namespace bv::lut
