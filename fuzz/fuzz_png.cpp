// Image files of a captured sequence (PNG -> YUYV).
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "hal/host/sequence.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::vector<uint8_t> out;
  int w = 0, h = 0;
  std::string error;
  if (bv::host::DecodePngToYuyv("fuzz.png", data, size, out, w, h, error)) {
    if (out.size() != static_cast<size_t>(w) * h * 2) __builtin_trap();
  } else if (error.empty()) {
    __builtin_trap();
  }
  return 0;
}
