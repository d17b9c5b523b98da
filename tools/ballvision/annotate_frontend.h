#pragma once
// Debug pictures of the image front end (like the paper's Fig. 1, right): the frame dimmed to
// grey, every scanline pixel in its colour class, the traced contours (holes in cyan), the
// Monte-Carlo attention samples and the predicted position, the chosen ball.
#include <string>
#include <utility>
#include <vector>

#include "core/calibration/calibration.h"
#include "core/color_lut/color_lut.h"
#include "core/common/ball_state.h"
#include "core/common/image.h"
#include "core/detect/detect.h"
#include "core/scanline/scanline.h"

namespace bv {

/// What the field features add to the omni picture, in image pixels.
struct FieldOverlay {
  struct Px {
    float u, v;
  };
  std::vector<Px> line_points;                  // observed line points (yellow)
  std::vector<std::pair<Px, float>> obstacles;  // footprint centre and radius in px (red)
  std::vector<Px> model;  // the field's lines seen through the estimated pose (green)
  // The robot itself as the calibration knows it (orange): usable radii, masked sectors, body.
  const OmniSelfMask* self_mask = nullptr;
  float center_u = 0, center_v = 0;
  std::string caption;
};

/// Draws the state of `finder` after its last Find() on `image` and writes a PNG (upscaled by
/// `scale`). `prediction` and `field` may be null. Returns false with `error` set when writing
/// fails.
bool AnnotateFrontEnd(const YuyvImage& image, const ColorLut& lut, const ScanlineTableBase& scan,
                      const BallFinder& finder, const Prediction* prediction,
                      const BallDetection& detection, const std::string& png_path,
                      std::string* error = nullptr, int scale = 1,
                      const FieldOverlay* field = nullptr);

}  // namespace bv
