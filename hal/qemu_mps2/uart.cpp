#include "hal/qemu_mps2/uart.h"

namespace bv::qemu {

void CmsdkUart::Init() {
  regs_->BAUDDIV = 16;  // minimum legal divider; QEMU does not model the baud rate
  regs_->CTRL = kUartCtrlTxEn | kUartCtrlRxEn;
}

size_t CmsdkUart::Poll() {
  if (tx_stalled()) return head_ - tail_;
  while (tail_ != head_ && (regs_->STATE & kUartStateTxFull) == 0) {
    regs_->DATA = tx_[tail_ & (kTxCapacity - 1)];
    ++tail_;
    ++bytes_sent_;
  }
  return head_ - tail_;
}

void CmsdkUart::Flush() {
  while (Poll() != 0 && !tx_stalled()) {
  }
}

Status CmsdkUart::DoWrite(std::span<const uint8_t> bytes) {
  Poll();
  if (bytes.size() > kTxCapacity - (head_ - tail_)) {
    ++writes_refused_;
    return Status(StatusCode::kUnavailable, "uart0: transmit ring full");
  }
  for (uint8_t b : bytes) tx_[head_++ & (kTxCapacity - 1)] = b;
  Poll();
  return Status();
}

size_t CmsdkUart::DoWriteSpace() const { return kTxCapacity - (head_ - tail_); }

Result<size_t> CmsdkUart::DoRead(std::span<uint8_t> out) {
  Poll();
  size_t n = 0;
  while (n < out.size() && (regs_->STATE & kUartStateRxFull) != 0) {
    out[n++] = static_cast<uint8_t>(regs_->DATA);
  }
  rx_bytes_ += static_cast<uint32_t>(n);
  if ((regs_->STATE & (1u << 3)) != 0) {
    regs_->STATE = 1u << 3;  // write-one-to-clear RX overrun
    ++rx_overruns_;
  }
  return n;
}

}  // namespace bv::qemu
