#pragma once
// The playing field (core/field/field_config.h) and the distance from any field point to the
// nearest line centre, for self-localisation (Lauer, Lange, Riedmiller 2006: "Calculating the
// perfect match"). The field is symmetric about both axes, so one quadrant is modelled: a table of
// 10 cm cells holds the index of the nearest line primitive (segment, arc or spot) and the
// distance itself is computed exactly from that primitive: continuous, with an exact gradient,
// where a table of distances would put every minimum on a cell node. Fixed size, no heap.
#include <cstdint>

#include "core/common/status.h"
#include "core/field/field_config.h"

namespace bv {

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
  /// The same distance squared, without the gradient (cheaper: the global search's scoring).
  float Distance2(float x_m, float y_m) const;
  /// True if (x, y) lies within the field lines plus `margin_m`.
  bool Inside(float x_m, float y_m, float margin_m) const;
  int primitive_count() const { return count_; }
  /// Points every `step_m` along every line of the whole field (all four quadrants; a shared
  /// axis line appears twice), for drawing the model; returns how many were written.
  int LinePoints(float step_m, float (*xy)[2], int capacity) const;

 private:
  struct Primitive {
    uint8_t kind;      // 0 axis-parallel segment (a, b) -> (c, d), a <= c, b <= d; 1 arc centre
                       // (a, b) radius c; 2 spot (a, b)
    float a, b, c, d;  // arc: d = start angle, 0 or pi (rad); it spans a quarter turn
  };
  void Add(uint8_t kind, float a, float b, float c, float d);
  float PrimitiveDistance(const Primitive& p, float x, float y, float& gx, float& gy) const;

  FieldConfig config_;
  bool ready_ = false;
  Primitive prims_[kMaxPrimitives] = {};
  int count_ = 0;
  float cell_m_ = 0.1f, inv_cell_ = 10.0f;
  int cells_x_ = 0, cells_y_ = 0;
  // 4 bits a cell (<= 16 primitives): 4.5 KB of RAM for the default field at 10 cm.
  uint8_t nearest_[kMaxCellsY][kMaxCellsX / 2] = {};
  static_assert(kMaxPrimitives <= 16 && kMaxCellsX % 2 == 0);
};

}  // namespace bv
