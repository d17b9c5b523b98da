#include "core/protocol/scan_capture.h"

#include "core/common/bytes.h"
#include "core/common/crc32.h"

namespace bv::protocol {

uint32_t ScanPositionsCrc(const ScanlineTableBase& table) {
  uint32_t crc = 0;
  ScanlineTableBase::Cursor c;
  table.ReadSamples(c, kMaxScanSamples, [&crc](int u, int v) {
    const uint8_t b[4] = {static_cast<uint8_t>(u), static_cast<uint8_t>(u >> 8),
                          static_cast<uint8_t>(v), static_cast<uint8_t>(v >> 8)};
    crc = Crc32Update(crc, b);
  });
  return crc;
}

bool ParseScanStreamHeader(std::span<const uint8_t> stream, uint32_t& samples,
                           uint32_t& positions_crc) {
  if (stream.size() < kScanStreamHeaderBytes) return false;
  ByteReader r(stream.first(kScanStreamHeaderBytes));
  samples = r.U32();
  positions_crc = r.U32();
  return samples <= kMaxScanSamples;
}

void ScanSampleStream::Start(const ScanlineTableBase& table, uint32_t positions_crc) {
  table_ = &table;
  cursor_ = ScanlineTableBase::Cursor{};
  pos_ = 0;
  total_ = ScanStreamBytes(table.pixel_count());
  ByteWriter w(header_);
  w.U32(table.pixel_count()), w.U32(positions_crc);
}

bool ScanSampleStream::Read(const YuyvImage& image, std::span<uint8_t> out) {
  if (table_ == nullptr || out.size() > total_ - pos_) return false;
  const ScanlineTableBase::Cursor saved_cursor = cursor_;
  const uint32_t saved_pos = pos_;
  uint8_t saved_sample[kScanSampleBytes];
  for (size_t k = 0; k < kScanSampleBytes; ++k) saved_sample[k] = sample_[k];
  for (uint8_t& byte : out) {
    if (pos_ < kScanStreamHeaderBytes) {
      byte = header_[pos_++];
      continue;
    }
    const uint32_t in_sample = (pos_ - kScanStreamHeaderBytes) % kScanSampleBytes;
    if (in_sample == 0) {  // the next sample's three bytes
      bool inside = false;
      table_->ReadSamples(cursor_, 1, [&](int u, int v) {
        inside = image.contains(u, v);
        if (!inside) return;
        const Yuv p = image.at(u, v);
        sample_[0] = p.y, sample_[1] = p.u, sample_[2] = p.v;
      });
      if (!inside) {  // a table for another image size: nothing is sent from it
        cursor_ = saved_cursor;
        pos_ = saved_pos;
        for (size_t k = 0; k < kScanSampleBytes; ++k) sample_[k] = saved_sample[k];
        return false;
      }
    }
    byte = sample_[in_sample];
    ++pos_;
  }
  return true;
}

}  // namespace bv::protocol
