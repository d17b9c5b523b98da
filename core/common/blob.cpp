#include "core/common/blob.h"

#include "core/common/bytes.h"
#include "core/common/crc32.h"

namespace bv {

Result<size_t> WriteBlob(BlobKind kind, uint16_t version, std::span<const uint8_t> payload,
                         std::span<uint8_t> out) {
  ByteWriter w(out);
  w.U32(kBlobMagic);
  w.U16(static_cast<uint16_t>(kind));
  w.U16(version);
  w.U32(static_cast<uint32_t>(payload.size()));
  w.U32(Crc32(payload));
  w.Bytes(payload);
  if (!w.ok()) return Status(StatusCode::kResourceExhausted, "blob: output buffer too small");
  return w.size();
}

Result<BlobView> ReadBlob(std::span<const uint8_t> blob, BlobKind expected, uint16_t max_version) {
  if (blob.size() < kBlobHeaderBytes) {
    return Status(StatusCode::kDataLoss, "blob: shorter than its 16-byte header");
  }
  ByteReader r(blob);
  if (r.U32() != kBlobMagic) return Status(StatusCode::kDataLoss, "blob: bad magic (not BVB1)");
  const auto kind = static_cast<BlobKind>(r.U16());
  const uint16_t version = r.U16();
  const uint32_t len = r.U32();
  const uint32_t crc = r.U32();
  if (kind != expected) return Status(StatusCode::kInvalidArgument, "blob: wrong kind");
  if (version == 0 || version > max_version) {
    return Status(StatusCode::kUnimplemented, "blob: unsupported version");
  }
  if (len > r.remaining()) return Status(StatusCode::kDataLoss, "blob: payload truncated");
  if (len < r.remaining()) return Status(StatusCode::kDataLoss, "blob: trailing bytes after payload");
  std::span<const uint8_t> payload = r.Take(len);
  if (Crc32(payload) != crc) return Status(StatusCode::kDataLoss, "blob: CRC-32 mismatch");
  return BlobView{kind, version, payload};
}

}  // namespace bv
