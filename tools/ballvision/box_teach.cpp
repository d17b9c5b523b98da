#include "tools/ballvision/box_teach.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/color_lut/color_model.h"
#include "core/color_lut/color_teach.h"
#include "tools/ballvision/lut_train.h"
#include "tools/ballvision/still_image.h"

namespace bv::cli {
namespace {

struct FloorSample {
  float v, r;
};

// Weighted least squares of r / d = k + c d on the samples below the horizon, d = v - v_h
// (relative residuals: a far ball's pixel counts as much as a near one's).
struct Fit {
  float k = 0, c = 0, cost = 3.4e38f, sd = 0;
};

Fit FitAt(const std::vector<FloorSample>& s, float vh, bool quadratic) {
  Fit best;
  std::vector<float> w(s.size(), 1.0f);
  for (int iter = 0; iter < 8; ++iter) {
    double sw = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (size_t i = 0; i < s.size(); ++i) {
      const double d = s[i].v - vh;
      if (d <= 1.0) continue;
      const double y = s[i].r / d;  // k + c d
      sw += w[i], sx += w[i] * d, sy += w[i] * y, sxx += w[i] * d * d, sxy += w[i] * d * y;
    }
    if (sw <= 0) return best;
    double k = sy / sw, c = 0;
    const double det = sw * sxx - sx * sx;
    if (quadratic && det > 1e-9 * sw * sxx) {
      c = (sw * sxy - sx * sy) / det;
      k = (sy - c * sx) / sw;
    }
    // Relative residuals; a sample above the horizon misses by its whole size.
    std::vector<float> res(s.size());
    for (size_t i = 0; i < s.size(); ++i) {
      const double d = s[i].v - vh;
      const double pred = d > 0 ? d * (k + c * d) : 0.0;
      res[i] = static_cast<float>((s[i].r - pred) / s[i].r);
    }
    std::vector<float> a(res.size());
    for (size_t i = 0; i < res.size(); ++i) a[i] = std::fabs(res[i]);
    std::nth_element(a.begin(), a.begin() + a.size() / 2, a.end());
    const float sd = std::max(1.4826f * a[a.size() / 2], 0.03f);
    float cost = 0;
    for (size_t i = 0; i < res.size(); ++i) {
      const float z = res[i] / (2.5f * sd);
      w[i] = std::fabs(z) < 1.0f ? (1.0f - z * z) * (1.0f - z * z) : 0.0f;  // Tukey
      cost += std::min(z * z, 1.0f);
    }
    best.k = static_cast<float>(k);
    best.c = static_cast<float>(c);
    best.sd = sd;
    best.cost = cost * sd;  // robust scale times the fraction explained
  }
  return best;
}

}  // namespace

bool LearnFloorProfile(const std::vector<AnnotatedImage>& images, int width, int height,
                       FloorBallProfile& out, std::string& note) {
  out = FloorBallProfile{};
  std::vector<FloorSample> s;
  for (const AnnotatedImage& im : images) {
    for (const AnnotatedBox& b : im.boxes) {
      const float w = b.u1 - b.u0, h = b.v1 - b.v0;
      if (b.class_id != 0 || std::min(w, h) < 0.8f * std::max(w, h) || std::max(w, h) < 4.0f ||
          b.u0 < 1.0f || b.v0 < 1.0f || b.u1 > width - 2.0f || b.v1 > height - 2.0f) {
        continue;
      }
      s.push_back({0.5f * (b.v0 + b.v1), 0.5f * std::max(w, h)});
    }
  }
  if (s.size() < 3) {
    note = "fewer than 3 whole balls in the boxes: no floor-ball profile";
    return false;
  }
  float v_lo = s[0].v, v_hi = s[0].v, r_max = 0;
  for (const FloorSample& x : s) {
    v_lo = std::min(v_lo, x.v), v_hi = std::max(v_hi, x.v), r_max = std::max(r_max, x.r);
  }
  if (v_hi - v_lo < 20.0f) {
    note = "the ball boxes span fewer than 20 rows: the horizon cannot be placed";
    return false;
  }
  const bool quadratic = s.size() >= 12 && v_hi - v_lo >= 150.0f;
  Fit best;
  float best_vh = 0;
  // The horizon lies above the highest floor ball; search a row grid there.
  for (float vh = v_lo - 4.0f * r_max - 200.0f; vh < v_lo; vh += 1.0f) {
    const Fit f = FitAt(s, vh, quadratic);
    if (f.k > 0.0f && f.cost < best.cost) {
      best = f;
      best_vh = vh;
    }
  }
  if (!(best.k > 0.0f)) {
    note = "the ball boxes do not grow towards the bottom of the image: no floor-ball profile";
    return false;
  }
  out.valid = true;
  out.width_px = static_cast<uint16_t>(width);
  out.height_px = static_cast<uint16_t>(height);
  out.horizon_v_px = best_vh;
  out.slope = best.k;
  out.curve = best.c;
  out.spread = best.sd;
  out.samples = static_cast<uint16_t>(std::min<size_t>(s.size(), 65535));
  return true;
}

bool TeachFromBoxes(const std::string& box_file, const std::vector<AnnotatedImage>& images,
                    const BoxTeachOptions& options, BoxTeach& out, std::string& error) {
  out = BoxTeach{};
  lut::TrainOptions opt;
  opt.ratio = options.ratio;
  opt.smooth = options.smooth;
  lut::Trainer trainer(opt);
  struct Loaded {
    lut::Image image;
    std::vector<lut::Trainer::Box> balls;
  };
  std::vector<Loaded> loaded;
  for (const AnnotatedImage& im : images) {
    Still still;
    if (!LoadStill(im.path, still, error)) return false;
    if (!CheckBoxesInside(box_file, im, still.width, still.height, error)) return false;
    if (out.width == 0) {
      out.width = still.width;
      out.height = still.height;
    } else if (still.width != out.width || still.height != out.height) {
      error = im.path + ": " + std::to_string(still.width) + "x" + std::to_string(still.height) +
              ", the images before it " + std::to_string(out.width) + "x" +
              std::to_string(out.height) + ": one teach is for one camera";
      return false;
    }
    std::vector<lut::Trainer::Box> balls;
    for (const AnnotatedBox& b : im.boxes) {
      if (b.class_id == 0) balls.push_back({b.u0, b.v0, b.u1, b.v1});
    }
    out.ball_images += !balls.empty();
    trainer.AddBoxes(still.image, balls);
    loaded.push_back({std::move(still.image), std::move(balls)});
  }
  if (out.ball_images == 0) {
    error = box_file + ": no ball box among the " + std::to_string(images.size()) +
            " images taught from";
    return false;
  }
  out.table = std::make_unique<ColorLut>(trainer.Build());
  out.ball_samples = trainer.ball_samples();
  out.other_samples = trainer.other_samples();
  for (uint32_t i = 0; i < ColorLut::kEntries; ++i) {
    out.ball_cells += out.table->at(i) == ColorClass::kBall;
  }
  if (out.ball_cells == 0) {
    error = "no colour of the ball boxes stands out from the rest of the images: no ball class";
    return false;
  }
  // The taught class against the images' background (every 8th pixel of every 8th row away from
  // the boxes): refused when it takes the field's or the lines' pixels.
  size_t field = 0, field_taken = 0, taken = 0;
  for (const Loaded& l : loaded) {
    const YuyvImage view = l.image.view();
    for (int v = 3; v < view.height; v += 8) {
      for (int u = 0; u < view.width; u += 8) {
        bool near = false;
        for (const auto& b : l.balls) {
          near |= u >= b.u0 - 4 && u <= b.u1 + 4 && v >= b.v0 - 4 && v <= b.v1 + 4;
        }
        if (near) continue;
        const Yuv p = view.at(u, v);
        const bool ball = out.table->Classify(p.y, p.u, p.v) == ColorClass::kBall;
        const ColorClass bg = BackgroundClass(p.y, p.u, p.v);
        ++out.background;
        taken += ball;
        if (bg == ColorClass::kField || bg == ColorClass::kLine) {
          ++field;
          field_taken += ball;
        }
      }
    }
  }
  out.field_taken = field ? static_cast<double>(field_taken) / static_cast<double>(field) : 0.0;
  out.background_taken =
      out.background ? static_cast<double>(taken) / static_cast<double>(out.background) : 0.0;
  if (out.field_taken > kMaxFieldTaken) {
    char buf[160];
    std::snprintf(buf, sizeof buf,
                  "the taught ball class would take %.2f %% of the field's and lines' pixels "
                  "(limit %.1f %%): refused",
                  100.0 * out.field_taken, 100.0 * kMaxFieldTaken);
    error = buf;
    return false;
  }
  LearnFloorProfile(images, out.width, out.height, out.profile, out.profile_note);
  return true;
}

}  // namespace bv::cli
