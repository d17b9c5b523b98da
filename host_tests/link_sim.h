#pragma once
// A simulated link for the firmware main loop on the host (capture_loop_test, bench_link_rates):
// a clock set by hand, a camera that delivers 30 Hz pairs into two DMA slots per camera and
// never overwrites a held slot, and a 2 KB TX ring emptied at 921600 Bd of simulated time.

#include <algorithm>
#include <cstring>
#include <vector>

#include "core/calibration/calibration.h"
#include "core/common/image.h"
#include "hal/camera.h"
#include "hal/clock.h"
#include "hal/common/blob_store.h"
#include "hal/storage.h"
#include "hal/uart.h"

namespace bv::fw::sim {

inline constexpr double kBytesPerUs = 92160.0 / 1e6;  // 921600 Bd, 8N1
inline constexpr uint64_t kPeriodUs = 33333;

class SimClock : public hal::Clock {
 public:
  uint64_t now = 1000;

 private:
  uint64_t DoNowUs() const override { return now; }
};

// What a pixel of pair p, camera c holds: distinct for every byte, pair and camera.
inline uint8_t PatternByte(uint32_t pair, int camera, size_t i) {
  return static_cast<uint8_t>(((i + 7 * pair + 131 * camera) * 2654435761u) >> 11);
}

class SimCamera : public hal::Camera {
 public:
  explicit SimCamera(const SimClock& clock, uint32_t pairs) : clock_(clock), pairs_(pairs) {
    for (auto& cam : slots_) {
      for (auto& s : cam) s.resize(kFrameBytes);
    }
  }
  int max_held = 0;
  uint32_t frames_lost = 0;  // no free slot when a frame was due
  uint32_t served = 0;

  // "DMA": frames due by now land in a slot that is neither held nor holding the unserved one.
  void Tick() {
    while (next_ < pairs_ && 1000 + uint64_t{next_} * kPeriodUs <= clock_.now) {
      int slot = -1;
      for (int s = 0; s < 2; ++s) {
        if (!held_[s] && s != ready_slot_) slot = s;
      }
      if (slot < 0 && ready_slot_ >= 0 && !held_[ready_slot_]) slot = ready_slot_;  // overwrite
      if (slot < 0) {
        ++frames_lost;
      } else {
        for (int c = 0; c < 2; ++c) {
          for (size_t i = 0; i < kFrameBytes; ++i) slots_[c][slot][i] = PatternByte(next_, c, i);
        }
        ready_slot_ = slot;
        ready_pair_ = next_;
      }
      ++next_;
    }
  }

 private:
  Status DoStart() override { return Status(); }
  Status DoAcquirePair(hal::FramePair& out) override {
    Tick();
    if (ready_slot_ < 0) return Status(StatusCode::kUnavailable, "none");
    const int s = ready_slot_;
    ready_slot_ = -1;
    held_[s] = true;
    max_held = std::max(max_held, held_[0] + held_[1] + 0);
    const uint64_t t = 1000 + uint64_t{ready_pair_} * kPeriodUs;
    out = hal::FramePair{};
    out.omni = {slots_[0][s].data(), kFrameBytes, t, ready_pair_, true};
    out.persp = {slots_[1][s].data(), kFrameBytes, t, ready_pair_, true};
    out.exposure_us = t;
    out.slot = static_cast<uint32_t>(s);
    ++served;
    return Status();
  }
  void DoRelease(const hal::FramePair& pair) override { held_[pair.slot] = false; }
  bool DoFinished() const override { return next_ >= pairs_ && ready_slot_ < 0; }
  int DoMaxHeldPairs() const override { return 2; }

  const SimClock& clock_;
  uint32_t pairs_;
  uint32_t next_ = 0;
  std::vector<uint8_t> slots_[2][2];
  bool held_[2] = {false, false};
  int ready_slot_ = -1;
  uint32_t ready_pair_ = 0;
};

// A 2 KB TX ring emptied at 921600 Bd of simulated time; what left is kept with the time its
// last byte left.
class PacedUart : public hal::Uart {
 public:
  static constexpr size_t kRing = 2048;
  std::vector<uint8_t> wire;
  std::vector<uint64_t> wire_done_us;  // per wire byte
  uint64_t rx_stamp_us = 0;
  bool have_rx_stamp = false;

