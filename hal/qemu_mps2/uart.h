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
  /// Blocks until every queued byte is in the hardware (used only before exit).
  void Flush();
  uint32_t rx_overruns() const { return rx_overruns_; }
  const uint32_t* rx_bytes() const { return &rx_bytes_; }

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
};

}  // namespace bv::qemu
