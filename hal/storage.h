#pragma once
// Non-volatile blob slots (flash sectors on the board, files or RAM on the host). Used in A/B
// pairs so that a write cut by power loss never destroys the last good blob.
#include <cstddef>
#include <cstdint>
#include <span>

#include "core/common/status.h"

namespace bv::hal {

class Storage {
 public:
  virtual ~Storage() = default;
  int slot_count() const { return DoSlotCount(); }
  size_t slot_size() const { return DoSlotSize(); }
  /// Reads `out.size()` bytes at `offset`. Errors: kOutOfRange (slot or range outside storage).
  Status Read(int slot, size_t offset, std::span<uint8_t> out) { return DoRead(slot, offset, out); }
  /// Erases a whole slot (to 0xFF, like flash).
  Status Erase(int slot) { return DoErase(slot); }
  /// Programs bytes into an erased region. Errors: kOutOfRange, kDataLoss (program failed).
  Status Write(int slot, size_t offset, std::span<const uint8_t> bytes) {
    return DoWrite(slot, offset, bytes);
  }

 private:
  virtual int DoSlotCount() const = 0;
  virtual size_t DoSlotSize() const = 0;
  virtual Status DoRead(int slot, size_t offset, std::span<uint8_t> out) = 0;
  virtual Status DoErase(int slot) = 0;
  virtual Status DoWrite(int slot, size_t offset, std::span<const uint8_t> bytes) = 0;
};

}  // namespace bv::hal
