// The calibration blob loader (device side).
#include <cmath>
#include <cstddef>
#include <cstdint>

#include <vector>

#include "core/calibration/calibration.h"
#include "core/common/blob.h"
#include "core/pipeline.h"
#include "core/scanline/scanline.h"
#include "fuzz/blob_input.h"

// Input: fuzz/blob_input.h.
extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  std::vector<uint8_t> wrapped;
  const std::span<const uint8_t> blob = bv::fuzz::BlobFromInput(
      data, size, bv::BlobKind::kCalibration, bv::kCalibrationBlobVersion, wrapped);
  bv::RigCalibration cal;
  if (bv::ParseCalibration(blob, cal).ok()) {
    // An accepted calibration must be usable: no NaN out of the models.
    float u = 0, v = 0, x = 0, y = 0;
    if (cal.persp.valid) {
      auto ray = bv::PerspPixelToRay(cal.persp, 320, 240);
      if (ray.ok() && !ray->dir.allFinite()) __builtin_trap();
    }
    if (cal.omni.valid &&
        bv::OmniPixelToGround(cal.omni, cal.omni.center_u + 50, cal.omni.center_v, x, y).ok()) {
      if (!std::isfinite(x) || !std::isfinite(y)) __builtin_trap();
      (void)bv::OmniGroundToPixel(cal.omni, x, y, u, v).ok();
    }
    // A learned self-mask sets the scan geometry: any accepted one builds a table or says why.
    if (cal.omni.valid && cal.omni.self_mask.known) {
      static bv::ScanlineTable<bv::kOmniScanPixels> table;
      (void)table.BuildOmni(bv::PipelineOmniScan(cal.omni, bv::PipelineConfig{}), 640, 480).ok();
    }
  }
  return 0;
}
