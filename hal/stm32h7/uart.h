#pragma once
// USART1 as hal::Uart, 921600 Bd, no CPU per byte in either direction.
//  Transmit: the shared transmit ring (hal/cortex_m/uart_rings.h) drained by DMA1 stream 0
//    (DMAMUX request 42), restarted from the transfer-complete interrupt. Write() is
//    all-or-nothing and never blocks.
//  Receive: DMA1 stream 1 (request 41) writes a small circular buffer without the CPU; its
//    half/full interrupts and the USART idle-line interrupt copy the new bytes into the shared
//    receive ring, so a short command is seen one character after its last byte and nothing
//    is lost while the main loop processes a frame (the buffer holds 64 characters = 694 us of
//    interrupt latency).
// Timestamps (clock µs), see docs/protocol.md "Receive path and timing":
//  - a frame's delimiter: interrupt time - (bytes after it in the batch + 1 if the batch ended
//    on an idle line) x 10.85 us. Exact to the interrupt latency when the delimiter ends a
//    burst; later by at most the gaps between the bytes after it (each < 1 character, else the
//    idle interrupt would have ended the batch).
//  - a packet's first byte: when its DMA chunk starts + its offset in the chunk x 10.85 us;
//    the byte starts within 2 characters after that stamp (the USART may still be shifting
//    out the previous chunk's last bytes).
// The peripherals come in through `Ports` (pointers to register blocks), so host tests run this
// exact code against a register-level fake (host_tests/uart_rx_test.cpp). The clock type is a
// parameter too: the interrupt handlers read it without a virtual call (ClockT::ReadUs()).
#include <array>
#include <cstddef>
#include <cstdint>

#include "hal/clock.h"
#include "hal/cortex_m/uart_rings.h"
#include "hal/stm32h7/clock.h"
#include "hal/stm32h7/registers.h"
#include "hal/stm32h7/system.h"
#include "hal/uart.h"

namespace bv::h7 {

/// The board's real peripherals.
struct Usart1Ports {
  UsartRegs* usart = kUsart1;
  DmaRegs* dma = kDma1;
  DmamuxRegs* dmamux = kDmamux1;
  RccRegs* rcc = kRcc;
  NvicRegs* nvic = kNvic;
};

template <typename Ports, typename ClockT>
class DmaUartT : public hal::Uart {
 public:
  static constexpr size_t kTxCapacity = 2048;
  static constexpr size_t kRxCapacity = 2048;  // > two upload chunks
  static constexpr size_t kRxFrames = 32;      // stamped frames waiting for the loop
  static constexpr size_t kRxDmaBytes = 64;    // circular; an interrupt every 32 characters
  static_assert((kRxDmaBytes & (kRxDmaBytes - 1)) == 0 && kRxDmaBytes % kCacheLine == 0);
  static constexpr uint32_t kBaud = 921600;
  static constexpr uint32_t kCharNs = 10 * 1000000000ull / kBaud;  // 8N1: 10 bits
  static constexpr int kTxStream = 0;  // DMA1 stream n = DMAMUX1 channel n
  static constexpr int kRxStream = 1;
  static constexpr uint8_t kIrqPriority = 4;  // below the camera's 2/3: those are short

  explicit DmaUartT(const Ports& hw = Ports()) : hw_(hw) {}
  /// `clock` stamps arrivals and departures (interrupt-safe ReadUs(), no virtual call).
  void Init(const ClockT* clock);
  /// DMA1 stream 0 interrupt: a transmit chunk is done.
  void OnTxDmaIrq();
  /// DMA1 stream 1 interrupt: the receive buffer is half or completely filled.
  void OnRxDmaIrq();
  /// USART1 interrupt: idle line after reception, overrun, framing / noise / parity error.
  void OnUsartIrq();
  /// Blocks until the transmit ring is empty (before a reset only).
  void Flush() {
    while (!tx_.empty()) {
    }
  }
  const uint8_t* rx_dma_buffer() const { return rx_dma_.data(); }
  const uint8_t* tx_ring_data() const { return tx_.data(); }

