#pragma once
// The stage order, written once: LUT on scanlines + attention -> regions -> ball choice ->
// rays -> triangulation -> ball filter. Statically sized; Process() never allocates.
#include <cstdint>

#include "core/calibration/calibration.h"
#include "core/common/ball_state.h"
#include "core/common/image.h"
#include "core/common/status.h"

namespace bv {

class ColorLut;

struct PipelineConfig {
  uint32_t predict_ahead_us = 200000;  // actuation latency covered by px/py/pz
};

struct FrameInput {
  YuyvImage omni;   // !valid() when that camera delivered no frame
  YuyvImage persp;
  uint64_t t_us = 0;  // exposure time of the pair
};

/// Per-frame counters of the front end (pixels read, regions, overflows) for benches and status.
struct PipelineStats {
  uint32_t pixels_read = 0;
  uint32_t regions_traced = 0;
  uint32_t overflows = 0;
};

class Pipeline {
 public:
  /// Errors: kFailedPrecondition when the calibration is not valid for any camera.
  Status Init(const RigCalibration& calibration, const ColorLut& lut, const PipelineConfig& config);
  /// Runs one frame pair. Always fills `out` (found=false and flags when nothing was seen).
  Status Process(const FrameInput& in, BallState& out);
  const PipelineStats& last_stats() const { return stats_; }

 private:
  const RigCalibration* calibration_ = nullptr;
  const ColorLut* lut_ = nullptr;
  PipelineConfig config_;
  PipelineStats stats_;
  bool initialised_ = false;
};

}  // namespace bv
