#pragma once
// Blob slots in PSRAM standing in for flash sectors (erase to 0xFF, program erased bytes only).
// The board fills them at boot, through hal::BlobStore, from files named on the command line.
#include <cstddef>
#include <cstdint>

#include "hal/storage.h"

namespace bv::qemu {

class RamStorage : public hal::Storage {
 public:
  static constexpr int kSlots = 6;  // calibration A/B, colour LUT A/B, ball classifier A/B
  static constexpr size_t kSlotBytes = 128 * 1024;

  /// `memory` must hold kSlots * kSlotBytes bytes.
  explicit RamStorage(uint8_t* memory) : mem_(memory) {}
  /// Erases every slot.
  void Init();

 private:
  int DoSlotCount() const override { return kSlots; }
  size_t DoSlotSize() const override { return kSlotBytes; }
  Status DoRead(int slot, size_t offset, std::span<uint8_t> out) override;
  Status DoErase(int slot) override;
  Status DoWrite(int slot, size_t offset, std::span<const uint8_t> bytes) override;
  Status CheckRange(int slot, size_t offset, size_t size) const;

  uint8_t* mem_;
};

}  // namespace bv::qemu
