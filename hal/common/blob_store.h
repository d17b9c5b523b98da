#pragma once
// Power-safe A/B store for one blob kind (calibration, LUT) over two hal::Storage slots.
//
// Slot layout: [blob bytes (BVB1 header + payload, core/common/blob.h)] ... [commit record]
// The commit record (16 bytes at the end of the slot: magic "BVCM", generation u32, blob length
// u32, CRC-32 of the first 12 bytes) is programmed only after the blob was written AND read
// back and verified. A slot counts only if its commit record and its blob both check out; the
// valid slot with the higher generation is current. A write always goes to the other slot, so a
// power cut at any byte leaves the last good blob untouched.
//
// No heap, no exceptions: works from a caller-provided scratch buffer.
#include <cstddef>
#include <cstdint>
#include <span>

#include "core/common/blob.h"
#include "core/common/status.h"
#include "hal/storage.h"

namespace bv::hal {

inline constexpr size_t kBlobCommitBytes = 16;
inline constexpr uint32_t kBlobCommitMagic = 0x4D434256u;  // "BVCM" little endian

class BlobStore {
 public:
  /// Uses slots `slot_a` and `slot_b` of `storage` for blobs of `kind` up to `max_version`.
  BlobStore(Storage& storage, int slot_a, int slot_b, BlobKind kind, uint16_t max_version)
      : storage_(storage), slots_{slot_a, slot_b}, kind_(kind), max_version_(max_version) {}

  /// Loads the newest valid blob into `out` (whole blob, header included).
  /// Errors: kNotFound (no valid slot), kResourceExhausted (`out` too small), storage errors.
  Result<size_t> Load(std::span<uint8_t> out);

  /// Writes `blob` (a complete BVB1 blob of this store's kind; checked first) into the slot
  /// that is not current, verifies it by reading back through `scratch` (>= blob size), then
  /// commits it. Errors: kInvalidArgument (not a valid blob of this kind), kResourceExhausted
  /// (blob + commit record larger than a slot, or scratch too small), kDataLoss (read-back
  /// mismatch), storage errors. On any error the previous blob stays current.
  Status Save(std::span<const uint8_t> blob, std::span<uint8_t> scratch);

  /// Generation of the current blob (0 if none). Increases with every successful Save.
  uint32_t current_generation() { return Scan().generation; }

 private:
  struct SlotState {
    int index = -1;  // 0 or 1 into slots_, -1: none valid
    uint32_t generation = 0;
    uint32_t length = 0;
  };
  // Checks a slot's commit record and blob (streamed CRC, no buffer needed).
  bool CheckSlot(int which, uint32_t& generation, uint32_t& length);
  SlotState Scan();

  Storage& storage_;
  int slots_[2];
  BlobKind kind_;
  uint16_t max_version_;
};

}  // namespace bv::hal
