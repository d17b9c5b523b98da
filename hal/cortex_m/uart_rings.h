#pragma once
// The UART rings both boards share (hal/stm32h7/uart.h, hal/qemu_mps2/uart.h): one single-
// producer / single-consumer ring per direction, free-running indices, power-of-2 capacity.
//  - UartRxRing: filled from the receive interrupt (one byte at a time; the H7 copies its DMA
//    buffer through it), drained by the main loop. COBS-aware: the arrival time of every frame
//    delimiter is kept, and a frame that does not fit is dropped whole (see Push).
//  - UartTxRing: filled by Write() (all or nothing), drained by DMA or polling; stamps when the
//    first byte of the last packet starts on the wire.
// The consumer's Read() runs with interrupts masked (cm7::IrqLock); the producer runs in one
// interrupt priority level only, so it never preempts itself.
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "hal/cortex_m/cortex_m7.h"
#include "hal/uart.h"

namespace bv::cm7 {

template <size_t kCapacity, size_t kMaxFrames>
class UartRxRing {
  static_assert(kCapacity >= 64 && (kCapacity & (kCapacity - 1)) == 0);
  static_assert(kMaxFrames >= 2 && (kMaxFrames & (kMaxFrames - 1)) == 0);

 public:
  /// Producer (receive interrupt): one byte that finished arriving at `t_us`. A zero byte ends
  /// a frame and is stamped. When the ring (or the stamp table) is full, the frame being
  /// received is dropped whole and the input is skipped up to the next delimiter: complete
  /// frames already queued stay intact, the next frame resyncs, nothing ever blocks.
  void Push(uint8_t byte, uint64_t t_us) {
    if (skipping_) {
      if (byte != 0) return;
      skipping_ = false;
      if (!terminate_) return;  // the dropped frame left nothing behind for the reader
      terminate_ = false;       // the reader holds its start: end it (its decoder rejects it)
    } else if (byte == 0 && head_ == frame_start_) {
      return;  // an empty frame (repeated delimiter, noise): nothing to deliver or stamp
    }
    const bool no_room = head_ - tail_ == kCapacity;
    if (byte == 0) {
      if (no_room || frames_head_ - frames_tail_ == kMaxFrames) {
        DropFrame(/*at_delimiter=*/true);
        if (!terminate_) return;
        terminate_ = false;  // the rewind made room for the terminating delimiter
      }
      Frame& f = frames_[frames_head_ & (kMaxFrames - 1)];
      f.end = head_;
      f.t_us = t_us;
      frames_head_ = frames_head_ + 1;
      buf_[head_ & (kCapacity - 1)] = 0;
      head_ = head_ + 1;
      frame_start_ = head_;
      return;
    }
    if (no_room) {
      DropFrame(/*at_delimiter=*/false);
      return;
    }
    buf_[head_ & (kCapacity - 1)] = byte;
    head_ = head_ + 1;
  }
  void CountOverrun() { ++stats_.overruns; }
  void CountLineError() { ++stats_.line_errors; }

  /// Consumer: copies bytes up to and including the next delimiter. Interrupts are masked
  /// while it runs (at most out.size() byte copies).
  size_t Read(std::span<uint8_t> out) {
    IrqLock lock;
    size_t n = 0;
    while (n < out.size() && tail_ != head_) {
      const uint8_t b = buf_[tail_ & (kCapacity - 1)];
      out[n++] = b;
      tail_ = tail_ + 1;
      if (b != 0) continue;
      // Every stored delimiter has a stamp, in order.
      const Frame& f = frames_[frames_tail_ & (kMaxFrames - 1)];
      if (frames_tail_ != frames_head_ && f.end == tail_ - 1) {
        last_frame_us_ = f.t_us;
        have_frame_ = true;
        frames_tail_ = frames_tail_ + 1;
      }
      break;
    }
    return n;
  }
  Result<uint64_t> LastFrameUs() const {
    if (!have_frame_) return Status(StatusCode::kUnavailable, "uart: no frame received yet");
    return last_frame_us_;
  }
  hal::UartRxStats stats() const {
    IrqLock lock;
    return stats_;
  }
  size_t size() const { return head_ - tail_; }

