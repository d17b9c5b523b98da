#include "core/field/field_model.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace bv {
namespace {

constexpr float kPi = 3.14159265358979f;

bool Positive(float v) { return std::isfinite(v) && v > 0.0f; }
bool NonNegative(float v) { return std::isfinite(v) && v >= 0.0f; }

}  // namespace

Status ValidateFieldConfig(const FieldConfig& f) {
  const auto bad = [](const char* what) { return Status(StatusCode::kInvalidArgument, what); };
  if (!Positive(f.length_m) || f.length_m > 40.0f) {
    return bad("field.length_m: not finite or outside (0, 40] m");
  }
  if (!Positive(f.width_m) || f.width_m > 30.0f) {
    return bad("field.width_m: not finite or outside (0, 30] m");
  }
  if (!Positive(f.line_width_m) || f.line_width_m > 0.5f) {
    return bad("field.line_width_m: not finite or outside (0, 0.5] m");
  }
  if (!NonNegative(f.center_circle_radius_m) ||
      2.0f * f.center_circle_radius_m > std::min(f.length_m, f.width_m)) {
    return bad("field.center_circle_radius_m: negative or the circle leaves the field");
  }
  if (!Positive(f.penalty_area_depth_m) || f.penalty_area_depth_m >= 0.5f * f.length_m) {
    return bad("field.penalty_area_depth_m: not positive or deeper than half the field");
  }
  if (!Positive(f.penalty_area_width_m) || f.penalty_area_width_m > f.width_m) {
    return bad("field.penalty_area_width_m: not positive or wider than the field");
  }
  if (!Positive(f.goal_area_depth_m) || f.goal_area_depth_m > f.penalty_area_depth_m) {
    return bad("field.goal_area_depth_m: not positive or deeper than the penalty area");
  }
  if (!Positive(f.goal_area_width_m) || f.goal_area_width_m > f.penalty_area_width_m) {
    return bad("field.goal_area_width_m: not positive or wider than the penalty area");
  }
  if (!NonNegative(f.penalty_mark_distance_m) || f.penalty_mark_distance_m >= 0.5f * f.length_m) {
    return bad("field.penalty_mark_distance_m: negative or beyond the halfway line");
  }
  if (!NonNegative(f.corner_arc_radius_m) ||
      f.corner_arc_radius_m > 0.5f * std::min(f.length_m, f.width_m)) {
    return bad("field.corner_arc_radius_m: negative or larger than half the field");
  }
  if (!Positive(f.goal_width_m) || f.goal_width_m > f.width_m) {
    return bad("field.goal_width_m: not positive or wider than the field");
  }
  if (!Positive(f.goal_height_m) || f.goal_height_m > 3.0f) {
    return bad("field.goal_height_m: not finite or outside (0, 3] m");
  }
  if (!Positive(f.goal_depth_m) || f.goal_depth_m > 3.0f) {
    return bad("field.goal_depth_m: not finite or outside (0, 3] m");
  }
  if (!NonNegative(f.border_m) || f.border_m > 5.0f) {
    return bad("field.border_m: not finite or outside [0, 5] m");
  }
  if (!NonNegative(f.margin_m) || f.margin_m > 2.0f) {
    return bad("field.margin_m: not finite or outside [0, 2] m");
  }
  return Status::Ok();
}

// Segments are axis-parallel (every line of the field is): stored as the box (a, b) - (c, d) with
// a <= c, b <= d, the nearest point is a clamp of each coordinate: no projection, no division.
void FieldModel::Add(uint8_t kind, float a, float b, float c, float d) {
  if (kind == 0) {
    if (a > c) std::swap(a, c);
    if (b > d) std::swap(b, d);
  }
  if (count_ < kMaxPrimitives) prims_[count_++] = Primitive{kind, a, b, c, d};
}