  void Advance(uint64_t now_us) {
    credit_ += static_cast<double>(now_us - last_us_) * kBytesPerUs;
    last_us_ = now_us;
    while (credit_ >= 1.0 && !queue_.empty()) {
      wire.push_back(queue_.front());
      wire_done_us.push_back(now_us);
      queue_.erase(queue_.begin());
      credit_ -= 1.0;
    }
    if (queue_.empty()) credit_ = 0;
  }
  void Feed(std::span<const uint8_t> b, uint64_t stamp_us) {
    rx_.insert(rx_.end(), b.begin(), b.end());
    rx_stamp_us = stamp_us;
  }

 private:
  Status DoWrite(std::span<const uint8_t> b) override {
    if (b.size() > kRing - queue_.size()) return Status(StatusCode::kUnavailable, "full");
    queue_.insert(queue_.end(), b.begin(), b.end());
    return Status();
  }
  size_t DoWriteSpace() const override { return kRing - queue_.size(); }
  Result<size_t> DoRead(std::span<uint8_t> out) override {
    size_t n = 0;
    while (n < out.size() && !rx_.empty()) {
      const uint8_t b = rx_.front();
      rx_.erase(rx_.begin());
      out[n++] = b;
      if (b == 0) {
        have_rx_stamp = true;
        break;
      }
    }
    return n;
  }
  Result<uint64_t> DoLastRxFrameUs() const override {
    if (!have_rx_stamp) return Status(StatusCode::kUnavailable, "none");
    return rx_stamp_us;
  }

  std::vector<uint8_t> queue_;
  std::vector<uint8_t> rx_;
  double credit_ = 0;
  uint64_t last_us_ = 1000;
};

class NoStorage : public hal::Storage {
  int DoSlotCount() const override { return 4; }
  size_t DoSlotSize() const override { return 1024; }
  Status DoRead(int, size_t, std::span<uint8_t> out) override {
    std::memset(out.data(), 0xFF, out.size());
    return Status();
  }
  Status DoErase(int) override { return Status(); }
  Status DoWrite(int, size_t, std::span<const uint8_t>) override { return Status(); }
};

// Storage that keeps what is written (4 slots of 80 KB), for a loop that boots with a
// calibration.
class MemStorage : public hal::Storage {
 public:
  static constexpr int kSlots = 4;
  static constexpr size_t kSlotBytes = 80 * 1024;
  MemStorage() : mem_(kSlots * kSlotBytes, 0xFF) {}
  void Put(int slot, std::span<const uint8_t> bytes) {
    std::memcpy(mem_.data() + slot * kSlotBytes, bytes.data(), bytes.size());
  }

 private:
  int DoSlotCount() const override { return kSlots; }
  size_t DoSlotSize() const override { return kSlotBytes; }
  Status DoRead(int slot, size_t offset, std::span<uint8_t> out) override {
    if (slot < 0 || slot >= kSlots || offset + out.size() > kSlotBytes) {
      return Status(StatusCode::kOutOfRange, "range");
    }
    std::memcpy(out.data(), mem_.data() + slot * kSlotBytes + offset, out.size());
    return Status();
  }
  Status DoErase(int slot) override {
    std::memset(mem_.data() + slot * kSlotBytes, 0xFF, kSlotBytes);
    return Status();
  }
  Status DoWrite(int slot, size_t offset, std::span<const uint8_t> b) override {
    std::memcpy(mem_.data() + slot * kSlotBytes + offset, b.data(), b.size());
    return Status();
  }
  std::vector<uint8_t> mem_;
};

/// Stores `cal` in calibration slots 0 / 1 as an upload would (the loop then boots with it and
/// builds the colour table from the built-in model). False on failure.
inline bool InstallCalibration(hal::Storage& storage, const RigCalibration& cal,
                               std::span<uint8_t> scratch) {
  std::vector<uint8_t> blob(kCalibrationBlobMaxBytes);
  const Result<size_t> n = SerializeCalibration(cal, blob);
  if (!n.ok()) return false;
  hal::BlobStore store(storage, 0, 1, BlobKind::kCalibration, kCalibrationBlobVersion);
  return store.Save(std::span<const uint8_t>(blob.data(), *n), scratch).ok();
}

}  // namespace bv::fw::sim
