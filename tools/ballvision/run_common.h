#pragma once
// Shared pieces of `run`, `eval` and `demo`: colour LUT lookup, a PNG line plotter (OpenCV,
// so the demo needs nothing but the binary), truth.csv reading and small statistics.
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

struct PlotSeries {
  std::string name;
  std::vector<double> x, y;
  uint8_t r = 0, g = 0, b = 0;
  enum Style { kLine, kPoints, kDashed, kLinePoints } style = kLine;
};
/// Writes a PNG line plot (axes with ticks, legend). Returns false with `error` set on failure.
bool PlotPng(const std::string& path, const std::string& title, const std::string& xlabel,
             const std::string& ylabel, const std::vector<PlotSeries>& series, std::string& error,
             double y_min = 0, double y_max = 0);

}  // namespace bv::cli
