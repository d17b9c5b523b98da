#pragma once
// Online adaptation of the ball colour on the device (issue 11): while the ball is confirmed by
// both cameras, the pixels inside its regions refine the ball colour statistics (fixed size,
// decaying), the model is refitted from them now and then, checked against a guard set of
// field / line / obstacle samples taken around the ball, and the table rebuilt in place a few
// rows per frame. Nothing is stored: the adapted table lives in RAM until a command saves it.
//
// ~6 KB of state: the firmware keeps the adapter in external RAM; the pipeline only holds a
// pointer (null: adaptation off).
#include <cstdint>

#include "core/color_lut/color_lut.h"
#include "core/color_lut/color_model.h"
#include "core/color_lut/color_teach.h"
#include "core/common/ball_state.h"
#include "core/common/image.h"

namespace bv {

struct ColorAdaptConfig {
  int refit_every = 16;           // confirmed frames between refits (and halvings of the counts)
  float min_pixels = 400.0f;      // decayed ball pixels a refit needs
  float max_guard_taken = 0.01f;  // a refit taking more of the guard samples is refused
  int rows_per_frame = 2;         // table U rows rebuilt per frame (of 64): ~1 s per rebuild
  int samples_per_region = 64;
};

struct ColorAdaptStats {
  uint32_t frames_observed = 0;
  uint32_t refits = 0;            // models accepted (and rebuilt)
  uint32_t refits_refused = 0;    // by the guard set or an invalid fit
  uint32_t refits_unchanged = 0;  // accepted fits that left the model as it was (no rebuild)
  uint32_t rebuilds_done = 0;
};

class ColorAdapter {
 public:
  static constexpr int kGuardSamples = 256;

  /// `table` is the live table the pipeline classifies with; `model` the model it was built
  /// from (the built-in one, or a taught one). Resets the statistics. Adaptation only adds to
  /// `model`: every refit is the union of it and the fit, so a refit from a few frames of one
  /// light can never lose the colours the start model finds (the shaded side of a ball resting
  /// behind a robot).
  void Start(const BallColorModel& model, ColorLut* table, const ColorAdaptConfig& config = {});
  bool active() const { return table_ != nullptr; }
  void Stop() { table_ = nullptr; }

  /// One confirmed detection of the ball in `image` (the caller decides confirmation: both
  /// cameras agree). Samples inside 0.6 of its radius that the current model widened by 10 deg
  /// of hue takes become ball statistics; 8 samples on a ring at 2.5 radii that the table calls
  /// field, line or obstacle become guard samples.
  void Observe(const YuyvImage& image, const BallDetection& det);
  /// Once per frame pair, after the observations: refits when due, rebuilds table rows.
  void Step();

  const BallColorModel& model() const { return model_; }
  const ColorAdaptStats& stats() const { return stats_; }
  bool rebuilding() const { return next_row_ >= 0; }
  /// The ball chroma box of the table after the last completed rebuild (scanned row by row as
  /// it was rebuilt: no full-table scan in any one frame).
  const ChromaBox& ball_box() const { return box_; }

 private:
  ColorAdaptConfig config_;
  ColorLut* table_ = nullptr;
  BallColorModel start_, model_, pending_;  // start_: the floor adaptation never gives up
  BallColorStats ball_;
  Yuv guard_[kGuardSamples] = {};
  int guard_count_ = 0, guard_next_ = 0;
  int frames_since_refit_ = 0;
  int next_row_ = -1;  // rebuilding pending_ into the table from this U row on; -1: idle
  bool observed_this_frame_ = false;
  ChromaBox box_, building_box_;
  ColorAdaptStats stats_;
};

}  // namespace bv
