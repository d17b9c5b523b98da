#pragma once
// The ball's colour as a shade-invariant model, and the lookup table generated from it.
//
// Light that falls unevenly on the ball (sun on one side, shadow on the other) scales a pixel's
// Y and its chroma (U-128, V-128) by the same factor, so the model is stated in the two
// quantities that factor leaves alone: the hue angle atan2(V-128, U-128) and the chroma relative
// to luma, |(U-128, V-128)| / Y (Pixy's brightness-normalised basis, in YUV). Specular light adds
// white, which lowers the relative chroma of bright pixels: above `bright_y` the chroma floor
// falls linearly to `chroma_min_bright` at `bright_y_end`. Every bound is a parameter, fitted by
// teaching (tools/ballvision `lut teach`, the device's teach command); the defaults cover the
// red-to-orange balls of the league in sun and shade (core/color_lut/README.md: how they were
// measured). The device never evaluates the model per pixel: BuildLut writes it into the table.
#include <cstdint>

#include "core/color_lut/color_lut.h"
#include "core/common/status.h"

namespace bv {

struct BallColorModel {
  float hue_min_deg = 104.0f;  // atan2(V-128, U-128), counter-clockwise window [min, max]
  float hue_max_deg = 152.0f;
  float chroma_min = 0.28f;         // relative chroma floor up to bright_y
  float chroma_min_bright = 0.16f;  // ... from bright_y_end on (highlights desaturate)
  float chroma_max = 1.30f;         // above: dark-pixel noise, not a surface colour
  uint8_t bright_y = 128, bright_y_end = 192;
  uint8_t y_min = 28, y_max = 255;  // below y_min chroma is mostly sensor noise
  // |(U-128, V-128)| floor in levels, whatever the luma: dark grey reads a few levels off grey
  // (often yellowish), which a relative floor alone lets in at low Y. 0: none.
  uint8_t chroma_abs_min = 0;
};

/// The match balls the built-in models know, by name (`--ball`, the device's ball command).
enum class BallName : uint8_t { kRed = 0, kOrange = 1, kYellow = 2 };
inline constexpr int kBallNameCount = 3;
const char* BallNameText(BallName b);
/// "red", "orange" or "yellow"; false for anything else.
bool ParseBallName(const char* text, BallName& out);
/// The built-in model of a ball: red is BallColorModel{} (red to orange-red); orange and yellow
/// cover those balls in sun and shade (core/color_lut/README.md: how each was measured).
BallColorModel BuiltInBallModel(BallName b);

/// kInvalidArgument naming the bad field: NaN, hue window empty or wider than 170 degrees, chroma
/// bounds outside (0, 4] or crossed, Y bounds crossed.
Status ValidateBallColorModel(const BallColorModel& m);

/// The model prepared for evaluation pixel by pixel (trigonometry once): teaching and tests; the
/// pipeline uses the table.
class BallColorTest {
 public:
  explicit BallColorTest(const BallColorModel& m);
  bool Contains(int y, int u, int v) const;
  /// Every bound but the hue window (luma range, relative chroma floor and ceiling).
  bool ContainsIgnoringHue(int y, int u, int v) const;
  /// Inside the hue window (narrower than 180 deg): left of its first edge, right of its last.
  bool InWindow(float du, float dv) const {
    return lo_x_ * dv - lo_y_ * du >= 0.0f && du * hi_y_ - dv * hi_x_ >= 0.0f;
  }
  float ChromaFloor(int y) const;

 private:
  float lo_x_, lo_y_, hi_x_, hi_y_;  // unit vectors of the hue window's edges in (U, V)
  float cmin_, cmin_bright_, cmax_;
  int bright_y_, bright_y_end_, y_min_, y_max_;
  float abs_min2_;
};

/// The model evaluated on one pixel (host tools and tests; the device uses the table).
bool InBallColorModel(const BallColorModel& m, uint8_t y, uint8_t u, uint8_t v);

/// The fixed rule for the non-ball classes (field green, white line, dark obstacle).
ColorClass BackgroundClass(uint8_t y, uint8_t u, uint8_t v);

/// Writes the whole table: a cell is ball when at least half of 8 colours spread over it are in
/// the model (so the table's boundary follows the model's, not the cell centres'), else the
/// background class. The model must be valid (kInvalidArgument, table untouched, otherwise).
/// Allocation-free: the device runs it at boot when it has no stored table, and after a teach.
Status BuildLut(const BallColorModel& m, ColorLut& out);
/// The ball class of the cells with U index in [u_first, u_end) only (of 64), for online
/// adaptation: a few rows per frame, so no frame costs more than its share. The rows were built
/// from model `from` (BuildLut or an earlier update); a cell model `m` holds becomes ball, a ball
/// cell it no longer holds gets the background class, every other cell keeps its class (a taught
/// venue table's field and lines stay). Chroma columns that neither model can make ball are not
/// read. `ball_box` receives the chroma box of the ball cells of these rows (as ColorLut::Bounds
/// would). kInvalidArgument (table untouched) for an invalid model or rows outside the table.
Status UpdateBallRows(const BallColorModel& from, const BallColorModel& m, ColorLut& table,
                      int u_first, int u_end, ChromaBox& ball_box);

}  // namespace bv
