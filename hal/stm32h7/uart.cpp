#include "hal/stm32h7/uart.h"

#include "hal/stm32h7/registers.h"
#include "hal/stm32h7/system.h"

namespace bv::h7 {
namespace {
constexpr int kTxStream = 0;  // DMA1 stream 0 = DMAMUX1 channel 0
}  // namespace

void DmaUart::Init() {
  kRcc->APB2ENR = kRcc->APB2ENR | (1u << 4);  // USART1 (kernel clock: PCLK2 100 MHz)
  kRcc->AHB1ENR = kRcc->AHB1ENR | (1u << 0);  // DMA1
  (void)kRcc->AHB1ENR;
  kUsart1->CR1 = 0;
  kUsart1->BRR = (kPclkHz + kBaud / 2) / kBaud;
  kUsart1->CR3 = 1u << 7;                            // DMAT
  kUsart1->CR1 = (1u << 0) | (1u << 2) | (1u << 3);  // UE, RE, TE

  DmaStreamRegs& s = kDma1->S[kTxStream];
  s.CR = 0;
  while (s.CR & kDmaCrEn) {
  }
  kDmamux1->CCR[kTxStream] = kDmamuxReqUsart1Tx;
  s.PAR = reinterpret_cast<uint32_t>(&kUsart1->TDR);
  s.CR = kDmaCrDirM2P | kDmaCrMinc | kDmaCrTcie | kDmaCrTeie;
  NvicPriority(kIrqDma1Stream0, 6);
  NvicEnable(kIrqDma1Stream0);
}

void DmaUart::KickLocked() {
  if (in_flight_ != 0 || head_ == tail_) return;
  const size_t start = tail_ & (kTxCapacity - 1);
  size_t n = head_ - tail_;
  if (n > kTxCapacity - start) n = kTxCapacity - start;  // up to the end of the ring
  DcacheClean(&tx_[start], n);
  DmaStreamRegs& s = kDma1->S[kTxStream];
  kDma1->LIFCR = kDmaFlagAll << DmaFlagShift(kTxStream);
  s.M0AR = reinterpret_cast<uint32_t>(&tx_[start]);
  s.NDTR = static_cast<uint32_t>(n);
  in_flight_ = n;
  s.CR = s.CR | kDmaCrEn;
}

void DmaUart::OnDmaIrq() {
  const uint32_t flags = (kDma1->LISR >> DmaFlagShift(kTxStream)) & kDmaFlagAll;
  kDma1->LIFCR = flags << DmaFlagShift(kTxStream);
  // On a transfer error the chunk is dropped too: the receiver resynchronises on COBS.
  tail_ = tail_ + in_flight_;
  in_flight_ = 0;
  KickLocked();
}

void DmaUart::Flush() {
  while (head_ != tail_) {
  }
}

Status DmaUart::DoWrite(std::span<const uint8_t> bytes) {
  const uint32_t primask = IrqSave();
  if (bytes.size() > kTxCapacity - (head_ - tail_)) {
    IrqRestore(primask);
    return Status(StatusCode::kUnavailable, "usart1: transmit ring full");
  }
  size_t h = head_;
  for (uint8_t b : bytes) tx_[h++ & (kTxCapacity - 1)] = b;
  head_ = h;
  KickLocked();
  IrqRestore(primask);
  return Status();
}

size_t DmaUart::DoWriteSpace() const { return kTxCapacity - (head_ - tail_); }

Result<size_t> DmaUart::DoRead(std::span<uint8_t> out) {
  size_t n = 0;
  while (n < out.size() && (kUsart1->ISR & (1u << 5)) != 0) {
    out[n++] = static_cast<uint8_t>(kUsart1->RDR);
  }
  if (kUsart1->ISR & (1u << 3)) kUsart1->ICR = 1u << 3;  // overrun: bytes lost, COBS resyncs
  return n;
}

}  // namespace bv::h7
