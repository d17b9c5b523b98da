#include "tools/ballvision/box_teach.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/ball_check/ball_check.h"
#include "core/color_lut/color_model.h"
#include "core/color_lut/color_teach.h"
#include "tools/ballvision/lut_train.h"
#include "tools/ballvision/still_image.h"

namespace bv::cli {
namespace {

struct FloorSample {
  float v, r;
};

// A level pinhole at height h sees k = R / (h - R) (core/ball_check/floor_profile.h), whatever
// its pitch to first order. An MSL robot is at most 0.8 m tall: a fit beyond these heights has let
// the quadratic term take the slope (a set whose balls lie in a band put the camera 3-19 m up,
// and every candidate's height with it), so k is held to them.
constexpr double kBallRadiusM = BallGeometryConfig{}.ball_radius_m;  // the place check's ball
constexpr double kCameraMinM = 0.2, kCameraMaxM = 1.2;
constexpr double kSlopeMin = kBallRadiusM / (kCameraMaxM - kBallRadiusM);
constexpr double kSlopeMax = kBallRadiusM / (kCameraMinM - kBallRadiusM);

// Weighted least squares of r / d = k + c d on the samples below the horizon, d = v - v_h
// (relative residuals: a far ball's pixel counts as much as a near one's), k within
// [kSlopeMin, kSlopeMax] (at a bound, c alone is fitted).
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
    const bool curved = quadratic && det > 1e-9 * sw * sxx;
    if (curved) {
      c = (sw * sxy - sx * sy) / det;
      k = (sy - c * sx) / sw;
    }
    if (k < kSlopeMin || k > kSlopeMax) {
      k = std::clamp(k, kSlopeMin, kSlopeMax);
      c = curved ? (sxy - k * sx) / sxx : 0.0;
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
  // The horizon lies above the floor balls; search a row grid there. Not only above the highest
  // box: that may be a ball held up or on a robot (an outlier of the fit), and a horizon forced
  // above it leaves only the curve to hold the floor balls. The grid runs down to the upper
  // quartile's row; boxes above the horizon count as misses.
  std::vector<float> rows(s.size());
  for (size_t i = 0; i < s.size(); ++i) rows[i] = s[i].v;
  std::nth_element(rows.begin(), rows.begin() + rows.size() / 4, rows.end());
  const float vh_end = rows[rows.size() / 4];
  for (float vh = v_lo - 4.0f * r_max - 200.0f; vh < vh_end; vh += 1.0f) {
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

namespace {

constexpr double kMinBallCoverage = 0.25;

struct Loaded {
  lut::Image image;
  std::vector<lut::Trainer::Box> balls;
};

// Loads every image (one size), checks its boxes and adds them to the trainer.
bool LoadAndAdd(const std::string& box_file, const std::vector<AnnotatedImage>& images,
                lut::Trainer& trainer, std::vector<Loaded>& loaded, BoxTeach& out,
                std::string& error) {
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
  return true;
}

// Per ball cell: the field- and line-class background samples it takes (every 8th pixel of every
// 8th row away from the boxes) and the boxes' ball pixels it holds.
struct CellCounts {
  std::vector<uint32_t> field_in = std::vector<uint32_t>(ColorLut::kEntries, 0);
  std::vector<uint32_t> ball_in = std::vector<uint32_t>(ColorLut::kEntries, 0);
  size_t field = 0, taken = 0, ball_pixels = 0;
  size_t ball_taken = 0;  // box pixels now ball
};

CellCounts CountCells(const std::vector<Loaded>& loaded, const ColorLut& table,
                      size_t& background) {
  CellCounts c;
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
        const uint32_t cell = ColorLut::Index(p.y, p.u, p.v);
        const bool ball = table.at(cell) == ColorClass::kBall;
        const ColorClass bg = BackgroundClass(p.y, p.u, p.v);
        ++background;
        c.taken += ball;
        if (bg == ColorClass::kField || bg == ColorClass::kLine) {
          ++c.field;
          if (ball) ++c.field_in[cell];
        }
      }
    }
    for (const auto& b : l.balls) {
      const float cu = 0.5f * (b.u0 + b.u1), cv = 0.5f * (b.v0 + b.v1);
      const float ru = std::max(0.4f * (b.u1 - b.u0), 0.5f);
      const float rv = std::max(0.4f * (b.v1 - b.v0), 0.5f);
      const int v0 = std::max(0, static_cast<int>(cv - rv));
      const int v1 = std::min(view.height - 1, static_cast<int>(cv + rv));
      const int u0 = std::max(0, static_cast<int>(cu - ru));
      const int u1 = std::min(view.width - 1, static_cast<int>(cu + ru));
      for (int v = v0; v <= v1; ++v) {
        for (int u = u0; u <= u1; ++u) {
          const float du = (u - cu) / ru, dv = (v - cv) / rv;
          if (du * du + dv * dv > 1.0f) continue;
          const Yuv p = view.at(u, v);
          const uint32_t cell = ColorLut::Index(p.y, p.u, p.v);
          ++c.ball_pixels;
          if (table.at(cell) != ColorClass::kBall) continue;
          ++c.ball_in[cell];
          ++c.ball_taken;
        }
      }
    }
  }
  return c;
}

// A few images do not show enough of the carpet to outweigh a small ball box's edge: the ball
// cells that hold the most field for the least ball are given back to the fixed rule until the
// class takes under half the limit of the field's and lines' samples.
void KeepOffTheField(const std::vector<Loaded>& loaded, BoxTeach& out) {
  CellCounts c = CountCells(loaded, *out.table, out.background);
  out.ball_coverage =
      c.ball_pixels ? static_cast<double>(c.ball_taken) / static_cast<double>(c.ball_pixels) : 0.0;
  size_t field_taken = 0;
  for (uint32_t n : c.field_in) field_taken += n;
  const double allowed = 0.5 * kMaxFieldTaken * static_cast<double>(c.field);
  if (static_cast<double>(field_taken) > allowed) {
    std::vector<uint32_t> cells;
    for (uint32_t i = 0; i < ColorLut::kEntries; ++i) {
      if (c.field_in[i] > 0) cells.push_back(i);
    }
    std::sort(cells.begin(), cells.end(), [&](uint32_t x, uint32_t y) {
      return static_cast<double>(c.field_in[x]) * (c.ball_in[y] + 1) >
             static_cast<double>(c.field_in[y]) * (c.ball_in[x] + 1);
    });
    size_t lost = 0;
    for (uint32_t cell : cells) {
      if (static_cast<double>(field_taken) <= allowed) break;
      uint8_t y, u, v;
      ColorLut::CellCenter(cell, y, u, v);
      out.table->Set(cell, BackgroundClass(y, u, v));
      field_taken -= c.field_in[cell];
      c.taken -= c.field_in[cell];
      lost += c.ball_in[cell];
      --out.ball_cells;
      ++out.cells_given_back;
    }
    out.ball_pixels_given_back =
        c.ball_pixels ? static_cast<double>(lost) / static_cast<double>(c.ball_pixels) : 0.0;
  }
  out.field_taken = c.field ? static_cast<double>(field_taken) / static_cast<double>(c.field) : 0.0;
  out.background_taken =
      out.background ? static_cast<double>(c.taken) / static_cast<double>(out.background) : 0.0;
}

}  // namespace

// A few boxes (a teach from five images) leave the ball's colours sparse: holes in the class
// that break the ball into pieces the shape test refuses.
int TeachBlur(const BoxTeachOptions& options, double ball_samples) {
  const double few = std::max(1.0, options.reference_ball_samples / std::max(ball_samples, 1.0));
  return std::min(options.smooth + 2,
                  static_cast<int>(std::lround(options.smooth * std::pow(few, 1.0 / 6.0))));
}

bool TeachFromBoxes(const std::string& box_file, const std::vector<AnnotatedImage>& images,
                    const BoxTeachOptions& options, BoxTeach& out, std::string& error) {
  out = BoxTeach{};
  lut::TrainOptions opt;
  opt.ratio = options.ratio;
  opt.smooth = options.smooth;
  lut::Trainer trainer(opt);
  std::vector<Loaded> loaded;
  if (!LoadAndAdd(box_file, images, trainer, loaded, out, error)) return false;
  out.smooth = TeachBlur(options, trainer.ball_samples());
  trainer.SetSmooth(out.smooth);
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
  KeepOffTheField(loaded, out);
  // Refused when the class holds few of the boxes' own pixels (boxes drawn on the carpet: only
  // its rarest shades stand out from the rest of the field), or when keeping off the field costs
  // a quarter of the ball's pixels: the boxes' colours are the field's.
  if (out.ball_coverage < kMinBallCoverage) {
    char buf[220];
    std::snprintf(buf, sizeof buf,
                  "the taught ball class holds %.0f %% of the ball boxes' pixels (under %.0f %%): "
                  "their colours are the field's or the lines': refused",
                  100.0 * out.ball_coverage, 100.0 * kMinBallCoverage);
    error = buf;
    return false;
  }
  if (out.ball_pixels_given_back > 0.25 || out.ball_cells <= 0) {
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "the ball boxes' colours are the field's or the lines': keeping the ball class "
                  "off them would cost %.0f %% of the ball's pixels: refused",
                  100.0 * out.ball_pixels_given_back);
    error = buf;
    return false;
  }
  LearnFloorProfile(images, out.width, out.height, out.profile, out.profile_note);
  return true;
}

}  // namespace bv::cli
