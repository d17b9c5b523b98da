#pragma once
// Non-blocking byte link to the robot's main computer.
#include <cstddef>
#include <cstdint>
#include <span>

#include "core/common/status.h"

namespace bv::hal {

class Uart {
 public:
  virtual ~Uart() = default;
  /// Queues all of `bytes` or none of them: kUnavailable when the transmit buffer lacks room
  /// (the caller drops and counts the packet; a partial packet would only corrupt the stream).
  Status Write(std::span<const uint8_t> bytes) { return DoWrite(bytes); }
  /// Bytes that Write() would accept right now.
  size_t WriteSpace() const { return DoWriteSpace(); }
  /// Copies up to out.size() received bytes; returns how many (0 when none). Never blocks.
  Result<size_t> Read(std::span<uint8_t> out) { return DoRead(out); }

 private:
  virtual Status DoWrite(std::span<const uint8_t> bytes) = 0;
  virtual size_t DoWriteSpace() const = 0;
  virtual Result<size_t> DoRead(std::span<uint8_t> out) = 0;
};

}  // namespace bv::hal
