#pragma once
// Runs the core pipeline over a captured sequence (host side of `run`, `eval`, tests).
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/pipeline.h"
#include "hal/host/sequence.h"

namespace bv::cli {

struct FrameRecord {
  int64_t index = 0;
  BallState state;
  MeasurementInfo meas;
  std::vector<uint64_t> contacts_us;  // predicted floor contacts after t (up to 8)
  PoseEstimate pose;                  // the coprocessor's own field pose after this frame
  bool field_features = false;        // the pipeline ran the field features
};

struct RunSettings {
  bool progress = false;          // progress bar on stderr
  bool reset_each_frame = false;  // unrelated stills (static_grid): no tracking across frames
  std::string annotate_dir;       // PNGs with detections and predictions when not empty
  std::string features_dir;       // lines.csv and obstacles.csv (DESIGN.md §4) when not empty
  // Called after each frame with the pipeline (e.g. to sample the filter's prediction).
  std::function<void(const Pipeline&, const FrameRecord&)> on_frame;
};

/// Processes every frame pair; proc_us is measured around Pipeline::Process.
bool RunSequence(const host::Sequence& seq, Pipeline& pipeline, const RunSettings& settings,
                 std::vector<FrameRecord>& records, std::string& error);

/// Writes the front end's debug pictures (tools/ballvision/annotate_frontend.h: scanlines,
/// contours, attention samples around the projected prediction, chosen ball) as
/// DIR/omni_NNNNNN.png and DIR/persp_NNNNNN.png.
bool AnnotateFrame(const std::string& dir, int64_t index, const FrameInput& in,
                   const Pipeline& pipeline, const BallState& s, std::string& error);

}  // namespace bv::cli
