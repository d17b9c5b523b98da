#pragma once
// Teaching a camera from annotated stills (`lut teach --boxes`, the real-image figures): the
// ball class from the colours inside the ball boxes against everything outside them (densities
// in the table's cells, shade-augmented and smoothed over neighbouring cells, a cell is ball where
// the ball's density beats the rest's by `ratio`), and the camera's floor-ball profile
// (core/ball_check/floor_profile.h) from where the boxes lie and how large they are. Both go into
// one teach file (the LUT blob with its camera section), which `detect` and the device read.
// No colour is refused for its hue: a yellow ball, white highlights and brown shade are taught
// as they are; only a ball class that would take the field or the lines is.
#include <memory>
#include <string>
#include <vector>

#include "core/ball_check/floor_profile.h"
#include "core/color_lut/color_lut.h"
#include "tools/ballvision/box_file.h"

namespace bv::cli {

struct BoxTeachOptions {
  float ratio = 10.0f;  // ball where its density beats the rest's by this
  int smooth = 2;       // densities blurred over +-2 chroma cells (+-1 in Y) ...
  // ... at this many ball samples or more; fewer widen the blur as a density estimate's bandwidth
  // grows, by (reference / samples)^(1/6) (two chroma dimensions), up to smooth + 2.
  double reference_ball_samples = 16000;
};

struct BoxTeach {
  std::unique_ptr<ColorLut> table;
  int ball_cells = 0;
  double ball_samples = 0, other_samples = 0;
  size_t background = 0;              // background samples checked (every 8th pixel, outside boxes)
  double field_taken = 0;             // of those of the field and line classes, fraction now ball
  double background_taken = 0;        // of all of them, fraction now ball
  int cells_given_back = 0;           // ball cells given back to the field or lines
  double ball_pixels_given_back = 0;  // the fraction of the boxes' ball pixels they held
  double ball_coverage = 0;           // of the boxes' inner pixels, the fraction the class holds
  FloorBallProfile profile;  // invalid when the boxes could not give one (profile_note says why)
  std::string profile_note;
  int width = 0, height = 0;  // the images' size
  int ball_images = 0;
  int smooth = 0;  // the blur used (BoxTeachOptions)
};

/// Teaches from `images` (all of one camera: one size). False with `error` naming the file, line
/// or reason: an unreadable image, a box outside its image, images of different sizes, no ball
/// box, a colour the fit cannot hold or that would take the field.
bool TeachFromBoxes(const std::string& box_file, const std::vector<AnnotatedImage>& images,
                    const BoxTeachOptions& options, BoxTeach& out, std::string& error);

/// The blur a teach from `ball_samples` (shade-augmented) ball samples uses.
int TeachBlur(const BoxTeachOptions& options, double ball_samples);

/// The floor-ball profile from ball boxes: whole balls (aspect >= 0.8, clear of the border),
/// r = k (v - v_h) fitted robustly (a ball held up or in the air is an outlier), a quadratic term
/// when there are 12 or more spread over 150 rows. False with `note` when there are fewer than 3
/// usable boxes or they span too few rows to place the horizon.
bool LearnFloorProfile(const std::vector<AnnotatedImage>& images, int width, int height,
                       FloorBallProfile& out, std::string& note);

}  // namespace bv::cli
