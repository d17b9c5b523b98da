#pragma once
// Non-blocking byte link to the robot's main computer.
#include <cstddef>
#include <cstdint>
#include <span>

#include "core/common/status.h"

namespace bv::hal {

/// Receive-side losses since boot (reported in the status packet).
struct UartRxStats {
  uint32_t overruns = 0;     // bytes the hardware lost before the driver took them
  uint32_t ring_full = 0;    // frames dropped because the receive ring had no room
  uint32_t line_errors = 0;  // framing / noise / parity errors (a line break is one)
};

class Uart {
 public:
  virtual ~Uart() = default;
  /// Queues all of `bytes` or none of them: kUnavailable when the transmit buffer lacks room
  /// (the caller drops and counts the packet; a partial packet would only corrupt the stream).
  Status Write(std::span<const uint8_t> bytes) { return DoWrite(bytes); }
  /// Bytes that Write() would accept right now.
  size_t WriteSpace() const { return DoWriteSpace(); }
  /// Copies up to out.size() received bytes; returns how many (0 when none). Never blocks.
  /// Stops after a frame delimiter (0x00), so LastRxFrameUs() belongs to the frame it ends.
  Result<size_t> Read(std::span<uint8_t> out) { return DoRead(out); }
  /// Clock µs at which the delimiter of the last frame returned by Read() arrived, stamped in
  /// the receive interrupt (for clock sync). kUnavailable before the first frame,
  /// kUnimplemented where the board cannot stamp arrivals.
  Result<uint64_t> LastRxFrameUs() const { return DoLastRxFrameUs(); }
  /// Clock µs at which the first byte of the last successful Write() started on the wire (see
  /// the board driver for its bound). kUnavailable while that byte is still queued.
  Result<uint64_t> LastTxStartUs() const { return DoLastTxStartUs(); }
  UartRxStats RxStats() const { return DoRxStats(); }

 private:
  virtual Status DoWrite(std::span<const uint8_t> bytes) = 0;
  virtual size_t DoWriteSpace() const = 0;
  virtual Result<size_t> DoRead(std::span<uint8_t> out) = 0;
  virtual Result<uint64_t> DoLastRxFrameUs() const {
    return Status(StatusCode::kUnimplemented, "uart: no arrival timestamps");
  }
  virtual Result<uint64_t> DoLastTxStartUs() const {
    return Status(StatusCode::kUnimplemented, "uart: no transmit timestamps");
  }
  virtual UartRxStats DoRxStats() const { return UartRxStats(); }
};

}  // namespace bv::hal
