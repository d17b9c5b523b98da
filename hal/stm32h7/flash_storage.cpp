#include "hal/stm32h7/flash_storage.h"

#include <cstring>

#include "hal/stm32h7/registers.h"

namespace bv::h7 {
namespace {

FlashBankRegs* const kBank = kFlashBank2;

void Unlock() {
  if (kBank->CR & kFlashCrLock) {
    kBank->KEYR = 0x45670123u;
    kBank->KEYR = 0xCDEF89ABu;
  }
}

void Lock() { kBank->CR = kBank->CR | kFlashCrLock; }

Status WaitDone() {
  while (kBank->SR & (kFlashSrQw | kFlashSrBsy)) {
  }
  const uint32_t errors = kBank->SR & kFlashSrErrors;
  kBank->CCR = errors | (1u << 16);  // clear errors and EOP
  if (errors != 0) return Status(StatusCode::kDataLoss, "flash: erase/program error");
  return Status();
}

Status CheckRange(int slot, size_t offset, size_t size) {
  if (slot < 0 || slot >= FlashStorage::kSlots) {
    return Status(StatusCode::kOutOfRange, "flash: no such slot");
  }
  if (offset > FlashStorage::kSlotBytes || size > FlashStorage::kSlotBytes - offset) {
    return Status(StatusCode::kOutOfRange, "flash: range outside the slot");
  }
  return Status();
}

uint8_t* SlotAddress(int slot) {
  return reinterpret_cast<uint8_t*>(FlashStorage::kBank2 +
                                    static_cast<uintptr_t>(FlashStorage::Sector(slot)) *
                                        FlashStorage::kSlotBytes);
}

}  // namespace

Status FlashStorage::DoRead(int slot, size_t offset, std::span<uint8_t> out) {
  BV_TRY(CheckRange(slot, offset, out.size()));
  std::memcpy(out.data(), SlotAddress(slot) + offset, out.size());
  return Status();
}

Status FlashStorage::DoErase(int slot) {
  BV_TRY(CheckRange(slot, 0, kSlotBytes));
  Unlock();
  BV_TRY(WaitDone());
  kBank->CR = kFlashCrSer | kFlashCrPsize64 | (static_cast<uint32_t>(Sector(slot)) << 8);
  kBank->CR = kBank->CR | kFlashCrStart;
  const Status st = WaitDone();
  kBank->CR = kBank->CR & ~kFlashCrSer;
  Lock();
  DcacheInvalidate(SlotAddress(slot), kSlotBytes);  // reads must see the erased bytes
  return st;
}

Status FlashStorage::DoWrite(int slot, size_t offset, std::span<const uint8_t> bytes) {
  BV_TRY(CheckRange(slot, offset, bytes.size()));
  if (offset % kFlashWordBytes != 0) {
    return Status(StatusCode::kInvalidArgument, "flash: write offset not 32-byte aligned");
  }
  Unlock();
  Status st = WaitDone();
  uint8_t* dst = SlotAddress(slot) + offset;
  for (size_t done = 0; st.ok() && done < bytes.size(); done += kFlashWordBytes) {
    alignas(4) uint8_t word[kFlashWordBytes];
    const size_t n = bytes.size() - done < kFlashWordBytes ? bytes.size() - done : kFlashWordBytes;
    std::memset(word, 0xFF, sizeof(word));
    std::memcpy(word, bytes.data() + done, n);
    kBank->CR = kFlashCrPg | kFlashCrPsize64;
    volatile uint32_t* target = reinterpret_cast<volatile uint32_t*>(dst + done);
    const uint32_t* src = reinterpret_cast<const uint32_t*>(word);
    for (size_t i = 0; i < kFlashWordBytes / 4; ++i) target[i] = src[i];
    asm volatile("dsb" ::: "memory");
    st = WaitDone();
    kBank->CR = kBank->CR & ~kFlashCrPg;
  }
  Lock();
  DcacheInvalidate(dst, bytes.size());
  return st;
}

}  // namespace bv::h7
