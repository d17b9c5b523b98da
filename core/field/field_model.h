#pragma once
// The playing field as configuration (MSL rule-book dimensions by default, as in the `field`
// section of the renderer's rig.json) and the distance from any field point to the nearest
// line centre, for self-localisation (Lauer, Lange, Riedmiller 2006: "Calculating the perfect
// match"). The field is symmetric about both axes, so one quadrant is modelled: a table of
// 10 cm cells holds the index of the nearest line primitive (segment, arc or spot) and the
// distance itself is computed exactly from that primitive: continuous, with an exact gradient,
// where a table of distances would put every minimum on a cell node. Fixed size, no heap.
#include <cstdint>

#include "core/common/status.h"

namespace bv {

/// Field frame: origin at the centre spot, +X towards the opponent goal line, metres.
struct FieldConfig {
  float length_m = 18.0f;  // goal line to goal line
  float width_m = 12.0f;   // touchline to touchline
  float line_width_m = 0.125f;
  float center_circle_radius_m = 2.0f;
  float penalty_area_depth_m = 2.25f;
  float penalty_area_width_m = 6.5f;
  float goal_area_depth_m = 0.75f;
  float goal_area_width_m = 3.5f;
  float penalty_mark_distance_m = 3.0f;  // from the goal line; 0: no mark
  float corner_arc_radius_m = 0.75f;     // 0: no corner arcs
  float goal_width_m = 2.0f;
  float border_m = 1.5f;  // floor beyond the lines (obstacles and the robot may be there)
  float margin_m = 0.3f;  // in-field rule: a ball on or just over a line still counts as inside
};

/// Errors (kInvalidArgument, the message names the field): a size not finite or <= 0, a penalty
/// or goal area wider than the field or deeper than half of it, a goal area larger than the
/// penalty area, a centre circle that leaves the field, a field over 40 x 30 m.
Status ValidateFieldConfig(const FieldConfig& f);

class FieldModel {
 public:
  static constexpr int kMaxCellsX = 112;
  static constexpr int kMaxCellsY = 80;
  static constexpr int kMaxPrimitives = 16;

  /// Errors: those of ValidateFieldConfig; the model is left unusable (ready() false).
  Status Init(const FieldConfig& config);
  bool ready() const { return ready_; }
  const FieldConfig& config() const { return config_; }

  /// Distance (m) from field point (x, y) to the nearest line centre; (gx, gy) receives the
  /// gradient of that distance (a unit vector pointing away from the line; 0 on the line).
  float Distance(float x_m, float y_m, float& gx, float& gy) const;
  /// True if (x, y) lies within the field lines plus `margin_m`.
  bool Inside(float x_m, float y_m, float margin_m) const;
  int primitive_count() const { return count_; }
  /// Points every `step_m` along every line of the whole field (all four quadrants; a shared
  /// axis line appears twice), for drawing the model; returns how many were written.
  int LinePoints(float step_m, float (*xy)[2], int capacity) const;

 private:
  struct Primitive {
    uint8_t kind;      // 0 segment (a, b) -> (c, d); 1 arc centre (a, b) radius c; 2 spot (a, b)
    float a, b, c, d;  // arc: d = start angle, 0 or pi (rad); it spans a quarter turn
  };
  void Add(uint8_t kind, float a, float b, float c, float d);
  float PrimitiveDistance(const Primitive& p, float x, float y, float& gx, float& gy) const;

  FieldConfig config_;
  bool ready_ = false;
  Primitive prims_[kMaxPrimitives] = {};
  int count_ = 0;
  float cell_m_ = 0.1f;
  int cells_x_ = 0, cells_y_ = 0;
  // 4 bits a cell (<= 16 primitives): 4.5 KB of RAM for the default field at 10 cm.
  uint8_t nearest_[kMaxCellsY][kMaxCellsX / 2] = {};
  static_assert(kMaxPrimitives <= 16 && kMaxCellsX % 2 == 0);
};

}  // namespace bv
