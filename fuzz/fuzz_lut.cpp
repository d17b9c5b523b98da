// The colour LUT blob loader (device side).
#include <cstddef>
#include <cstdint>

#include "core/color_lut/color_lut.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static bv::ColorLut lut;  // 32 KB: static, as on the device
  const uint32_t before = lut.Id();
  if (!bv::ParseLut({data, size}, lut).ok()) {
    if (lut.Id() != before) __builtin_trap();  // a refused blob must leave the table untouched
  }
  return 0;
}