 private:
  Status DoWrite(std::span<const uint8_t> bytes) override;
  size_t DoWriteSpace() const override { return tx_.space(); }
  Result<size_t> DoRead(std::span<uint8_t> out) override { return rx_.Read(out); }
  Result<uint64_t> DoLastRxFrameUs() const override { return rx_.LastFrameUs(); }
  Result<uint64_t> DoLastTxStartUs() const override {
    IrqLock lock;
    return tx_.LastPacketStartUs();
  }
  hal::UartRxStats DoRxStats() const override { return rx_.stats(); }
  void KickLocked();  // starts the next DMA chunk if idle; IRQs masked by the caller
  void StartRxStream();
  void DrainRxDma(bool idle);

  Ports hw_;
  const ClockT* clock_ = nullptr;
  cm7::UartTxRing<kTxCapacity> tx_;
  cm7::UartRxRing<kRxCapacity, kRxFrames> rx_;
  alignas(32) std::array<uint8_t, kRxDmaBytes> rx_dma_{};
  size_t rx_read_ = 0;             // next unread position in rx_dma_
  volatile size_t in_flight_ = 0;  // bytes of the running transmit DMA transfer
};

using DmaUart = DmaUartT<Usart1Ports, Tim2Clock>;

template <typename Ports, typename ClockT>
void DmaUartT<Ports, ClockT>::Init(const ClockT* clock) {
  clock_ = clock;
  hw_.rcc->APB2ENR = hw_.rcc->APB2ENR | (1u << 4);  // USART1 (kernel clock: PCLK2 100 MHz)
  hw_.rcc->AHB1ENR = hw_.rcc->AHB1ENR | (1u << 0);  // DMA1
  (void)hw_.rcc->AHB1ENR;
  auto& u = *hw_.usart;
  u.CR1 = 0;
  u.BRR = (kPclkHz + kBaud / 2) / kBaud;
  // DDRE stays 0: a byte with a framing / noise error is still transferred (COBS + CRC judge
  // it) and reception continues; EIE raises the error interrupt that counts it.
  u.CR3 = kUsartCr3Dmat | kUsartCr3Dmar | kUsartCr3Eie;

  auto& s = hw_.dma->S[kTxStream];
  s.CR = 0;
  while (s.CR & kDmaCrEn) {
  }
  hw_.dmamux->CCR[kTxStream] = kDmamuxReqUsart1Tx;
  s.PAR = BusAddress(&u.TDR);
  s.CR = kDmaCrDirM2P | kDmaCrMinc | kDmaCrTcie | kDmaCrTeie;
  StartRxStream();
  u.ICR = kUsartPe | kUsartFe | kUsartNe | kUsartOre | kUsartIdle;
  u.CR1 = kUsartCr1Ue | kUsartCr1Re | kUsartCr1Te | kUsartCr1Idleie;
  // One priority for all three: the receive handlers never preempt each other.
  for (int irq : {kIrqDma1Stream0, kIrqDma1Stream1, kIrqUsart1}) {
    cm7::NvicPriority(*hw_.nvic, irq, kIrqPriority);
    cm7::NvicEnable(*hw_.nvic, irq);
  }
}

template <typename Ports, typename ClockT>
void DmaUartT<Ports, ClockT>::StartRxStream() {
  auto& s = hw_.dma->S[kRxStream];
  s.CR = 0;
  while (s.CR & kDmaCrEn) {
  }
  hw_.dmamux->CCR[kRxStream] = kDmamuxReqUsart1Rx;
  s.PAR = BusAddress(&hw_.usart->RDR);
  s.M0AR = BusAddress(rx_dma_.data());
  s.NDTR = kRxDmaBytes;
  s.CR = kDmaCrMinc | kDmaCrCirc | kDmaCrHtie | kDmaCrTcie | kDmaCrTeie;  // peripheral->memory
  hw_.dma->LIFCR = kDmaFlagAll << DmaFlagShift(kRxStream);
  rx_read_ = 0;
  s.CR = s.CR | kDmaCrEn;
}

template <typename Ports, typename ClockT>
void DmaUartT<Ports, ClockT>::DrainRxDma(bool idle) {
  const uint64_t now_us = clock_->ReadUs();
  const uint32_t ndtr = hw_.dma->S[kRxStream].NDTR;
  const size_t pos = (kRxDmaBytes - ndtr) & (kRxDmaBytes - 1);
  const size_t n = (pos - rx_read_) & (kRxDmaBytes - 1);
  DcacheInvalidate(rx_dma_.data(), kRxDmaBytes);
  for (size_t i = 0; i < n; ++i) {
    const uint8_t b = rx_dma_[(rx_read_ + i) & (kRxDmaBytes - 1)];
    uint64_t t_us = now_us;
    if (b == 0) {  // only delimiters keep their stamp: back-date by the characters after it
      const uint64_t back_ns = uint64_t{n - 1 - i + (idle ? 1u : 0u)} * kCharNs;
      const uint64_t back_us = (back_ns + 500) / 1000;
      t_us = now_us > back_us ? now_us - back_us : 0;
    }
    rx_.Push(b, t_us);
  }
  rx_read_ = pos;
}

template <typename Ports, typename ClockT>
void DmaUartT<Ports, ClockT>::OnRxDmaIrq() {
  const uint32_t shift = DmaFlagShift(kRxStream);
  const uint32_t flags = (hw_.dma->LISR >> shift) & kDmaFlagAll;
  hw_.dma->LIFCR = flags << shift;
  DrainRxDma(false);
  if (flags & kDmaFlagTe) {  // the stream stopped: what it had written is kept, restart it
    rx_.CountOverrun();
    StartRxStream();
  }
}

template <typename Ports, typename ClockT>
void DmaUartT<Ports, ClockT>::OnUsartIrq() {
  const uint32_t isr = hw_.usart->ISR;
  const uint32_t errors = isr & (kUsartPe | kUsartFe | kUsartNe);
  hw_.usart->ICR = isr & (kUsartPe | kUsartFe | kUsartNe | kUsartOre | kUsartIdle);
  if (isr & kUsartOre) rx_.CountOverrun();
  if (errors != 0) rx_.CountLineError();
  if (isr & kUsartIdle) DrainRxDma(true);
}

template <typename Ports, typename ClockT>
void DmaUartT<Ports, ClockT>::KickLocked() {
  if (in_flight_ != 0 || tx_.empty()) return;
  const std::span<const uint8_t> chunk = tx_.Contiguous();
  DcacheClean(chunk.data(), chunk.size());
  auto& s = hw_.dma->S[kTxStream];
  hw_.dma->LIFCR = kDmaFlagAll << DmaFlagShift(kTxStream);
  s.M0AR = BusAddress(chunk.data());
  s.NDTR = static_cast<uint32_t>(chunk.size());
  in_flight_ = chunk.size();
  tx_.OnSendStart(chunk.size(), clock_->ReadUs(), kCharNs);
  s.CR = s.CR | kDmaCrEn;
}

template <typename Ports, typename ClockT>
void DmaUartT<Ports, ClockT>::OnTxDmaIrq() {
  const uint32_t shift = DmaFlagShift(kTxStream);
  const uint32_t flags = (hw_.dma->LISR >> shift) & kDmaFlagAll;
  hw_.dma->LIFCR = flags << shift;
  // On a transfer error the chunk is dropped too: the receiver resynchronises on COBS.
  tx_.Consume(in_flight_);
  in_flight_ = 0;
  KickLocked();
}

template <typename Ports, typename ClockT>
Status DmaUartT<Ports, ClockT>::DoWrite(std::span<const uint8_t> bytes) {
  IrqLock lock;
  if (!tx_.Push(bytes)) return Status(StatusCode::kUnavailable, "usart1: transmit ring full");
  KickLocked();
  return Status();
}

}  // namespace bv::h7
