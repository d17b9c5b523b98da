#pragma once
// CMSDK APB UART0 as hal::Uart: a software TX ring drained by polling (every call drains what
// the hardware accepts), so Write() never blocks and is all-or-nothing.
#include <array>
#include <cstddef>
#include <cstdint>

#include "hal/qemu_mps2/registers.h"
#include "hal/uart.h"

namespace bv::qemu {

class CmsdkUart : public hal::Uart {
 public:
  static constexpr size_t kTxCapacity = 2048;  // > one second of packets at 30 Hz
  static_assert((kTxCapacity & (kTxCapacity - 1)) == 0, "ring index masking needs a power of 2");

  explicit CmsdkUart(CmsdkUartRegs* regs) : regs_(regs) {}
  void Init();
  /// Moves queued bytes into the hardware while it has room; returns bytes still queued.
  size_t Poll();
  /// Blocks until every queued byte is in the hardware (used only before exit); returns at once
  /// while the transmitter is stalled.
  void Flush();
  uint32_t rx_overruns() const { return rx_overruns_; }
  const uint32_t* rx_bytes() const { return &rx_bytes_; }
  /// Fault injection: once *counter > at the transmitter accepts nothing more, as a line held
  /// by flow control or a hung peer would; the ring fills and Write() refuses packets.
  void StallTxAfter(const uint32_t* counter, uint32_t at) {
    stall_counter_ = counter;
    stall_at_ = at;
  }
  bool tx_stalled() const { return stall_counter_ != nullptr && *stall_counter_ > stall_at_; }
  uint32_t writes_refused() const { return writes_refused_; }
  uint32_t bytes_sent() const { return bytes_sent_; }
  size_t bytes_queued() const { return head_ - tail_; }

 private:
  Status DoWrite(std::span<const uint8_t> bytes) override;
  size_t DoWriteSpace() const override;
  Result<size_t> DoRead(std::span<uint8_t> out) override;

  CmsdkUartRegs* regs_;
  std::array<uint8_t, kTxCapacity> tx_{};
  size_t head_ = 0;  // next byte to write into the ring (free-running)
  size_t tail_ = 0;  // next byte to send (free-running)
  uint32_t rx_overruns_ = 0;
  uint32_t rx_bytes_ = 0;
  const uint32_t* stall_counter_ = nullptr;
  uint32_t stall_at_ = 0;
  uint32_t writes_refused_ = 0;
  uint32_t bytes_sent_ = 0;
};

}  // namespace bv::qemu
