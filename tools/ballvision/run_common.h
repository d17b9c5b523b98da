#pragma once
// Shared pieces of `run`, `eval` and `demo`: the colour LUT they run with.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "core/color_lut/color_lut.h"
#include "tools/ballvision/stats.h"

namespace bv::cli {

/// Fills `lut` with the built-in colour model's table (core/color_lut/color_model.h: red to
/// orange balls in sun and shade). Used by the demo, `--lut builtin` and when no table is found.
void FillBuiltInLut(ColorLut& lut);

/// Loads a LUT blob file. With `path` empty: $BV_LUT, then *.lut / *.bin in <calib dir>/luts/
/// (the committed sim LUT sits next to the reference calibration in host_tests/data/luts/),
/// then the built-in colour model ("builtin" asks for it). `used` describes what was taken.
bool LoadLutOrDefault(const std::string& path, const std::string& calib_path, ColorLut& lut,
                      std::string& used, std::string& error);

}  // namespace bv::cli
