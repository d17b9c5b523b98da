#pragma once
// How large a ball on the floor looks across the image of a camera without calibration, as a
// teach learns it from the boxes of annotated stills. A level pinhole camera at height h sees a
// floor ball of radius R at row v with radius r = k (v - v_h), k = R / (h - R); a wide-angle
// lens bends that line, which the quadratic term holds. Carried in the colour table's blob
// (core/color_lut), so the device has it wherever it has the table.
#include <cstdint>

namespace bv {

struct FloorBallProfile {
  bool valid = false;
  uint16_t width_px = 0, height_px = 0;  // image size the profile was learned on
  float horizon_v_px = 0;                // row of the horizon (v_h)
  float slope = 0;                       // k: radius gained per row below the horizon (> 0)
  float curve = 0;                       // c: r = k d + c d^2, d = v - v_h (rows)
  float spread = 0;      // relative scatter of the learning boxes about the profile (robust sd)
  uint16_t samples = 0;  // boxes it was learned from

  /// Radius of a floor ball whose centre is at row v; <= 0 at and above the horizon.
  float RadiusAt(float v_px) const {
    const float d = v_px - horizon_v_px;
    return d > 0 ? d * (slope + curve * d) : 0.0f;
  }
};

}  // namespace bv
