#pragma once
// One-step venue teaching (ballvision lut teach): fits the shade-invariant ball colour model
// (core/color_lut/color_model.h) to the ball as it appears across a whole short sequence, so the
// sunlit and the shaded side, near and far, are all in the fit.
//
// Per camera and frame the ball is found with the current model's table (the built-in default
// unless given), tracked from frame to frame; from the found centre the ball is grown over the
// image (not the table) with a relaxed colour test inside twice the found radius, so the pixels
// the current table misses (the other side of the shade, the sun) are collected too. The model
// is then fitted to those pixels' hue, relative chroma and luma with margins, and checked
// against the rest of the frames: a model that would take the field's pixels is refused.
#include <cstdint>
#include <string>
#include <vector>

#include "core/color_lut/color_model.h"
#include "core/common/image.h"
#include "tools/ballvision/lut_train.h"

namespace bv::lut {

struct TeachOptions {
  bool cameras[2] = {true, true};  // [Camera::kOmni], [Camera::kPersp]
  // A click: the ball is at pixel (u, v) of camera `click_camera` in the frame `click_index`;
  // that camera is tracked from there forwards and backwards. Without one the finder's choice
  // is followed (the ball must be the one moving ball-coloured blob).
  bool click = false;
  int64_t click_index = 0;
  Camera click_camera = Camera::kPersp;
  float click_u = 0, click_v = 0;
  BallColorModel start;  // the model whose table finds the ball to learn from
  int every = 1;         // frames used (index % every == 0)
};

struct TeachReport {
  BallColorModel model;
  int frames[2] = {0, 0};       // frames the ball was found and grown in, per camera
  size_t ball_pixels = 0;       // grown ball pixels fitted
  size_t background = 0;        // background samples checked
  double field_taken = 0;       // of the field-class background samples, fraction now ball
  double background_taken = 0;  // of all background samples, fraction now ball
  int64_t first_moves_px = 0;   // auto mode: largest distance between found centres, per camera
};

/// Fits a model to ball pixels. False with `why` when there are too few pixels (< 200) or their
/// colour cannot be a ball (no hue range with enough chroma).
bool FitBallColorModel(const std::vector<Yuv>& ball, const BallColorModel& start,
                       BallColorModel& out, std::string& why);

/// Narrows the model's hue window to the choice of ball-pixel percentiles that leaves out the
/// most background for the fewest ball pixels (each background sample counts `background_weight`
/// pixels): red and orange things near the ball's hue but not on it are excluded where the ball's
/// own spread allows.
void NarrowAgainstBackground(const std::vector<Yuv>& ball, const std::vector<Yuv>& background,
                             double background_weight, BallColorModel& m);

/// The whole teach over a sequence directory (frames.csv). False with `error` naming what was
/// wrong: the sequence, no frame with the ball, a click not on a ball-coloured region, a fit
/// that would take more than 0.2 % of the field's pixels.
bool TeachSequence(const std::string& dir, const FinderSetup& setup, const TeachOptions& opt,
                   TeachReport& out, std::string& error);

}  // namespace bv::lut
