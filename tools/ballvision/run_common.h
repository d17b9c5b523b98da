#pragma once
// Shared pieces of `run`, `eval` and `demo`: the colour LUT they run with.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "core/ball_check/ball_check.h"
#include "core/color_lut/color_lut.h"
#include "tools/ballvision/stats.h"

namespace bv::cli {

/// Fills `lut` with the built-in colour model's table (core/color_lut/color_model.h: red to
/// orange balls in sun and shade). Used by the demo, `--lut builtin` and when no table is found.
void FillBuiltInLut(ColorLut& lut);

/// `--ball NAME`: the built-in model of that ball (red, orange, yellow) into `lut`; false with
/// `error` for an unknown name.
bool FillBuiltInBallLut(const std::string& name, ColorLut& lut, std::string& error);

/// `--classifier FILE|builtin|off` (empty: builtin) into `c` (off: not loaded). False with `error`
/// naming the file and what was wrong with it.
bool LoadClassifierArg(const std::string& arg, BallClassifier& c, std::string& error);

/// Loads a LUT blob file. With `path` empty: $BV_LUT, then *.lut / *.bin in <calib dir>/luts/
/// (the committed sim LUT sits next to the reference calibration in host_tests/data/luts/),
/// then the built-in colour model ("builtin" asks for it). `used` describes what was taken.
/// With `ball` (a ball name), the built-in model of that ball: `path` must then be empty or
/// "builtin".
bool LoadLutOrDefault(const std::string& path, const std::string& calib_path, ColorLut& lut,
                      std::string& used, std::string& error, const std::string& ball = "");

}  // namespace bv::cli
