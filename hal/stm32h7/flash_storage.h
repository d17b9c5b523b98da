#pragma once
// Blob slots in internal flash: bank 2 sectors 4..7 (128 KB each) at 0x08180000 for slots 0-3,
// sectors 2..3 at 0x08140000 for slots 4-5, read through the memory map, erased and programmed
// with the bank-2 register sequences (the code runs from bank 1, so the CPU keeps fetching while
// bank 2 is busy).
#include <cstddef>
#include <cstdint>

#include "hal/storage.h"

namespace bv::h7 {

class FlashStorage : public hal::Storage {
 public:
  static constexpr int kSlots = 6;  // calibration A/B, colour LUT A/B, ball classifier A/B
  static constexpr size_t kSlotBytes = 128 * 1024;
  static constexpr uintptr_t kBank2 = 0x08100000u;
  /// Bank-2 sector of a slot: slots 0-3 in sectors 4-7 (as before the classifier's), 4-5 in 2-3.
  static constexpr int Sector(int slot) { return slot < 4 ? 4 + slot : slot - 2; }
  static constexpr size_t kFlashWordBytes = 32;  // programming unit (256 bits + ECC)

 private:
  int DoSlotCount() const override { return kSlots; }
  size_t DoSlotSize() const override { return kSlotBytes; }
  Status DoRead(int slot, size_t offset, std::span<uint8_t> out) override;
  Status DoErase(int slot) override;
  /// Offsets must be multiples of 32 bytes (one flash word, ECC-protected, programmable once);
  /// a trailing partial word is padded with 0xFF. kInvalidArgument otherwise.
  Status DoWrite(int slot, size_t offset, std::span<const uint8_t> bytes) override;
};

}  // namespace bv::h7
