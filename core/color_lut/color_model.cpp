#include "core/color_lut/color_model.h"

#include <cmath>

namespace bv {
namespace {

constexpr float kDegToRad = 3.14159265f / 180.0f;

bool Finite(float x) { return std::isfinite(x); }

}  // namespace

BallColorTest::BallColorTest(const BallColorModel& m)
    : lo_x_(std::cos(m.hue_min_deg * kDegToRad)),
      lo_y_(std::sin(m.hue_min_deg * kDegToRad)),
      hi_x_(std::cos(m.hue_max_deg * kDegToRad)),
      hi_y_(std::sin(m.hue_max_deg * kDegToRad)),
      cmin_(m.chroma_min),
      cmin_bright_(m.chroma_min_bright),
      cmax_(m.chroma_max),
      bright_y_(m.bright_y),
      bright_y_end_(m.bright_y_end),
      y_min_(m.y_min),
      y_max_(m.y_max),
      abs_min2_(static_cast<float>(m.chroma_abs_min) * static_cast<float>(m.chroma_abs_min)) {}

float BallColorTest::ChromaFloor(int y) const {
  if (y >= bright_y_end_) return cmin_bright_;
  if (y <= bright_y_) return cmin_;
  return cmin_ + (cmin_bright_ - cmin_) * static_cast<float>(y - bright_y_) /
                     static_cast<float>(bright_y_end_ - bright_y_);
}

bool BallColorTest::ContainsIgnoringHue(int y, int u, int v) const {
  if (y < y_min_ || y > y_max_) return false;
  const float du = static_cast<float>(u - 128), dv = static_cast<float>(v - 128);
  const float c2 = du * du + dv * dv, fy = static_cast<float>(y), f = ChromaFloor(y);
  return c2 >= f * f * fy * fy && c2 >= abs_min2_ && c2 <= cmax_ * cmax_ * fy * fy;
}

bool BallColorTest::Contains(int y, int u, int v) const {
  return InWindow(static_cast<float>(u - 128), static_cast<float>(v - 128)) &&
         ContainsIgnoringHue(y, u, v);
}

const char* BallNameText(BallName b) {
  switch (b) {
    case BallName::kRed:
      return "red";
    case BallName::kOrange:
      return "orange";
    case BallName::kYellow:
      return "yellow";
  }
  return "?";
}

bool ParseBallName(const char* text, BallName& out) {
  for (int i = 0; i < kBallNameCount; ++i) {
    const auto b = static_cast<BallName>(i);
    const char* name = BallNameText(b);
    int k = 0;
    while (name[k] != 0 && text[k] == name[k]) ++k;
    if (name[k] == 0 && text[k] == 0) {
      out = b;
      return true;
    }
  }
  return false;
}

BallColorModel BuiltInBallModel(BallName b) {
  BallColorModel m;
  switch (b) {
    case BallName::kRed:
      break;
    case BallName::kOrange:
      m.hue_min_deg = 117.0f;
      m.hue_max_deg = 162.0f;
      break;
    case BallName::kYellow:
      // Dark grey reads yellowish on many sensors (U a little below grey): the luma and absolute
      // chroma floors keep a dark hall's ceiling out (README: the grid it was chosen from).
      m.hue_min_deg = 140.0f;
      m.hue_max_deg = 200.0f;
      m.chroma_min = 0.16f;
      m.chroma_min_bright = 0.10f;
      m.y_min = 64;
      m.chroma_abs_min = 14;
      break;
  }
  return m;
}

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
  return BallColorTest(m).Contains(y, u, v);
}

ColorClass BackgroundClass(uint8_t y, uint8_t u, uint8_t v) {
  const int du = u - 128, dv = v - 128;
  const int adu = du < 0 ? -du : du, adv = dv < 0 ? -dv : dv;
  const int sat = adu > adv ? adu : adv;
  if (y >= 150 && sat < 20) return ColorClass::kLine;
  // Green before dark: a carpet in a robot's or the sun's shadow is dark but keeps its hue (U and
  // V both below grey); a black robot has none.
  if (du < -4 && dv < -4 && y >= 20) return ColorClass::kField;
  if (y < 50 && sat < 24) return ColorClass::kObstacle;
  if (sat < 14 && y < 80) return ColorClass::kObstacle;
  return ColorClass::kUnknown;
}

