// The calibration blob loader (device side).
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "core/calibration/calibration.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  bv::RigCalibration cal;
  if (bv::ParseCalibration({data, size}, cal).ok()) {
    // An accepted calibration must be usable: no NaN out of the models.
    float u = 0, v = 0, x = 0, y = 0;
    if (cal.persp.valid) {
      auto ray = bv::PerspPixelToRay(cal.persp, 320, 240);
      if (ray.ok() && !ray->dir.allFinite()) __builtin_trap();
    }
    if (cal.omni.valid && bv::OmniPixelToGround(cal.omni, cal.omni.center_u + 50,
                                                cal.omni.center_v, x, y).ok()) {
      if (!std::isfinite(x) || !std::isfinite(y)) __builtin_trap();
      (void)bv::OmniGroundToPixel(cal.omni, x, y, u, v).ok();
    }
  }
  return 0;
}
