#include "hal/common/blob_store.h"

#include <cstring>

#include "core/common/bytes.h"
#include "core/common/crc32.h"

namespace bv::hal {
namespace {

constexpr size_t kChunkBytes = 64;  // stack buffer for streamed checks

}  // namespace

bool BlobStore::CheckSlot(int which, uint32_t& generation, uint32_t& length) {
  const int slot = slots_[which];
  const size_t size = storage_.slot_size();
  if (size < kBlobHeaderBytes + kBlobCommitBytes) return false;
  uint8_t rec[kBlobCommitBytes];
  if (!storage_.Read(slot, size - kBlobCommitBytes, rec).ok()) return false;
  ByteReader r(rec);
  const uint32_t magic = r.U32();
  const uint32_t gen = r.U32();
  const uint32_t len = r.U32();
  const uint32_t crc = r.U32();
  if (magic != kBlobCommitMagic || crc != Crc32(std::span<const uint8_t>(rec, 12))) return false;
  if (len < kBlobHeaderBytes || len > size - kBlobCommitBytes) return false;
  // Blob header, then the payload CRC streamed in chunks.
  uint8_t hdr[kBlobHeaderBytes];
  if (!storage_.Read(slot, 0, hdr).ok()) return false;
  ByteReader h(hdr);
  if (h.U32() != kBlobMagic) return false;
  if (h.U16() != static_cast<uint16_t>(kind_)) return false;
  const uint16_t version = h.U16();
  if (version == 0 || version > max_version_) return false;
  const uint32_t payload_len = h.U32();
  const uint32_t payload_crc = h.U32();
  if (payload_len != len - kBlobHeaderBytes) return false;
  uint32_t c = 0;
  uint8_t chunk[kChunkBytes];
  for (size_t off = 0; off < payload_len; off += kChunkBytes) {
    const size_t n = payload_len - off < kChunkBytes ? payload_len - off : kChunkBytes;
    if (!storage_.Read(slot, kBlobHeaderBytes + off, std::span<uint8_t>(chunk, n)).ok()) {
      return false;
    }
    c = Crc32Update(c, std::span<const uint8_t>(chunk, n));
  }
  if (c != payload_crc) return false;
  generation = gen;
  length = len;
  return true;
}

BlobStore::SlotState BlobStore::Scan() {
  SlotState best;
  for (int i = 0; i < 2; ++i) {
    uint32_t gen = 0, len = 0;
    if (!CheckSlot(i, gen, len)) continue;
    // Generations only grow; compare with wrap-around in mind.
    if (best.index < 0 || static_cast<int32_t>(gen - best.generation) > 0) {
      best.index = i;
      best.generation = gen;
      best.length = len;
    }
  }
  return best;
}

Result<size_t> BlobStore::Load(std::span<uint8_t> out) {
  const SlotState s = Scan();
  if (s.index < 0) return Status(StatusCode::kNotFound, "blob store: no valid blob in slot A or B");
  if (s.length > out.size()) {
    return Status(StatusCode::kResourceExhausted, "blob store: output buffer smaller than blob");
  }
  BV_TRY(storage_.Read(slots_[s.index], 0, out.first(s.length)));
  // The slot could change between the check and this read only through a bug; check again.
  BV_TRY(ReadBlob(out.first(s.length), kind_, max_version_).status());
  return static_cast<size_t>(s.length);
}

Status BlobStore::Save(std::span<const uint8_t> blob, std::span<uint8_t> scratch) {
  BV_TRY(ReadBlob(blob, kind_, max_version_).status());
  const size_t size = storage_.slot_size();
  if (blob.size() + kBlobCommitBytes > size) {
    return Status(StatusCode::kResourceExhausted, "blob store: blob larger than a slot");
  }
  if (scratch.size() < blob.size()) {
    return Status(StatusCode::kResourceExhausted, "blob store: scratch smaller than blob");
  }
  const SlotState cur = Scan();
  const int target = cur.index == 0 ? 1 : 0;
  const uint32_t generation = cur.index < 0 ? 1 : cur.generation + 1;
  const int slot = slots_[target];
  BV_TRY(storage_.Erase(slot));
  BV_TRY(storage_.Write(slot, 0, blob));
  // Verify the written bytes before committing.
  BV_TRY(storage_.Read(slot, 0, scratch.first(blob.size())));
  if (std::memcmp(scratch.data(), blob.data(), blob.size()) != 0) {
    return Status(StatusCode::kDataLoss, "blob store: read-back of the new blob differs");
  }
  uint8_t rec[kBlobCommitBytes];
  ByteWriter w(rec);
  w.U32(kBlobCommitMagic);
  w.U32(generation);
  w.U32(static_cast<uint32_t>(blob.size()));
  w.U32(Crc32(std::span<const uint8_t>(rec, 12)));
  BV_TRY(storage_.Write(slot, size - kBlobCommitBytes, rec));
  uint32_t gen = 0, len = 0;
  if (!CheckSlot(target, gen, len) || gen != generation) {
    return Status(StatusCode::kDataLoss, "blob store: committed slot does not verify");
  }
  return Status::Ok();
}

}  // namespace bv::hal
