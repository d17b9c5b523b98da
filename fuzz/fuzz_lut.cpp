// The colour LUT blob loader (device side).
#include <cstddef>
#include <cstdint>

#include <vector>

#include "core/color_lut/color_lut.h"
#include "core/common/blob.h"
#include "fuzz/blob_input.h"

// Input: fuzz/blob_input.h.
extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static bv::ColorLut lut;  // 32 KB: static, as on the device
  if (size == 0) return 0;
  std::vector<uint8_t> wrapped;
  const std::span<const uint8_t> blob = bv::fuzz::BlobFromInput(data, size, bv::BlobKind::kColorLut,
                                                                bv::kColorLutBlobVersion, wrapped);
  // Only a whole-size blob whose container checks out can reach the code that writes the table,
  // so the (costly: 64 K cells) untouched-on-refusal check is done for those alone.
  // Version 1 (no camera section) still loads, so a whole v1 container may be accepted too.
  const bool v2 = blob.size() == bv::kColorLutBlobBytes &&
                  bv::ReadBlob(blob, bv::BlobKind::kColorLut, bv::kColorLutBlobVersion).ok();
  const bool v1 = blob.size() == 16 + bv::kColorLutPayloadBytesV1 &&
                  bv::ReadBlob(blob, bv::BlobKind::kColorLut, 1).ok();
  if (!v1 && !v2) {
    if (bv::ParseLut(blob, lut).ok()) __builtin_trap();
    return 0;
  }
  const uint32_t before = lut.Id();
  if (!bv::ParseLut(blob, lut).ok()) {
    if (lut.Id() != before) __builtin_trap();  // a refused blob must leave the table untouched
  }
  return 0;
}
