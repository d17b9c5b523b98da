#pragma once
// USART1 as hal::Uart: a TX ring in AXI SRAM drained by DMA1 stream 0 (request via DMAMUX1),
// restarted from the transfer-complete interrupt. Write() is all-or-nothing and never blocks.
#include <array>
#include <cstddef>
#include <cstdint>

#include "hal/uart.h"

namespace bv::h7 {

class DmaUart : public hal::Uart {
 public:
  static constexpr size_t kTxCapacity = 2048;
  static_assert((kTxCapacity & (kTxCapacity - 1)) == 0);
  static constexpr uint32_t kBaud = 921600;

  void Init();
  /// Transfer-complete interrupt of the TX stream.
  void OnDmaIrq();
  /// Blocks until the ring is empty (before a reset only).
  void Flush();

 private:
  Status DoWrite(std::span<const uint8_t> bytes) override;
  size_t DoWriteSpace() const override;
  Result<size_t> DoRead(std::span<uint8_t> out) override;
  void KickLocked();  // starts the next DMA chunk if idle; IRQs masked by the caller

  alignas(32) std::array<uint8_t, kTxCapacity> tx_{};
  volatile size_t head_ = 0;  // free-running
  volatile size_t tail_ = 0;
  volatile size_t in_flight_ = 0;  // bytes of the running DMA transfer
};

}  // namespace bv::h7