Status FieldModel::Init(const FieldConfig& f) {
  ready_ = false;
  count_ = 0;
  BV_TRY(ValidateFieldConfig(f));
  config_ = f;
  const float hl = 0.5f * f.length_m, hw = 0.5f * f.width_m;
  // Lines are part of the areas they bound (the dimensions are to their outer edges, as the rule
  // book and the renderer have them): each centre lies half a line width inside its area. Only
  // the halfway line and the marks are centred on their nominal place.
  const float h = 0.5f * f.line_width_m;
  // The quadrant x >= 0, y >= 0; the other three are its mirror images.
  Add(0, 0.0f, hw - h, hl - h, hw - h);  // touchline
  Add(0, hl - h, 0.0f, hl - h, hw - h);  // goal line
  Add(0, 0.0f, 0.0f, 0.0f, hw - h);      // halfway line
  if (f.center_circle_radius_m > 0.0f)
    Add(1, 0.0f, 0.0f, std::max(0.0f, f.center_circle_radius_m - h), 0.0f);
  const float px = hl - f.penalty_area_depth_m + h, py = 0.5f * f.penalty_area_width_m - h;
  Add(0, px, 0.0f, px, py);
  Add(0, px, py, hl - h, py);
  const float gx = hl - f.goal_area_depth_m + h, gy = 0.5f * f.goal_area_width_m - h;
  Add(0, gx, 0.0f, gx, gy);
  Add(0, gx, gy, hl - h, gy);
  if (f.corner_arc_radius_m > 0.0f) Add(1, hl, hw, std::max(0.0f, f.corner_arc_radius_m - h), kPi);
  if (f.penalty_mark_distance_m > 0.0f) Add(2, hl - f.penalty_mark_distance_m, 0.0f, 0.0f, 0.0f);

  const float ex = hl + f.border_m + 0.5f, ey = hw + f.border_m + 0.5f;
  cell_m_ = std::max({0.1f, ex / kMaxCellsX, ey / kMaxCellsY});
  inv_cell_ = 1.0f / cell_m_;
  cells_x_ = std::min(kMaxCellsX, static_cast<int>(std::ceil(ex / cell_m_)));
  cells_y_ = std::min(kMaxCellsY, static_cast<int>(std::ceil(ey / cell_m_)));
  for (int j = 0; j < cells_y_; ++j) {
    for (int i = 0; i < cells_x_; ++i) {
      const float x = (static_cast<float>(i) + 0.5f) * cell_m_;
      const float y = (static_cast<float>(j) + 0.5f) * cell_m_;
      float best = 1e9f, gx0, gy0;
      for (int k = 0; k < count_; ++k) {
        const float d = PrimitiveDistance(prims_[k], x, y, gx0, gy0);
        if (d < best) {
          best = d;
          uint8_t& cell = nearest_[j][i >> 1];
          const unsigned shift = (i & 1) * 4u;
          cell = static_cast<uint8_t>((cell & ~(0x0Fu << shift)) |
                                      (static_cast<unsigned>(k) << shift));
        }
      }
    }
  }
  ready_ = true;
  return Status::Ok();
}

float FieldModel::PrimitiveDistance(const Primitive& p, float x, float y, float& gx,
                                    float& gy) const {
  float qx = p.a, qy = p.b;  // nearest point of the primitive
  if (p.kind == 0) {
    qx = std::min(std::max(x, p.a), p.c);
    qy = std::min(std::max(y, p.b), p.d);
  } else if (p.kind == 1) {
    // Quarter arcs start at an axis (angle d = 0 or pi): the point is within the arc's angle
    // when both offsets have the quarter's signs; else the nearer end. No trigonometry.
    const float sx = p.d > 1.0f ? -1.0f : 1.0f;  // quadrant signs of the arc
    const float rx = x - p.a, ry = y - p.b;
    if (rx * sx >= 0.0f && ry * sx >= 0.0f) {
      const float len = std::sqrt(rx * rx + ry * ry);
      qx = len > 1e-6f ? p.a + p.c * rx / len : p.a + p.c * sx;
      qy = len > 1e-6f ? p.b + p.c * ry / len : p.b;
    } else {
      const float e0x = p.a + sx * p.c, e0y = p.b, e1x = p.a, e1y = p.b + sx * p.c;
      const bool first = (x - e0x) * (x - e0x) + (y - e0y) * (y - e0y) <=
                         (x - e1x) * (x - e1x) + (y - e1y) * (y - e1y);
      qx = first ? e0x : e1x;
      qy = first ? e0y : e1y;
    }
  }
  const float ex = x - qx, ey = y - qy;
  const float d = std::sqrt(ex * ex + ey * ey);
  if (d > 1e-6f) {
    gx = ex / d;
    gy = ey / d;
  } else {
    gx = gy = 0.0f;
  }
  return d;
}