 private:
  struct Frame {
    size_t end;  // free-running index of the delimiter
    uint64_t t_us;
  };

  // Rewinds over the frame in progress (it is the only partial frame) and, unless its
  // delimiter is the byte at hand, skips input to the next one.
  void DropFrame(bool at_delimiter) {
    ++stats_.ring_full;
    const size_t unread = head_ - tail_;
    const size_t partial = head_ - frame_start_;
    // The reader already took the start of this frame: rewind to what it has read and
    // deliver a bare delimiter so its decoder ends (and rejects) that stub.
    terminate_ = partial > unread;
    head_ = terminate_ ? tail_ : frame_start_;
    skipping_ = !at_delimiter;
  }

  std::array<uint8_t, kCapacity> buf_{};
  std::array<Frame, kMaxFrames> frames_{};
  volatile size_t head_ = 0;  // producer
  volatile size_t tail_ = 0;  // consumer
  size_t frame_start_ = 0;    // producer: first index of the frame in progress
  volatile size_t frames_head_ = 0;
  volatile size_t frames_tail_ = 0;
  bool skipping_ = false;
  bool terminate_ = false;
  uint64_t last_frame_us_ = 0;
  bool have_frame_ = false;
  hal::UartRxStats stats_;
};

template <size_t kCapacity>
class UartTxRing {
  static_assert(kCapacity >= 64 && (kCapacity & (kCapacity - 1)) == 0);

 public:
  /// All of `bytes` or nothing (false: no room). Callers that share the ring with an interrupt
  /// mask it around the call.
  bool Push(std::span<const uint8_t> bytes) {
    if (bytes.size() > space()) return false;
    size_t h = head_;
    for (uint8_t b : bytes) buf_[h++ & (kCapacity - 1)] = b;
    packet_start_ = head_;
    packet_pending_ = !bytes.empty();
    head_ = h;
    return true;
  }
  size_t space() const { return kCapacity - (head_ - tail_); }
  size_t size() const { return head_ - tail_; }
  bool empty() const { return head_ == tail_; }
  /// Queued bytes that are contiguous in memory from the oldest one (for one DMA transfer).
  std::span<const uint8_t> Contiguous() const {
    const size_t start = tail_ & (kCapacity - 1);
    size_t n = head_ - tail_;
    if (n > kCapacity - start) n = kCapacity - start;
    return {&buf_[start], n};
  }
  /// The `n` oldest bytes start leaving at `t_us`, one every `byte_ns`: stamps the last packet
  /// if its first byte is among them. Then call Consume(n) once they are gone.
  void OnSendStart(size_t n, uint64_t t_us, uint32_t byte_ns) {
    const size_t offset = packet_start_ - tail_;
    if (!packet_pending_ || offset >= n) return;
    packet_pending_ = false;
    tx_start_us_ = t_us + (uint64_t{offset} * byte_ns + 500) / 1000;
    have_tx_start_ = true;
  }
  void Consume(size_t n) { tail_ = tail_ + n; }
  Result<uint64_t> LastPacketStartUs() const {
    if (packet_pending_) return Status(StatusCode::kUnavailable, "uart: packet still queued");
    if (!have_tx_start_) return Status(StatusCode::kUnavailable, "uart: nothing sent yet");
    return tx_start_us_;
  }
  const uint8_t* data() const { return buf_.data(); }

 private:
  alignas(32) std::array<uint8_t, kCapacity> buf_{};
  volatile size_t head_ = 0;  // free-running
  volatile size_t tail_ = 0;
  size_t packet_start_ = 0;  // first byte of the last Push()
  volatile bool packet_pending_ = false;
  uint64_t tx_start_us_ = 0;
  bool have_tx_start_ = false;
};

}  // namespace bv::cm7
