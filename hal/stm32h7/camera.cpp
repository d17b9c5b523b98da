#include "hal/stm32h7/camera.h"

#include "hal/stm32h7/registers.h"
#include "hal/stm32h7/system.h"

namespace bv::h7 {
namespace {
constexpr int kStream = 1;  // DMA2 stream 1 = DMAMUX1 channel 9
constexpr int kDmamuxChannel = 8 + kStream;
}  // namespace

uint32_t DcmiCamera::ChunkAddress(int slot, int chunk) const {
  return reinterpret_cast<uint32_t>(&slots_[slot][static_cast<size_t>(chunk) * kChunkBytes]);
}

int DcmiCamera::FreeSlot() const {
  return slots_held_.Free(pairer_.pending_slot(hal::CameraId::kOmni), write_slot_);
}

void DcmiCamera::Restart() {
  // (Re)arms DCMI + DMA at the start of a fresh slot: used at start and after a sync error.
  kDcmi->CR = kDcmi->CR & ~1u;  // CAPTURE off
  DmaStreamRegs& s = kDma2->S[kStream];
  s.CR = s.CR & ~kDmaCrEn;
  while (s.CR & kDmaCrEn) {
  }
  kDma2->LIFCR = kDmaFlagAll << DmaFlagShift(kStream);
  write_slot_ = FreeSlot();
  chunks_done_ = 0;
  s.M0AR = ChunkAddress(write_slot_, 0);
  s.M1AR = ChunkAddress(write_slot_, 1);
  prog_slot_ = write_slot_;
  prog_chunk_ = 2;
  s.NDTR = static_cast<uint32_t>(kChunkBytes / 4);
  s.CR = (s.CR & ~kDmaCrCt) | kDmaCrEn;
  kDcmi->CR = kDcmi->CR | 1u;  // CAPTURE
}

Status DcmiCamera::DoStart() {
  kRcc->AHB2ENR = kRcc->AHB2ENR | (1u << 0);  // DCMI
  kRcc->AHB1ENR = kRcc->AHB1ENR | (1u << 1);  // DMA2
  (void)kRcc->AHB1ENR;
  kDcmi->CR = 0;
  // Continuous capture, hardware sync, 8-bit data, PIXCLK rising edge, VSYNC active high (the
  // bridge's output polarity), whole frame (no crop).
  kDcmi->CR = (1u << 5) | (1u << 7);
  kDcmi->ICR = 0x1F;
  kDcmi->IER = kDcmiFrame | kDcmiOvr | kDcmiErr | kDcmiVsync;

  DmaStreamRegs& s = kDma2->S[kStream];
  s.CR = 0;
  while (s.CR & kDmaCrEn) {
  }
  kDmamux1->CCR[kDmamuxChannel] = kDmamuxReqDcmi;
  s.PAR = reinterpret_cast<uint32_t>(&kDcmi->DR);
  s.FCR = (1u << 2) | 3u;  // FIFO on (needed for bursts), threshold full
  s.CR = kDmaCrMinc | kDmaCrPsize32 | kDmaCrMsize32 | kDmaCrPlVeryHigh | kDmaCrDbm | kDmaCrTcie |
         kDmaCrTeie | kDmaCrMburst4;
  NvicPriority(kIrqDma2Stream1, 2);
  NvicPriority(kIrqDcmi, 3);
  NvicEnable(kIrqDma2Stream1);
  NvicEnable(kIrqDcmi);
  kDcmi->CR = kDcmi->CR | (1u << 14);  // ENABLE
  started_ = true;
  Restart();
  return Status();
}

void DcmiCamera::OnDmaIrq() {
  const uint32_t flags = (kDma2->LISR >> DmaFlagShift(kStream)) & kDmaFlagAll;
  kDma2->LIFCR = flags << DmaFlagShift(kStream);
  if (flags & kDmaFlagTe) {
    ++errors_;
    Restart();
    return;
  }
  if ((flags & kDmaFlagTc) == 0) return;
  // The DMA has switched to the other memory register; reprogram the idle one two chunks ahead.
  DmaStreamRegs& s = kDma2->S[kStream];
  const uint32_t next = ChunkAddress(prog_slot_, prog_chunk_);
  if (s.CR & kDmaCrCt) {
    s.M0AR = next;  // DMA now on M1: M0 is idle
  } else {
    s.M1AR = next;
  }
  prog_chunk_ = prog_chunk_ + 1;
  if (prog_chunk_ == kChunksPerSlot) {
    prog_chunk_ = 0;
    prog_slot_ = FreeSlot();  // next frame's slot, decided two chunks before it starts
  }
  chunks_done_ = chunks_done_ + 1;
  if (chunks_done_ == kChunksPerSlot) {
    // Both images of the merged frame are complete and were exposed together.
    const uint32_t slot = static_cast<uint32_t>(write_slot_);
    pairer_.OnFrameComplete(hal::CameraId::kOmni, frame_start_us_, sequence_, slot);
    pairer_.OnFrameComplete(hal::CameraId::kPersp, frame_start_us_, sequence_, slot);
    sequence_ = sequence_ + 1;
    chunks_done_ = 0;
    // The next frame's slot was chosen when its first chunk was programmed (prog_chunk_ is
    // now 2 within that slot).
    write_slot_ = prog_slot_;
  }
}

void DcmiCamera::OnDcmiIrq() {
  const uint32_t mis = kDcmi->MIS;
  kDcmi->ICR = mis;
  if (mis & kDcmiVsync) {
    // Frame start. Sensors expose before readout: the timestamp is the readout start, a fixed
    // offset from the exposure that the rig calibration absorbs.
    frame_start_us_ = clock_.NowUs();
    if (chunks_done_ != 0) {
      ++errors_;  // a short frame: resynchronise on a fresh slot
      Restart();
    }
  }
  if (mis & (kDcmiOvr | kDcmiErr)) {
    ++errors_;
    Restart();
  }
}

Status DcmiCamera::DoAcquirePair(hal::FramePair& out) {
  if (!started_) return Status(StatusCode::kUnavailable, "dcmi: not started");
  hal::PairDecision d;
  const uint64_t now = clock_.NowUs();
  const uint32_t primask = IrqSave();
  // A third pair is not handed out: its slot could not be kept from the DMA.
  const bool room = slots_held_.held_count() < kMaxHeldPairs;
  const bool have = room && pairer_.TakePair(now, d);
  if (have) slots_held_.Hold(static_cast<int>(d.slot[0]));
  IrqRestore(primask);
  if (!room) return Status(StatusCode::kResourceExhausted, "dcmi: two pairs held already");
  if (!have) return Status(StatusCode::kUnavailable, "dcmi: no new frame");
  uint8_t* base = slots_[d.slot[0]];
  DcacheInvalidate(base, kSlotBytes);  // the DMA wrote behind the cache
  out = hal::FramePair{};
  out.omni = hal::Frame{base,          kSlotBytes, d.exposure_us[0],
                        d.sequence[0], true,       static_cast<uint32_t>(kMergedStrideBytes)};
  out.persp = hal::Frame{base + kFrameWidth * kYuyvBytesPerPixel,
                         kSlotBytes - kFrameWidth * kYuyvBytesPerPixel,
                         d.exposure_us[1],
                         d.sequence[1],
                         true,
                         static_cast<uint32_t>(kMergedStrideBytes)};
  out.exposure_us = d.exposure_us_pair;
  out.skew_us = d.skew_us;
  out.flags = d.flags;
  out.dropped = d.dropped / 2;  // each merged frame was reported once per camera
  out.slot = d.slot[0];
  return Status();
}

void DcmiCamera::DoRelease(const hal::FramePair& pair) {
  slots_held_.Release(static_cast<int>(pair.slot));
}

}  // namespace bv::h7
