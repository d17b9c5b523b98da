#pragma once
// The playing field as configuration: MSL rule-book dimensions by default, as in the `field`
// section of the renderer's rig.json. Stored with the calibration (RigCalibration::field, the
// calibration JSON's `field` section, the device blob from version 2): venues differ.
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
  float goal_width_m = 2.0f;             // between the posts' inner faces
  float goal_height_m = 1.0f;
  float goal_depth_m = 0.6f;  // goal line to the back of the goal
  float border_m = 1.5f;      // floor beyond the lines (the robot may be there; people, not robots)
  float margin_m = 0.3f;      // in-field rule: a ball on or just over a line still counts as inside
};

/// Errors (kInvalidArgument, the message names the field): a size not finite or <= 0, a penalty
/// or goal area wider than the field or deeper than half of it, a goal area larger than the
/// penalty area, a centre circle that leaves the field, a field over 40 x 30 m, a goal deeper
/// than the border or higher than 3 m.
Status ValidateFieldConfig(const FieldConfig& f);

}  // namespace bv
