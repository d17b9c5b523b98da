#include "core/color_lut/color_model.h"

#include <cmath>

namespace bv {
namespace {

constexpr float kDegToRad = 3.14159265f / 180.0f;

// The model with its trigonometry done once, so a pixel costs multiplies and compares only.
struct Prepared {
  float lo_x, lo_y, hi_x, hi_y;  // unit vectors of the hue window's edges in (U, V)
  float cmin, cmin_bright, cmax;
  int bright_y, bright_y_end, y_min, y_max;

  explicit Prepared(const BallColorModel& m)
      : lo_x(std::cos(m.hue_min_deg * kDegToRad)),
        lo_y(std::sin(m.hue_min_deg * kDegToRad)),
        hi_x(std::cos(m.hue_max_deg * kDegToRad)),
        hi_y(std::sin(m.hue_max_deg * kDegToRad)),
        cmin(m.chroma_min),
        cmin_bright(m.chroma_min_bright),
        cmax(m.chroma_max),
        bright_y(m.bright_y),
        bright_y_end(m.bright_y_end),
        y_min(m.y_min),
        y_max(m.y_max) {}

  bool Contains(int y, int u, int v) const {
    if (y < y_min || y > y_max) return false;
    const float du = static_cast<float>(u - 128), dv = static_cast<float>(v - 128);
    // Inside the window (narrower than 180 degrees): left of its first edge, right of its last.
    if (lo_x * dv - lo_y * du < 0.0f || du * hi_y - dv * hi_x < 0.0f) return false;
    float floor = cmin;
    if (y >= bright_y_end) {
      floor = cmin_bright;
    } else if (y > bright_y) {
      floor = cmin + (cmin_bright - cmin) * static_cast<float>(y - bright_y) /
                         static_cast<float>(bright_y_end - bright_y);
    }
    const float c2 = du * du + dv * dv, fy = static_cast<float>(y);
    return c2 >= floor * floor * fy * fy && c2 <= cmax * cmax * fy * fy;
  }
};

bool Finite(float x) { return std::isfinite(x); }

}  // namespace

Status ValidateBallColorModel(const BallColorModel& m) {
  if (!Finite(m.hue_min_deg) || !Finite(m.hue_max_deg) || !Finite(m.chroma_min) ||
      !Finite(m.chroma_min_bright) || !Finite(m.chroma_max)) {
    return Status(StatusCode::kInvalidArgument, "colour model: a bound is not a finite number");
  }
  const float width = m.hue_max_deg - m.hue_min_deg;
  if (!(width > 0.0f && width <= 170.0f)) {
    return Status(StatusCode::kInvalidArgument,
                  "colour model: hue window must be 0 < max - min <= 170 deg");
  }
  if (!(m.chroma_min > 0.0f && m.chroma_min_bright > 0.0f && m.chroma_max <= 4.0f &&
        m.chroma_min < m.chroma_max && m.chroma_min_bright < m.chroma_max)) {
    return Status(StatusCode::kInvalidArgument,
                  "colour model: chroma bounds must be 0 < min < max <= 4");
  }
  if (m.bright_y >= m.bright_y_end) {
    return Status(StatusCode::kInvalidArgument,
                  "colour model: bright_y must be below bright_y_end");
  }
  if (m.y_min >= m.y_max) {
    return Status(StatusCode::kInvalidArgument, "colour model: y_min must be below y_max");
  }
  return Status::Ok();
}

bool InBallColorModel(const BallColorModel& m, uint8_t y, uint8_t u, uint8_t v) {
  return Prepared(m).Contains(y, u, v);
}

ColorClass BackgroundClass(uint8_t y, uint8_t u, uint8_t v) {
  const int du = u - 128, dv = v - 128;
  const int adu = du < 0 ? -du : du, adv = dv < 0 ? -dv : dv;
  const int sat = adu > adv ? adu : adv;
  if (y < 50 && sat < 24) return ColorClass::kObstacle;
  if (y >= 150 && sat < 20) return ColorClass::kLine;
  if (du < -4 && dv < -4 && y >= 20) return ColorClass::kField;  // green: U and V below grey
  if (sat < 14 && y < 80) return ColorClass::kObstacle;
  return ColorClass::kUnknown;
}

Status BuildLut(const BallColorModel& m, ColorLut& out) {
  BV_TRY(ValidateBallColorModel(m));
  const Prepared p(m);
  constexpr int kYStep = 1 << (8 - ColorLut::kYBits), kCStep = 1 << (8 - ColorLut::kUBits);
  static_assert(ColorLut::kUBits == ColorLut::kVBits);
  for (uint32_t i = 0; i < ColorLut::kEntries; ++i) {
    uint8_t yc, uc, vc;
    ColorLut::CellCenter(i, yc, uc, vc);
    const int y0 = yc - kYStep / 2, u0 = uc - kCStep / 2, v0 = vc - kCStep / 2;
    int votes = 0;
    for (int a = 0; a < 2; ++a) {
      for (int b = 0; b < 2; ++b) {
        for (int c = 0; c < 2; ++c) {
          votes += p.Contains(y0 + kYStep / 4 + a * kYStep / 2, u0 + kCStep / 4 + b * kCStep / 2,
                              v0 + kCStep / 4 + c * kCStep / 2);
        }
      }
    }
    out.Set(i, votes >= 4 ? ColorClass::kBall : BackgroundClass(yc, uc, vc));
  }
  return Status::Ok();
}

}  // namespace bv