float FieldModel::Distance(float x_m, float y_m, float& gx, float& gy) const {
  const float sx = x_m < 0.0f ? -1.0f : 1.0f, sy = y_m < 0.0f ? -1.0f : 1.0f;
  const float ax = std::fabs(x_m), ay = std::fabs(y_m);
  if (!(ax < 1e3f) || !(ay < 1e3f)) {  // NaN or absurd: far from every line, no pull
    gx = gy = 0.0f;
    return 1e3f;
  }
  int i = static_cast<int>(ax / cell_m_), j = static_cast<int>(ay / cell_m_);
  i = std::clamp(i, 0, cells_x_ - 1);
  j = std::clamp(j, 0, cells_y_ - 1);
  const int k = (nearest_[j][i >> 1] >> ((i & 1) * 4)) & 0x0F;
  const float d = PrimitiveDistance(prims_[k], ax, ay, gx, gy);
  gx *= sx;
  gy *= sy;
  return d;
}

// The global search's inner loop: the squared distance only (its error function needs no more),
// so no gradient, no division and a square root for arcs alone.
float FieldModel::Distance2(float x_m, float y_m) const {
  const float ax = std::fabs(x_m), ay = std::fabs(y_m);
  if (!(ax < 1e3f) || !(ay < 1e3f)) return 1e6f;
  const int i = std::min(static_cast<int>(ax * inv_cell_), cells_x_ - 1);
  const int j = std::min(static_cast<int>(ay * inv_cell_), cells_y_ - 1);
  const Primitive& p = prims_[(nearest_[j][i >> 1] >> ((i & 1) * 4)) & 0x0F];
  if (p.kind == 0) {
    const float ex = ax - std::min(std::max(ax, p.a), p.c);
    const float ey = ay - std::min(std::max(ay, p.b), p.d);
    return ex * ex + ey * ey;
  }
  if (p.kind == 1) {
    float gx, gy;
    const float d = PrimitiveDistance(p, ax, ay, gx, gy);
    return d * d;
  }
  const float ex = ax - p.a, ey = ay - p.b;
  return ex * ex + ey * ey;
}

bool FieldModel::Inside(float x_m, float y_m, float margin_m) const {
  return std::fabs(x_m) <= 0.5f * config_.length_m + margin_m &&
         std::fabs(y_m) <= 0.5f * config_.width_m + margin_m;
}

int FieldModel::LinePoints(float step_m, float (*xy)[2], int capacity) const {
  if (!ready_ || !(step_m > 0.001f)) return 0;
  int n = 0;
  const auto put = [&](float x, float y) {
    for (int q = 0; q < 4 && n < capacity; ++q) {
      xy[n][0] = (q & 1) ? -x : x;
      xy[n][1] = (q & 2) ? -y : y;
      ++n;
    }
  };
  for (int k = 0; k < count_; ++k) {
    const Primitive& p = prims_[k];
    if (p.kind == 0) {
      const float len = std::hypot(p.c - p.a, p.d - p.b);
      for (float t = 0.0f; t <= len; t += step_m) {
        const float f = len > 0.0f ? t / len : 0.0f;
        put(p.a + f * (p.c - p.a), p.b + f * (p.d - p.b));
      }
    } else if (p.kind == 1) {
      const float span = 0.5f * kPi, da = step_m / p.c;
      for (float a = 0.0f; a <= span; a += da)
        put(p.a + p.c * std::cos(p.d + a), p.b + p.c * std::sin(p.d + a));
    } else {
      put(p.a, p.b);
    }
  }
  return n;
}

}  // namespace bv