namespace {
// fn(index, ball) for every cell with U index in [u_first, u_end): a cell is ball when at least
// half of 8 colours spread over it are in the model, so the table's boundary follows the model's,
// not the cell centres'. With `before` (the model the cells were built from), the chroma columns
// that neither model can make ball in any luma are skipped: no cell there changes. The models
// must be valid.
template <typename Fn>
void ForEachCellVote(const BallColorModel& m, const BallColorModel* before, int u_first, int u_end,
                     Fn&& fn) {
  const BallColorTest p(m);
  const BallColorTest q(before != nullptr ? *before : m);
  constexpr int kYCells = 1 << ColorLut::kYBits, kCCells = 1 << ColorLut::kUBits;
  constexpr int kYStep = 1 << (8 - ColorLut::kYBits), kCStep = 1 << (8 - ColorLut::kUBits);
  static_assert(ColorLut::kUBits == ColorLut::kVBits);
  // Two Y samples per cell; their chroma bounds (squared, times Y^2) once for the whole table.
  float lo2[2 * kYCells], hi2[2 * kYCells];
  for (int k = 0; k < 2 * kYCells; ++k) {
    const int y = kYStep / 4 + k * kYStep / 2;
    const float f = p.ChromaFloor(y), fy = static_cast<float>(y);
    const bool in_range = y >= m.y_min && y <= m.y_max;
    const float abs2 = static_cast<float>(m.chroma_abs_min) * static_cast<float>(m.chroma_abs_min);
    lo2[k] = in_range ? (f * f * fy * fy > abs2 ? f * f * fy * fy : abs2) : 1e30f;
    hi2[k] = m.chroma_max * m.chroma_max * fy * fy;
  }
  for (int cu = u_first; cu < u_end; ++cu) {
    for (int cv = 0; cv < kCCells; ++cv) {
      // The cell's 4 chroma samples: in the hue window or not, and their squared chroma.
      float c2[4];
      bool hue_in[4];
      int any = 0, any_before = 0;
      for (int k = 0; k < 4; ++k) {
        const float du = static_cast<float>(cu * kCStep + kCStep / 4 + (k >> 1) * kCStep / 2 - 128);
        const float dv = static_cast<float>(cv * kCStep + kCStep / 4 + (k & 1) * kCStep / 2 - 128);
        hue_in[k] = p.InWindow(du, dv);
        c2[k] = du * du + dv * dv;
        any += hue_in[k];
        if (before != nullptr) any_before += q.InWindow(du, dv);
      }
      // At least 4 of 8 votes needs 2 of the 4 chroma samples in the window (below).
      if (before != nullptr && any < 2 && any_before < 2) continue;
      for (int cy = 0; cy < kYCells; ++cy) {
        const uint32_t index = static_cast<uint32_t>(cy) << (ColorLut::kUBits + ColorLut::kVBits) |
                               static_cast<uint32_t>(cu) << ColorLut::kVBits |
                               static_cast<uint32_t>(cv);
        int votes = 0;
        if (any >= 2) {
          for (int a = 0; a < 2; ++a) {
            const float lo = lo2[2 * cy + a], hi = hi2[2 * cy + a];
            for (int k = 0; k < 4; ++k) votes += hue_in[k] && c2[k] >= lo && c2[k] <= hi;
          }
        }
        fn(index, votes >= 4);
      }
    }
  }
}

ColorClass BackgroundClassOf(uint32_t index) {
  uint8_t yc, uc, vc;
  ColorLut::CellCenter(index, yc, uc, vc);
  return BackgroundClass(yc, uc, vc);
}
}  // namespace

Status BuildLut(const BallColorModel& m, ColorLut& out) {
  BV_TRY(ValidateBallColorModel(m));
  ForEachCellVote(m, nullptr, 0, 1 << ColorLut::kUBits, [&out](uint32_t index, bool ball) {
    out.Set(index, ball ? ColorClass::kBall : BackgroundClassOf(index));
  });
  return Status::Ok();
}

Status UpdateBallRows(const BallColorModel& from, const BallColorModel& m, ColorLut& table,
                      int u_first, int u_end, ChromaBox& ball_box) {
  BV_TRY(ValidateBallColorModel(from));
  BV_TRY(ValidateBallColorModel(m));
  if (u_first < 0 || u_end > (1 << ColorLut::kUBits) || u_first > u_end) {
    return Status(StatusCode::kInvalidArgument, "colour model: U rows outside the table");
  }
  constexpr uint32_t kCMask = (1u << ColorLut::kUBits) - 1;
  uint32_t umin = kCMask + 1, umax = 0, vmin = kCMask + 1, vmax = 0;
  ForEachCellVote(m, &from, u_first, u_end, [&](uint32_t index, bool ball) {
    if (ball) {
      table.Set(index, ColorClass::kBall);
      const uint32_t uc = (index >> ColorLut::kVBits) & kCMask, vc = index & kCMask;
      umin = uc < umin ? uc : umin;
      umax = uc > umax ? uc : umax;
      vmin = vc < vmin ? vc : vmin;
      vmax = vc > vmax ? vc : vmax;
    } else if (table.at(index) == ColorClass::kBall) {
      table.Set(index, BackgroundClassOf(index));
    }
  });
  ball_box = ChromaBox{};
  if (umin > umax) {
    ball_box.empty = true;
    return Status::Ok();
  }
  constexpr int kShift = 8 - ColorLut::kUBits;  // a cell covers 2^kShift chroma values
  ball_box.u_min = static_cast<uint8_t>(umin << kShift);
  ball_box.u_max = static_cast<uint8_t>(((umax + 1) << kShift) - 1);
  ball_box.v_min = static_cast<uint8_t>(vmin << kShift);
  ball_box.v_max = static_cast<uint8_t>(((vmax + 1) << kShift) - 1);
  return Status::Ok();
}

}  // namespace bv
