#pragma once
// carpet.json of an omni calibration sequence (DESIGN.md, render/README.md): the strip's patch
// edges along its centre line, the patch colours and the strip's direction in each frame. Read
// through the strict JSON layer: types, units, ranges, unknown keys reported on stderr.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace bv::cli {

enum CarpetColorCode : uint8_t {
  kCarpetOther = 0,
  kCarpetWhite = 1,
  kCarpetBlue = 2,
  kCarpetRed = 3
};

struct Carpet {
  std::vector<double> edges_m;  // ground distance of each patch boundary, increasing
  std::vector<uint8_t> colors;  // CarpetColorCode per patch (one less than edges)
  double width_m = 0.6, thickness_m = 0;
  std::map<long, double> azimuth_rad;  // frame index -> carpet azimuth (CCW from +x), [0, 2pi)
};

/// "white", "blue", "red" or kCarpetOther.
CarpetColorCode CarpetColor(const std::string& name);

/// Errors name the file, the field, the value and what was expected.
bool LoadCarpet(const std::string& path, Carpet& c, std::string& error);
bool ParseCarpet(const nlohmann::json& j, const std::string& path, Carpet& c, std::string& error);

}  // namespace bv::cli
