#pragma once
// The one container for every blob the device stores or receives (calibration, LUT):
//   magic "BVB1" | kind u16 | version u16 | payload_len u32 | payload_crc32 u32 | payload
// (little endian, 16-byte header). A blob is accepted only if magic, kind, version, length and
// CRC all check out; each failure has its own message.
#include <cstddef>
#include <cstdint>
#include <span>

#include "core/common/status.h"

namespace bv {

enum class BlobKind : uint16_t {
  kCalibration = 1,
  kColorLut = 2,
  kBallClassifier = 3,
};

inline constexpr size_t kBlobHeaderBytes = 16;
inline constexpr uint32_t kBlobMagic = 0x31425642u;  // "BVB1" little endian

struct BlobView {
  BlobKind kind{};
  uint16_t version = 0;
  std::span<const uint8_t> payload;
};

/// Wraps `payload` into `out`. Returns the total size, or kResourceExhausted if `out` is small.
Result<size_t> WriteBlob(BlobKind kind, uint16_t version, std::span<const uint8_t> payload,
                         std::span<uint8_t> out);

/// Checks a complete blob. Errors: kDataLoss (truncated, bad magic, length or CRC mismatch),
/// kInvalidArgument (other kind than `expected`), kUnimplemented (version newer than known).
Result<BlobView> ReadBlob(std::span<const uint8_t> blob, BlobKind expected, uint16_t max_version);

}  // namespace bv
