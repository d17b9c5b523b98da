#pragma once
// Debug pictures of the image front end (like the paper's Fig. 1, right): the frame dimmed to
// grey, every scanline pixel in its colour class, the traced contours (holes in cyan), the
// Monte-Carlo attention samples and the predicted position, the chosen ball.
#include <string>

#include "core/color_lut/color_lut.h"
#include "core/common/ball_state.h"
#include "core/common/image.h"
#include "core/detect/detect.h"
#include "core/scanline/scanline.h"

namespace bv {

/// Draws the state of `finder` after its last Find() on `image` and writes a PNG (upscaled by
/// `scale`). `prediction` may be null. Returns false with `error` set when writing fails.
bool AnnotateFrontEnd(const YuyvImage& image, const ColorLut& lut, const ScanlineTableBase& scan,
                      const BallFinder& finder, const Prediction* prediction,
                      const BallDetection& detection, const std::string& png_path,
                      std::string* error = nullptr, int scale = 1);

}  // namespace bv
