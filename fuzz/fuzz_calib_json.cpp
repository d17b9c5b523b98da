// The calibration JSON reader (tools/ballvision/calib_io + strict_json): any bytes must give
// either a refusal with a message or a calibration that survives JSON -> struct -> JSON.
#include <cstddef>
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "tools/ballvision/calib_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const nlohmann::json j = nlohmann::json::parse(data, data + size, nullptr, false);
  if (j.is_discarded()) return 0;
  bv::RigCalibration cal;
  std::string error;
  std::vector<std::string> unknown;
  if (!bv::cli::CalibrationFromJson(j, cal, error, "fuzz.json", &unknown)) {
    if (error.empty()) __builtin_trap();  // every refusal says why
    return 0;
  }
  // Accepted: writing it back and reading it again must give the same device blob.
  std::vector<uint8_t> a, b;
  bv::RigCalibration again;
  if (!bv::cli::CalibrationToBlob(cal, a, error) ||
      !bv::cli::CalibrationFromJson(bv::cli::CalibrationToJson(cal), again, error) ||
      !bv::cli::CalibrationToBlob(again, b, error) || a != b) {
    __builtin_trap();
  }
  return 0;
}
