#pragma once
// Colour classification by lookup table on YUV 4:2:2 pixels.
// Layout: a 3D table indexed by Y>>4, U>>2, V>>2 (4/6/6 bits, as SSL-Vision's default):
// 16 x 64 x 64 = 65536 cells, one 4-bit class per cell, two cells per byte = 32 KB of RAM (the
// blob keeps one byte per cell). Classify() is a shift/or, one load and a nibble select. See
// README.md for why this layout (vs CMVision bitmasks or a 2D UV table) was chosen.
#include <cstddef>
#include <cstdint>
#include <span>

#if defined(__ARM_FEATURE_SIMD32) && __ARM_FEATURE_SIMD32
#include <arm_acle.h>
#endif

#include "core/ball_check/floor_profile.h"
#include "core/common/status.h"

namespace bv {

enum class ColorClass : uint8_t {
  kUnknown = 0,
  kBall = 1,
  kField = 2,
  kLine = 3,
  kObstacle = 4,
};
inline constexpr int kColorClassCount = 5;
const char* ColorClassName(ColorClass c);

/// Chroma bounding box of one class (inclusive U and V ranges of all its cells); a pixel outside
/// it can never have that class, which lets the scanlines reject most pixels with two compares.
struct ChromaBox {
  uint8_t u_min = 0, u_max = 255, v_min = 0, v_max = 255;  // default: no rejection
  bool empty = false;                                      // the class has no cell at all
  constexpr bool Contains(uint8_t u, uint8_t v) const {
    return static_cast<uint8_t>(u - u_min) <= static_cast<uint8_t>(u_max - u_min) &&
           static_cast<uint8_t>(v - v_min) <= static_cast<uint8_t>(v_max - v_min);
  }
};

/// A ChromaBox as a test on a YUYV pixel pair read as one little-endian word (Y0 U Y1 V): two
/// saturating byte subtractions on the M7's DSP extension, plain compares elsewhere. It keeps a
/// superset of what Contains() keeps: an axis whose range wraps (min > max) keeps everything.
class PairChromaTest {
 public:
  explicit constexpr PairChromaTest(const ChromaBox& b) {
    const bool u_ok = b.u_min <= b.u_max, v_ok = b.v_min <= b.v_max;
    const uint32_t u_lo = u_ok ? b.u_min : 0, u_hi = u_ok ? b.u_max : 255;
    const uint32_t v_lo = v_ok ? b.v_min : 0, v_hi = v_ok ? b.v_max : 255;
    lo_ = u_lo << 8 | v_lo << 24;  // Y lanes 0 and 255: never out of range
    hi_ = 0xFFu | u_hi << 8 | 0xFFu << 16 | v_hi << 24;
  }
  /// The word's lower and upper bounds per byte (Y lanes 0 and 255), for a vector form of Holds.
  constexpr uint32_t lo() const { return lo_; }
  constexpr uint32_t hi() const { return hi_; }
  bool Holds(uint32_t pair_word) const {
#if defined(__ARM_FEATURE_SIMD32) && __ARM_FEATURE_SIMD32
    return (__uqsub8(lo_, pair_word) | __uqsub8(pair_word, hi_)) == 0;
#else
    const uint32_t u = (pair_word >> 8) & 0xFFu, v = pair_word >> 24;
    return u >= ((lo_ >> 8) & 0xFFu) && u <= ((hi_ >> 8) & 0xFFu) && v >= (lo_ >> 24) &&
           v <= (hi_ >> 24);
#endif
  }

 private:
  uint32_t lo_ = 0, hi_ = 0xFFFFFFFFu;
};

/// The smallest box holding both.
ChromaBox Union(const ChromaBox& a, const ChromaBox& b);

class ColorLut {
 public:
  static constexpr int kYBits = 4;
  static constexpr int kUBits = 6;
  static constexpr int kVBits = 6;
  static constexpr size_t kEntries = size_t{1} << (kYBits + kUBits + kVBits);
  static_assert(kEntries <= 65536, "LUT must stay within 64 KB");

