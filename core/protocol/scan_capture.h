#pragma once
// Capture mode 3, "scanlines" (docs/protocol.md, "Capture"): per camera only the pixels the
// front end reads on its precomputed scan table (core/scanline), as one byte stream
//   sample_count u32 | positions_crc32 u32 | Y U V per sample, in table order
// (row-major, ScanlineTableBase::ReadSamples). Y is the sample pixel's own luma, U and V its
// pixel pair's chroma: exactly the three bytes the colour table classifies (core/detect reads
// the pair word and takes Y by the parity of u), one byte less than the pair word, which would
// add the neighbour's luma that no classification of this sample uses.
// positions_crc32 is the CRC-32 of (u u16, v u16), little endian, of every sample in that
// order: a host that builds the table from the calibration file can tell that its table is
// the device's sample for sample (the count alone would not see a shifted centre).
#include <cstddef>
#include <cstdint>
#include <span>

#include "core/common/image.h"
#include "core/scanline/scanline.h"

namespace bv::protocol {

inline constexpr size_t kScanStreamHeaderBytes = 8;
inline constexpr size_t kScanSampleBytes = 3;
/// Samples a table can hold at most (ScanlineTable's capacity bound).
inline constexpr uint32_t kMaxScanSamples = 65535;

/// Bytes of one camera's stream for `samples` samples.
constexpr uint32_t ScanStreamBytes(uint32_t samples) {
  return static_cast<uint32_t>(kScanStreamHeaderBytes + kScanSampleBytes * samples);
}

/// CRC-32 of every sample position (u u16, v u16 little endian) in table order.
uint32_t ScanPositionsCrc(const ScanlineTableBase& table);

/// The sample count and positions CRC at the start of a stream; false for fewer than
/// kScanStreamHeaderBytes bytes or a count above kMaxScanSamples.
bool ParseScanStreamHeader(std::span<const uint8_t> stream, uint32_t& samples,
                           uint32_t& positions_crc);

/// One camera's stream, read front to back in pieces of any size (the capture's chunks), with
/// no buffer beyond one sample: the cursor walks the table as the bytes are asked for.
class ScanSampleStream {
 public:
  /// Rewinds to the first byte for `table`, whose ScanPositionsCrc is `positions_crc`.
  void Start(const ScanlineTableBase& table, uint32_t positions_crc);
  uint32_t total_bytes() const { return total_; }
  uint32_t position() const { return pos_; }
  /// The next out.size() bytes, the samples read from `image`. False (stream left where it
  /// was) past the stream's end, without a table, or for a sample outside the image.
  bool Read(const YuyvImage& image, std::span<uint8_t> out);

 private:
  const ScanlineTableBase* table_ = nullptr;
  ScanlineTableBase::Cursor cursor_;
  uint8_t header_[kScanStreamHeaderBytes] = {};
  uint8_t sample_[kScanSampleBytes] = {};
  uint32_t pos_ = 0;
  uint32_t total_ = 0;
};

}  // namespace bv::protocol
