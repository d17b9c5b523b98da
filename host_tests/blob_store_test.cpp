// hal/common/blob_store: A/B slots survive a power cut at every byte of a write.
#include "hal/common/blob_store.h"

#include <array>
#include <cstring>
#include <vector>

#include <gtest/gtest.h>

#include "core/common/blob.h"

namespace bv::hal {
namespace {

constexpr size_t kSlotBytes = 512;

// Flash-like fake: erase sets 0xFF, programming can only clear bits, and a byte budget
// simulates the power cut (the write stops in the middle, the rest of the call is lost).
class FakeFlash final : public Storage {
 public:
  FakeFlash() {
    for (auto& s : slots_) s.fill(0xFF);
  }
  long budget = -1;  // bytes that may still be programmed; -1 unlimited
  bool dead = false;
  int erases = 0;

 private:
  int DoSlotCount() const override { return 2; }
  size_t DoSlotSize() const override { return kSlotBytes; }
  Status DoRead(int slot, size_t offset, std::span<uint8_t> out) override {
    if (slot < 0 || slot > 1 || offset + out.size() > kSlotBytes) {
      return Status(StatusCode::kOutOfRange, "fake: range");
    }
    std::memcpy(out.data(), slots_[slot].data() + offset, out.size());
    return Status::Ok();
  }
  Status DoErase(int slot) override {
    if (dead) return Status(StatusCode::kUnavailable, "fake: power lost");
    if (slot < 0 || slot > 1) return Status(StatusCode::kOutOfRange, "fake: slot");
    if (budget == 0) {  // power cut during the erase: half erased
      for (size_t i = 0; i < kSlotBytes / 2; ++i) slots_[slot][i] = 0xFF;
      dead = true;
      return Status(StatusCode::kUnavailable, "fake: power lost");
    }
    slots_[slot].fill(0xFF);
    ++erases;
    return Status::Ok();
  }
  Status DoWrite(int slot, size_t offset, std::span<const uint8_t> bytes) override {
    if (dead) return Status(StatusCode::kUnavailable, "fake: power lost");
    if (slot < 0 || slot > 1 || offset + bytes.size() > kSlotBytes) {
      return Status(StatusCode::kOutOfRange, "fake: range");
    }
    for (size_t i = 0; i < bytes.size(); ++i) {
      if (budget == 0) {
        dead = true;
        return Status(StatusCode::kUnavailable, "fake: power lost");
      }
      slots_[slot][offset + i] &= bytes[i];
      if (budget > 0) --budget;
    }
    return Status::Ok();
  }
  std::array<std::array<uint8_t, kSlotBytes>, 2> slots_{};
};

std::vector<uint8_t> MakeBlob(uint8_t fill, size_t payload_bytes) {
  std::vector<uint8_t> payload(payload_bytes);
  for (size_t i = 0; i < payload.size(); ++i) payload[i] = static_cast<uint8_t>(fill + i * 7);
  std::vector<uint8_t> blob(payload_bytes + kBlobHeaderBytes);
  const Result<size_t> n = WriteBlob(BlobKind::kCalibration, 1, payload, blob);
  EXPECT_TRUE(n.ok());
  return blob;
}

std::vector<uint8_t> LoadAll(BlobStore& store) {
  std::vector<uint8_t> out(kSlotBytes);
  const Result<size_t> n = store.Load(out);
  if (!n.ok()) return {};
  out.resize(*n);
  return out;
}

TEST(BlobStore, EmptyStoreHasNothing) {
  FakeFlash flash;
  BlobStore store(flash, 0, 1, BlobKind::kCalibration, 1);
  std::vector<uint8_t> out(kSlotBytes);
  EXPECT_EQ(store.Load(out).status().code(), StatusCode::kNotFound);
  EXPECT_EQ(store.current_generation(), 0u);
}

TEST(BlobStore, SavesAlternateSlotsAndLoadNewest) {
  FakeFlash flash;
  BlobStore store(flash, 0, 1, BlobKind::kCalibration, 1);
  std::vector<uint8_t> scratch(kSlotBytes);
  for (int i = 0; i < 5; ++i) {
    const std::vector<uint8_t> b = MakeBlob(static_cast<uint8_t>(i * 11), 100 + i);
    ASSERT_TRUE(store.Save(b, scratch).ok());
    EXPECT_EQ(LoadAll(store), b);
    EXPECT_EQ(store.current_generation(), static_cast<uint32_t>(i + 1));
  }
}

TEST(BlobStore, RefusesBadInput) {
  FakeFlash flash;
  BlobStore store(flash, 0, 1, BlobKind::kCalibration, 1);
  std::vector<uint8_t> scratch(kSlotBytes);
  std::vector<uint8_t> b = MakeBlob(1, 50);
  b[20] ^= 1;  // CRC broken
  EXPECT_EQ(store.Save(b, scratch).code(), StatusCode::kDataLoss);
  const std::vector<uint8_t> big = MakeBlob(1, kSlotBytes);
  EXPECT_EQ(store.Save(big, scratch).code(), StatusCode::kResourceExhausted);
  const std::vector<uint8_t> ok = MakeBlob(1, 50);
  EXPECT_EQ(store.Save(ok, std::span<uint8_t>(scratch.data(), 10)).code(),
            StatusCode::kResourceExhausted);
  EXPECT_EQ(flash.erases, 0);  // nothing touched
  std::vector<uint8_t> small(10);
  ASSERT_TRUE(store.Save(ok, scratch).ok());
  EXPECT_EQ(store.Load(small).status().code(), StatusCode::kResourceExhausted);
}

// The core property: cut the power after every possible number of programmed bytes (and
// during the erase) of a second write; the first blob must always load, or the new one when
// the write completed.
TEST(BlobStore, PowerCutAtEveryByteKeepsTheLastGoodBlob) {
  const std::vector<uint8_t> first = MakeBlob(3, 200);
  const std::vector<uint8_t> second = MakeBlob(90, 230);
  const long total = static_cast<long>(second.size() + kBlobCommitBytes);
  int survived_old = 0, got_new = 0;
  for (long cut = 0; cut <= total; ++cut) {
    for (int round = 0; round < 2; ++round) {  // round 1: the old blob sits in slot B
      FakeFlash flash;
      BlobStore store(flash, 0, 1, BlobKind::kCalibration, 1);
      std::vector<uint8_t> scratch(kSlotBytes);
      if (round == 1) {
        ASSERT_TRUE(store.Save(MakeBlob(5, 60), scratch).ok());
      }
      ASSERT_TRUE(store.Save(first, scratch).ok());
      flash.budget = cut;
      const Status s = store.Save(second, scratch);
      flash.dead = false;  // power back
      flash.budget = -1;
      BlobStore after(flash, 0, 1, BlobKind::kCalibration, 1);  // fresh boot
      const std::vector<uint8_t> loaded = LoadAll(after);
      if (s.ok()) {
        EXPECT_EQ(loaded, second) << "cut " << cut;
        ++got_new;
      } else {
        EXPECT_EQ(loaded, first) << "cut " << cut << " round " << round;
        ++survived_old;
        // and the store still accepts a new write afterwards
        ASSERT_TRUE(after.Save(second, scratch).ok());
        EXPECT_EQ(LoadAll(after), second);
      }
    }
  }
  EXPECT_EQ(got_new, 2);  // only with the full budget
  EXPECT_EQ(survived_old, 2 * total);
}

}  // namespace
}  // namespace bv::hal
