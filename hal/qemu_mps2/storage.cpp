#include "hal/qemu_mps2/storage.h"

#include <cstring>

namespace bv::qemu {

void RamStorage::Init() {
  for (int s = 0; s < kSlots; ++s) DoErase(s).IgnoreError();
}

Status RamStorage::CheckRange(int slot, size_t offset, size_t size) const {
  if (slot < 0 || slot >= kSlots) return Status(StatusCode::kOutOfRange, "storage: no such slot");
  if (offset > kSlotBytes || size > kSlotBytes - offset) {
    return Status(StatusCode::kOutOfRange, "storage: range outside the slot");
  }
  return Status();
}

Status RamStorage::DoRead(int slot, size_t offset, std::span<uint8_t> out) {
  BV_TRY(CheckRange(slot, offset, out.size()));
  std::memcpy(out.data(), mem_ + static_cast<size_t>(slot) * kSlotBytes + offset, out.size());
  return Status();
}

Status RamStorage::DoErase(int slot) {
  BV_TRY(CheckRange(slot, 0, kSlotBytes));
  std::memset(mem_ + static_cast<size_t>(slot) * kSlotBytes, 0xFF, kSlotBytes);
  return Status();
}

Status RamStorage::DoWrite(int slot, size_t offset, std::span<const uint8_t> bytes) {
  BV_TRY(CheckRange(slot, offset, bytes.size()));
  uint8_t* dst = mem_ + static_cast<size_t>(slot) * kSlotBytes + offset;
  for (size_t i = 0; i < bytes.size(); ++i) {
    // Like NOR flash: programming can only clear bits.
    if ((dst[i] & bytes[i]) != bytes[i]) {
      return Status(StatusCode::kDataLoss, "storage: programming a byte that is not erased");
    }
    dst[i] = bytes[i];
  }
  return Status();
}

}  // namespace bv::qemu
