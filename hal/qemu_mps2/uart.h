#pragma once
// CMSDK APB UART0 as hal::Uart. Receive: the RX interrupt moves each byte into the shared
// receive ring (hal/cortex_m/uart_rings.h) stamped with the clock, so nothing waits for the
// main loop. Transmit: the shared transmit ring drained by polling (every call drains what the
// hardware accepts), so Write() never blocks and is all-or-nothing.
// The register blocks are template parameters so host tests can drive this exact code against
// a register-level fake (host_tests/uart_rx_test.cpp); the firmware uses CmsdkUart.
#include <cstddef>
#include <cstdint>

#include "hal/clock.h"
#include "hal/cortex_m/uart_rings.h"
#include "hal/qemu_mps2/clock.h"
#include "hal/qemu_mps2/registers.h"
#include "hal/uart.h"

namespace bv::qemu {

template <typename Regs, typename Nvic, typename ClockT>
class CmsdkUartT : public hal::Uart {
 public:
  static constexpr size_t kTxCapacity = 2048;  // > one second of packets at 30 Hz
  static constexpr size_t kRxCapacity = 2048;  // > two upload chunks
  static constexpr size_t kRxFrames = 32;      // stamped frames waiting for the loop

  CmsdkUartT(Regs* regs, Nvic* nvic) : regs_(regs), nvic_(nvic) {}
  /// `clock` stamps arrivals and departures (interrupt-safe ReadUs(), no virtual call).
  void Init(const ClockT* clock) {
    clock_ = clock;
    regs_->BAUDDIV = 16;  // minimum legal divider; QEMU does not model the baud rate
    regs_->CTRL = kUartCtrlTxEn | kUartCtrlRxEn | kUartCtrlRxIntEn;
    cm7::NvicPriority(*nvic_, kIrqUart0Rx, 2);  // above the watchdog tick
    cm7::NvicEnable(*nvic_, kIrqUart0Rx);
  }
  /// UART0 RX interrupt: the one-byte holding register into the ring.
  void OnRxIrq() {
    regs_->INTSTATUS = kUartIntRx;  // before the read: a later byte raises it again
    const uint64_t t_us = clock_->ReadUs();
    while ((regs_->STATE & kUartStateRxFull) != 0) {
      rx_.Push(static_cast<uint8_t>(regs_->DATA), t_us);
      ++rx_arrived_;
    }
    if ((regs_->STATE & kUartStateRxOverrun) != 0) {
      regs_->STATE = kUartStateRxOverrun;
      rx_.CountOverrun();
    }
  }
  /// Moves queued bytes into the hardware while it has room; returns bytes still queued.
  size_t Poll() {
    if (tx_stalled() || tx_.empty()) return tx_.size();
    // QEMU sends a byte the moment DATA is written: its stamp is the write time.
    const uint64_t t_us = clock_->ReadUs();
    while (!tx_.empty() && (regs_->STATE & kUartStateTxFull) == 0) {
      tx_.OnSendStart(1, t_us, 0);
      regs_->DATA = tx_.Contiguous()[0];
      tx_.Consume(1);
      ++bytes_sent_;
    }
    return tx_.size();
  }
  /// Blocks until every queued byte is in the hardware (used only before exit); returns at once
  /// while the transmitter is stalled.
  void Flush() {
    while (Poll() != 0 && !tx_stalled()) {
    }
  }
  uint32_t rx_overruns() const { return rx_.stats().overruns; }
  /// Bytes the main loop is done with: read, or lost (a frame the full ring dropped, an overrun),
  /// as of its last Read(). A test aid holds the replay open on it; counting the lost ones lets a
  /// drop end the hold (the test then fails on the missing replies) instead of hanging it.
  const uint32_t* rx_bytes() const { return &rx_done_; }
  /// Fault injection: once *counter > at the transmitter accepts nothing more, as a line held
  /// by flow control or a hung peer would; the ring fills and Write() refuses packets.
  void StallTxAfter(const uint32_t* counter, uint32_t at) {
    stall_counter_ = counter;
    stall_at_ = at;
  }
  bool tx_stalled() const { return stall_counter_ != nullptr && *stall_counter_ > stall_at_; }
  uint32_t writes_refused() const { return writes_refused_; }
  uint32_t bytes_sent() const { return bytes_sent_; }
  size_t bytes_queued() const { return tx_.size(); }

 private:
  Status DoWrite(std::span<const uint8_t> bytes) override {
    Poll();
    if (!tx_.Push(bytes)) {
      ++writes_refused_;
      return Status(StatusCode::kUnavailable, "uart0: transmit ring full");
    }
    Poll();
    return Status();
  }
  size_t DoWriteSpace() const override { return tx_.space(); }
  Result<size_t> DoRead(std::span<uint8_t> out) override {
    Poll();
    const size_t n = rx_.Read(out);
    {
      cm7::IrqLock lock;
      rx_done_ = rx_arrived_ - static_cast<uint32_t>(rx_.size()) + rx_.stats().overruns;
    }
    return n;
  }
  Result<uint64_t> DoLastRxFrameUs() const override { return rx_.LastFrameUs(); }
  Result<uint64_t> DoLastTxStartUs() const override { return tx_.LastPacketStartUs(); }
  hal::UartRxStats DoRxStats() const override { return rx_.stats(); }

  Regs* regs_;
  Nvic* nvic_;
  const ClockT* clock_ = nullptr;
  cm7::UartTxRing<kTxCapacity> tx_;
  cm7::UartRxRing<kRxCapacity, kRxFrames> rx_;
  uint32_t rx_arrived_ = 0;  // every byte the interrupt took from the hardware
  uint32_t rx_done_ = 0;
  const uint32_t* stall_counter_ = nullptr;
  uint32_t stall_at_ = 0;
  uint32_t writes_refused_ = 0;
  uint32_t bytes_sent_ = 0;
};

using CmsdkUart = CmsdkUartT<CmsdkUartRegs, NvicRegs, DualTimerClock>;

}  // namespace bv::qemu
