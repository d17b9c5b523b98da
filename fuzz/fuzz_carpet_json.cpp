// The carpet.json reader (tools/ballvision/carpet_json): refusal with a message, or a carpet
// that satisfies what calibrate omni relies on.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "tools/ballvision/carpet_json.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const nlohmann::json j = nlohmann::json::parse(data, data + size, nullptr, false);
  if (j.is_discarded()) return 0;
  bv::cli::Carpet c;
  std::string error;
  if (!bv::cli::ParseCarpet(j, "fuzz.json", c, error)) {
    if (error.empty()) __builtin_trap();
    return 0;
  }
  if (c.edges_m.size() < 12 || c.colors.size() + 1 != c.edges_m.size()) __builtin_trap();
  for (size_t i = 1; i < c.edges_m.size(); ++i) {
    if (!(c.edges_m[i] > c.edges_m[i - 1])) __builtin_trap();
  }
  for (const auto& [index, az] : c.azimuth_rad) {
    if (!(az >= 0 && az < 2 * M_PI + 1e-9)) __builtin_trap();
  }
  return 0;
}
