#include "core/pipeline.h"

namespace bv {

// Placeholder stage order until the front end, calibration and filter stages land: it checks
// the input and reports "not found". Owner: tracking stage (issue 5) fills in the stages.
Status Pipeline::Init(const RigCalibration& calibration, const ColorLut& lut,
                      const PipelineConfig& config) {
  calibration_ = &calibration;
  lut_ = &lut;
  config_ = config;
  initialised_ = true;
  return Status();
}

Status Pipeline::Process(const FrameInput& in, BallState& out) {
  out = BallState{};
  out.t_us = in.t_us;
  stats_ = PipelineStats{};
  if (!initialised_) return Status(StatusCode::kFailedPrecondition, "pipeline: Init() not called");
  return Status();
}

}  // namespace bv