  static constexpr uint32_t Index(uint8_t y, uint8_t u, uint8_t v) {
    return (uint32_t{y} >> (8 - kYBits)) << (kUBits + kVBits) |
           (uint32_t{u} >> (8 - kUBits)) << kVBits | (uint32_t{v} >> (8 - kVBits));
  }
  /// Centre of a cell's (y, u, v) box, for training and display.
  static constexpr void CellCenter(uint32_t index, uint8_t& y, uint8_t& u, uint8_t& v) {
    y = static_cast<uint8_t>(((index >> (kUBits + kVBits)) << (8 - kYBits)) + (1 << (7 - kYBits)));
    u = static_cast<uint8_t>((((index >> kVBits) & ((1u << kUBits) - 1)) << (8 - kUBits)) +
                             (1 << (7 - kUBits)));
    v = static_cast<uint8_t>(((index & ((1u << kVBits) - 1)) << (8 - kVBits)) +
                             (1 << (7 - kVBits)));
  }

  ColorClass Classify(uint8_t y, uint8_t u, uint8_t v) const { return at(Index(y, u, v)); }
  ColorClass at(uint32_t index) const {
    return static_cast<ColorClass>((packed_[index >> 1] >> ((index & 1u) << 2)) & 0x0Fu);
  }
  void Set(uint32_t index, ColorClass c) {
    const unsigned shift = (index & 1u) << 2;
    uint8_t& b = packed_[index >> 1];
    b = static_cast<uint8_t>((b & ~(0x0Fu << shift)) | (static_cast<unsigned>(c) << shift));
  }
  void Fill(ColorClass c);
  /// Unpacks entries [first, first + out.size()) one byte per cell (blob layout).
  void CopyEntries(uint32_t first, std::span<uint8_t> out) const;
  /// CRC-32 of the table, one byte per cell (RigCalibration::lut_id).
  uint32_t Id() const;
  /// Chroma box of class `c` over the cells of U rows [u_first, u_end) (a scan: once per LUT,
  /// or a few rows per frame, not every frame).
  ChromaBox Bounds(ColorClass c, uint32_t u_first = 0, uint32_t u_end = 1u << kUBits) const;

 private:
  // 4 bits per cell halve the RAM (the 128 KB budget); classes fit in 4 bits.
  static_assert(kColorClassCount <= 16);
  uint8_t packed_[kEntries / 2] = {};
};

// --- the device blob (BlobKind::kColorLut) ---
// payload: y_bits u8 | u_bits u8 | v_bits u8 | class_count u8 | table (kEntries bytes) |
//          camera section (version 2, kColorLutCameraBytes): what a teach from boxes learned of
//          the camera's geometry (FloorBallProfile):
//          valid u8 | 3 x 0 | width u16 | height u16 | horizon_v f32 | slope f32 | curve f32 |
//          spread f32 | samples u16 | 6 x 0
// Version 1 blobs (no camera section) still load, with no profile.
inline constexpr uint16_t kColorLutBlobVersion = 2;
inline constexpr size_t kColorLutCameraBytes = 32;
inline constexpr size_t kColorLutPayloadBytesV1 = 4 + ColorLut::kEntries;
inline constexpr size_t kColorLutPayloadBytes = kColorLutPayloadBytesV1 + kColorLutCameraBytes;
inline constexpr size_t kColorLutBlobBytes = 16 + kColorLutPayloadBytes;

/// `profile` may be null (no camera section content: valid = 0). Errors: kResourceExhausted if
/// `out` is smaller than kColorLutBlobBytes, kInvalidArgument for a profile ParseLut would refuse.
Result<size_t> SerializeLut(const ColorLut& lut, std::span<uint8_t> out,
                            const FloorBallProfile* profile = nullptr);
/// Validates magic, kind, version, length, CRC, the bit layout, every class value and the camera
/// section before touching `out` or `profile` (may be null; set invalid when the blob has none).
/// Errors: kDataLoss (truncated/CRC), kInvalidArgument (layout, class values, camera section),
/// kUnimplemented (newer version).
Status ParseLut(std::span<const uint8_t> blob, ColorLut& out, FloorBallProfile* profile = nullptr);
/// The camera section's checks: a valid profile has a finite horizon, slope in (0, 10], finite
/// curve, spread >= 0 and an image size of 1..4096.
bool FloorProfileSane(const FloorBallProfile& p);

}  // namespace bv
