#pragma once
// Two cameras through the one DCMI of the STM32H743: a small bridge (see README.md) merges the
// two FSIN-synchronised sensors line by line into one 1280x480 YUYV stream, so both images of
// a pair are exposed together and land in the same DMA slot; each image is then that slot with
// a 2560-byte stride (hal::Frame::stride_bytes). DMA2 stream 1 runs in double-buffer mode over
// 5 chunks per slot (a frame exceeds one DMA transfer's 65535 words); 5 slots in SDRAM (6 MB
// of its 32), so the DMA always has a slot that is neither held by the loop (up to two pairs:
// a capture streams one while the pipeline takes the next) nor waiting to be acquired
// (slot_book.h).
#include <cstdint>

#include "core/common/image.h"
#include "hal/camera.h"
#include "hal/clock.h"
#include "hal/common/frame_pairer.h"
#include "hal/stm32h7/slot_book.h"

namespace bv::h7 {

inline constexpr size_t kMergedStrideBytes = 2 * kFrameWidth * kYuyvBytesPerPixel;  // 2560
inline constexpr size_t kSlotBytes = kMergedStrideBytes * kFrameHeight;             // 1228800
inline constexpr int kMaxHeldPairs = 2;
inline constexpr int kCaptureSlots = kMaxHeldPairs + 3;
inline constexpr int kChunksPerSlot = 5;
inline constexpr size_t kChunkBytes = kSlotBytes / kChunksPerSlot;
static_assert(kSlotBytes % (kChunksPerSlot * 4) == 0, "chunks must be whole 32-bit words");
static_assert(kChunkBytes / 4 <= 65535, "a chunk must fit one DMA transfer (NDTR)");
using CaptureSlots = uint8_t[kCaptureSlots][kSlotBytes];

class DcmiCamera : public hal::Camera {
 public:
  DcmiCamera(CaptureSlots& slots, const hal::Clock& clock, const hal::PairerConfig& pairer)
      : slots_(slots), clock_(clock), pairer_(pairer) {}
  // Interrupt entry points.
  void OnDmaIrq();
  void OnDcmiIrq();

 private:
  Status DoStart() override;
  Status DoAcquirePair(hal::FramePair& out) override;
  void DoRelease(const hal::FramePair& pair) override;
  /// Frames lost to DCMI overrun / sync errors.
  uint32_t DoBadInputCount() const override { return errors_; }
  int DoMaxHeldPairs() const override { return kMaxHeldPairs; }

  int FreeSlot() const;
  uint32_t ChunkAddress(int slot, int chunk) const;
  void Restart();

  CaptureSlots& slots_;
  const hal::Clock& clock_;
  hal::FramePairer pairer_;
  // Shared with the interrupts.
  volatile int write_slot_ = 0;   // slot of the frame being captured
  volatile int chunks_done_ = 0;  // chunks of that frame completed
  volatile int prog_slot_ = 0;    // (slot, chunk) to program into the next idle register
  volatile int prog_chunk_ = 0;
  SlotBook<kCaptureSlots, kMaxHeldPairs> slots_held_;  // handed out to the main loop
  volatile uint64_t frame_start_us_ = 0;
  volatile uint32_t sequence_ = 0;
  uint32_t errors_ = 0;  // written by interrupts only (read through a call: never cached)
  volatile bool started_ = false;
};

}  // namespace bv::h7
