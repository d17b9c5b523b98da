// The boards' UART drivers (hal/stm32h7/uart.h, hal/qemu_mps2/uart.h) compiled for the host and
// driven against register-level fakes: the STM32H7's USART1 + DMA1 (circular receive DMA, idle
// line, error flags, transmit DMA) and the CMSDK UART's one-byte holding register with its RX
// interrupt. Bytes arrive on a simulated 921600 Bd line while a simulated main loop is busy
// with 1.5 ms frames and only reads the UART between them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <functional>
#include <memory>
#include <random>
#include <vector>

#include "core/common/crc32.h"
#include "core/protocol/protocol.h"
// The QEMU board's header first: the H7 overlay header undefines the register macros.
#include "hal/qemu_mps2/uart.h"
#include "hal/stm32h7/uart.h"

namespace bv {
namespace {

constexpr uint64_t kCharNs = 10ull * 1000000000ull / 921600;  // 10 850 ns per 8N1 byte

class SimClock final : public hal::Clock {
 public:
  uint64_t now_ns = 0;
  uint64_t ReadUs() const { return now_ns / 1000; }

 private:
  uint64_t DoNowUs() const override { return ReadUs(); }
};

/// A register with hardware side effects: reads and writes go through the fake's handlers.
class FakeReg {
 public:
  std::function<uint32_t(uint32_t&)> on_read;
  std::function<void(uint32_t&, uint32_t)> on_write;
  uint32_t v = 0;
  operator uint32_t() const {  // NOLINT(google-explicit-constructor)
    return on_read ? on_read(const_cast<uint32_t&>(v)) : v;
  }
  FakeReg& operator=(uint32_t x) {
    if (on_write) {
      on_write(v, x);
    } else {
      v = x;
    }
    return *this;
  }
  FakeReg& operator=(const FakeReg&) = delete;
};

/// What a board fake offers the scenario runner.
class SimBoard {
 public:
  virtual ~SimBoard() = default;
  virtual hal::Uart& uart() = 0;
  /// A byte finished arriving at clock.now_ns (`framing_error`: a break or a bad stop bit).
  virtual void RxByte(uint8_t b, bool framing_error) = 0;
  /// Hardware activity up to `t_ns` (idle-line detection, transmit progress).
  virtual void Advance(uint64_t t_ns) = 0;
  /// Interrupts masked (a long critical section) or not; pending ones run on unmasking.
  virtual void MaskIrqs(bool masked) = 0;
  virtual const char* name() const = 0;
  SimClock clock;
};

// --- STM32H7: USART1 + DMA1 streams 0 (TX) and 1 (RX) ---

struct FakeUsart {
  FakeReg CR1, CR2, CR3, BRR, GTPR, RTOR, RQR, ISR, ICR, RDR, TDR, PRESC;
};
struct FakeDmaStream {
  FakeReg CR, NDTR, PAR, M0AR, M1AR, FCR;
};
struct FakeDma {
  FakeReg LISR, HISR, LIFCR, HIFCR;
  FakeDmaStream S[8];
};
struct FakeNvic {
  FakeReg ISER[8];  // write one to set
  uint8_t IPR[240] = {};
  FakeNvic() {
    for (FakeReg& r : ISER) r.on_write = [](uint32_t& v, uint32_t x) { v |= x; };
  }
  bool enabled(int irq) const { return ISER[irq >> 5].v & (1u << (irq & 31)); }
};
struct FakeH7Ports {
  FakeUsart* usart;
  FakeDma* dma;
  h7::DmamuxRegs* dmamux;
  h7::RccRegs* rcc;
  FakeNvic* nvic;
};

class H7Board : public SimBoard {
 public:
  using Driver = h7::DmaUartT<FakeH7Ports, SimClock>;
  H7Board() : uart_(FakeH7Ports{&usart_, &dma_, &dmamux_, &rcc_, &nvic_}) {
    usart_.ICR.on_write = [this](uint32_t&, uint32_t x) { usart_.ISR.v &= ~x; };
    dma_.LIFCR.on_write = [this](uint32_t&, uint32_t x) { dma_.LISR.v &= ~x; };
    dma_.S[0].CR.on_write = [this](uint32_t& r, uint32_t x) {
      const bool start = (x & h7::kDmaCrEn) && !(r & h7::kDmaCrEn);
      r = x;
      if (start) StartTx();
    };
    uart_.Init(&clock);
  }
  hal::Uart& uart() override { return uart_; }
  Driver& driver() { return uart_; }
  const char* name() const override { return "stm32h7 usart1+dma"; }
  FakeUsart& usart() { return usart_; }
  FakeDma& dma() { return dma_; }
  h7::DmamuxRegs& dmamux() { return dmamux_; }
  FakeNvic& nvic() { return nvic_; }
  std::vector<std::pair<uint64_t, uint8_t>> sent;  // (start ns, byte) on the TX line

  void RxByte(uint8_t b, bool framing_error) override {
    last_rx_ns_ = clock.now_ns;
    idle_armed_ = true;
    FakeDmaStream& s = dma_.S[1];
    const bool dma_on = (usart_.CR3.v & h7::kUsartCr3Dmar) && (s.CR.v & h7::kDmaCrEn);
    if (framing_error) Raise(usart_.ISR, h7::kUsartFe, h7::kIrqUsart1);
    if (!dma_on) {  // nobody takes RDR: the byte is lost (overrun)
      usart_.ISR.v |= h7::kUsartOre;
      return;
    }
    ASSERT_EQ(s.M0AR.v, h7::BusAddress(uart_.rx_dma_buffer()));
    ASSERT_EQ(s.PAR.v, h7::BusAddress(&usart_.RDR));
    const uint32_t size = Driver::kRxDmaBytes;
    const uint32_t pos = size - s.NDTR.v;
    const_cast<uint8_t*>(uart_.rx_dma_buffer())[pos] = b;
    s.NDTR.v = s.NDTR.v - 1;
    const uint32_t shift = h7::DmaFlagShift(1);
    if (s.NDTR.v == size / 2 && (s.CR.v & h7::kDmaCrHtie)) {
      Raise(dma_.LISR, h7::kDmaFlagHt << shift, h7::kIrqDma1Stream1);
    }
    if (s.NDTR.v == 0) {
      ASSERT_TRUE(s.CR.v & h7::kDmaCrCirc);
      s.NDTR.v = size;
      if (s.CR.v & h7::kDmaCrTcie) Raise(dma_.LISR, h7::kDmaFlagTc << shift, h7::kIrqDma1Stream1);
    }
  }

  void Advance(uint64_t t_ns) override {
    const uint64_t now = clock.now_ns;
    if (idle_armed_ && last_rx_ns_ + kCharNs <= t_ns) {  // one idle character after reception
      idle_armed_ = false;
      clock.now_ns = last_rx_ns_ + kCharNs;
      if (usart_.CR1.v & h7::kUsartCr1Idleie) Raise(usart_.ISR, h7::kUsartIdle, h7::kIrqUsart1);
    }
    while (tx_left_ > 0 && tx_next_ns_ <= t_ns) {
      clock.now_ns = tx_next_ns_;
      sent.emplace_back(tx_next_ns_, *tx_ptr_++);
      tx_next_ns_ += kCharNs;
      if (--tx_left_ == 0) {  // the last byte went to TDR: transfer complete
        dma_.S[0].CR.v &= ~h7::kDmaCrEn;
        dma_.S[0].NDTR.v = 0;
        Raise(dma_.LISR, h7::kDmaFlagTc << h7::DmaFlagShift(0), h7::kIrqDma1Stream0);
      }
    }
    clock.now_ns = std::max(now, t_ns);
  }

  void MaskIrqs(bool masked) override {
    masked_ = masked;
    if (!masked) {
      for (int irq : {h7::kIrqDma1Stream0, h7::kIrqDma1Stream1, h7::kIrqUsart1}) {
        if (pending_[irq]) Call(irq);
      }
    }
  }

 private:
  void StartTx() {
    FakeDmaStream& s = dma_.S[0];
    ASSERT_EQ(dmamux_.CCR[0], h7::kDmamuxReqUsart1Tx);
    ASSERT_EQ(s.PAR.v, h7::BusAddress(&usart_.TDR));
    // The 32-bit bus address back to a host pointer into the driver's transmit ring.
    const auto base = reinterpret_cast<uintptr_t>(uart_.tx_ring_data());
    const uintptr_t p = (base & ~uintptr_t{0xFFFFFFFFu}) | s.M0AR.v;
    ASSERT_GE(p, base);
    ASSERT_LE(p + s.NDTR.v, base + Driver::kTxCapacity);
    tx_ptr_ = reinterpret_cast<const uint8_t*>(p);
    tx_left_ = s.NDTR.v;
    // The USART still shifts out the previous chunk's last byte.
    tx_next_ns_ = std::max(clock.now_ns, tx_line_free_ns_);
    tx_line_free_ns_ = tx_next_ns_ + tx_left_ * kCharNs;
  }
  void Raise(FakeReg& flags, uint32_t bit, int irq) {
    flags.v |= bit;
    if (nvic_.enabled(irq)) {
      pending_[irq] = true;
      if (!masked_) Call(irq);
    }
  }
  void Call(int irq) {
    pending_[irq] = false;
    if (irq == h7::kIrqUsart1) uart_.OnUsartIrq();
    if (irq == h7::kIrqDma1Stream1) uart_.OnRxDmaIrq();
    if (irq == h7::kIrqDma1Stream0) uart_.OnTxDmaIrq();
  }

  FakeUsart usart_;
  FakeDma dma_;
  h7::DmamuxRegs dmamux_{};
  h7::RccRegs rcc_{};
  FakeNvic nvic_;
  Driver uart_;
  uint64_t last_rx_ns_ = 0;
  bool idle_armed_ = false;
  bool masked_ = false;
  bool pending_[h7::kIrqCount] = {};
  const uint8_t* tx_ptr_ = nullptr;
  uint32_t tx_left_ = 0;
  uint64_t tx_next_ns_ = 0;
  uint64_t tx_line_free_ns_ = 0;
};

// --- QEMU mps2-an500: CMSDK APB UART0 ---

struct FakeCmsdk {
  FakeReg DATA, STATE, CTRL, INTSTATUS, BAUDDIV;
};

class QemuBoard : public SimBoard {
 public:
  using Driver = qemu::CmsdkUartT<FakeCmsdk, FakeNvic, SimClock>;
  QemuBoard() : uart_(&regs_, &nvic_) {
    regs_.DATA.on_read = [this](uint32_t& r) {
      regs_.STATE.v &= ~qemu::kUartStateRxFull;
      return r;
    };
    regs_.DATA.on_write = [this](uint32_t&, uint32_t x) {
      sent.emplace_back(clock.now_ns, static_cast<uint8_t>(x));
    };
    regs_.STATE.on_write = [](uint32_t& r, uint32_t x) { r &= ~(x & 0xCu); };  // overrun W1C
    regs_.INTSTATUS.on_write = [](uint32_t& r, uint32_t x) { r &= ~x; };       // W1C
    uart_.Init(&clock);
  }
  hal::Uart& uart() override { return uart_; }
  Driver& driver() { return uart_; }
  const char* name() const override { return "qemu cmsdk uart0"; }
  std::vector<std::pair<uint64_t, uint8_t>> sent;

  void RxByte(uint8_t b, bool) override {  // the CMSDK UART reports no framing errors
    if (regs_.STATE.v & qemu::kUartStateRxFull) {
      regs_.STATE.v |= qemu::kUartStateRxOverrun;  // the holding register was not read
      return;
    }
    regs_.DATA.v = b;
    regs_.STATE.v |= qemu::kUartStateRxFull;
    if (regs_.CTRL.v & qemu::kUartCtrlRxIntEn) regs_.INTSTATUS.v |= qemu::kUartIntRx;
    Deliver();
  }
  void Advance(uint64_t t_ns) override { clock.now_ns = std::max(clock.now_ns, t_ns); }
  void MaskIrqs(bool masked) override {
    masked_ = masked;
    Deliver();
  }

 private:
  void Deliver() {  // level-triggered RX line, NVIC IRQ 0
    const bool enabled = nvic_.enabled(qemu::kIrqUart0Rx);
    for (int guard = 0;
         guard < 4 && enabled && !masked_ && (regs_.INTSTATUS.v & qemu::kUartIntRx) != 0; ++guard) {
      uart_.OnRxIrq();
    }
  }

  FakeCmsdk regs_;
  FakeNvic nvic_;
  Driver uart_;
  bool masked_ = false;
};

// --- scenarios ---

struct WireByte {
  uint64_t t_ns;
  uint8_t b;
  bool framing_error = false;
};

/// Appends `bytes` back to back at 921600 Bd from `t_ns`; returns the time after the last one.
uint64_t Transmit(std::vector<WireByte>& wire, uint64_t t_ns, std::span<const uint8_t> bytes,
                  bool framing_error = false) {
  for (uint8_t b : bytes) {
    t_ns += kCharNs;
    wire.push_back({t_ns, b, framing_error});
  }
  return t_ns;
}

std::vector<uint8_t> Frame(protocol::MsgType type, uint32_t seq, std::span<const uint8_t> payload) {
  std::vector<uint8_t> out(protocol::kMaxWireFrameBytes);
  const Result<size_t> n = protocol::EncodeFrame(type, seq, payload, out);
  EXPECT_TRUE(n.ok());
  out.resize(*n);
  return out;
}

struct Received {
  uint32_t seq;
  std::vector<uint8_t> payload;
  uint64_t loop_ns;   // when the main loop decoded it
  uint64_t stamp_us;  // Uart::LastRxFrameUs() right after the read that ended it
};

struct RunResult {
  std::vector<Received> frames;
  protocol::DecoderStats decoder;
  hal::UartRxStats rx;
  size_t bytes_read = 0;
  uint64_t end_ns = 0;
};

struct LoopModel {
  uint64_t frame_ns = 1500000;  // busy processing a frame pair; reads only in between
  uint64_t mask_from_ns = 0;    // optional interrupt-masked window
  uint64_t mask_to_ns = 0;
};

/// Runs the line and the main loop until every wire byte arrived and the loop drained the
/// UART. The loop alternates: read everything available, then `frame_ns` of processing.
RunResult RunLine(SimBoard& board, const std::vector<WireByte>& wire, const LoopModel& loop) {
  RunResult r;
  protocol::Decoder decoder;
  size_t next = 0;
  uint64_t t = 0, next_read = 0;
  const uint64_t end = (wire.empty() ? 0 : wire.back().t_ns) + 2 * loop.frame_ns + 2 * kCharNs;
  for (; t <= end; t += 1000) {
    const bool masked = t >= loop.mask_from_ns && t < loop.mask_to_ns;
    board.MaskIrqs(masked);
    while (next < wire.size() && wire[next].t_ns <= t) {
      board.clock.now_ns = wire[next].t_ns;
      board.RxByte(wire[next].b, wire[next].framing_error);
      ++next;
    }
    board.Advance(t);
    if (t < next_read) continue;
    uint8_t buf[64];
    for (;;) {
      const Result<size_t> n = board.uart().Read(buf);
      EXPECT_TRUE(n.ok());
      if (!n.ok() || *n == 0) break;
      r.bytes_read += *n;
      for (size_t i = 0; i < *n; ++i) {
        protocol::FrameView f;
        if (!decoder.Push(buf[i], f)) continue;
        EXPECT_EQ(i + 1, *n) << "Read() must stop at a delimiter";
        const Result<uint64_t> stamp = board.uart().LastRxFrameUs();
        EXPECT_TRUE(stamp.ok());
        r.frames.push_back({f.seq, {f.payload.begin(), f.payload.end()}, t, *stamp});
      }
    }
    next_read = t + loop.frame_ns;
  }
  r.decoder = decoder.stats();
  r.rx = board.uart().RxStats();
  r.end_ns = t;
  return r;
}

/// A 1 KB upload as the main computer sends it, every frame back to back.
std::vector<std::vector<uint8_t>> UploadFrames(const std::vector<uint8_t>& blob) {
  std::vector<std::vector<uint8_t>> frames;
  uint32_t seq = 100;
  uint8_t begin[9] = {2};
  const uint32_t len = static_cast<uint32_t>(blob.size()), crc = Crc32(blob);
  std::memcpy(begin + 1, &len, 4);
  std::memcpy(begin + 5, &crc, 4);
  frames.push_back(Frame(protocol::MsgType::kUploadBegin, seq++, begin));
  for (uint32_t off = 0; off < len; off += 512) {
    std::vector<uint8_t> chunk = {2, 0, 0, 0, 0};
    std::memcpy(chunk.data() + 1, &off, 4);
    chunk.insert(chunk.end(), blob.begin() + off, blob.begin() + std::min<size_t>(off + 512, len));
    frames.push_back(Frame(protocol::MsgType::kUploadChunk, seq++, chunk));
  }
  const uint8_t commit[1] = {2};
  frames.push_back(Frame(protocol::MsgType::kUploadCommit, seq++, commit));
  return frames;
}

std::vector<uint8_t> RandomBytes(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<uint8_t> v(n);
  for (uint8_t& b : v) b = static_cast<uint8_t>(rng());
  return v;
}

std::unique_ptr<SimBoard> MakeBoard(bool h7) {
  if (h7) return std::make_unique<H7Board>();
  return std::make_unique<QemuBoard>();
}

class UartRx : public ::testing::TestWithParam<bool> {};  // true: STM32H7, false: QEMU

TEST_P(UartRx, UploadArrivesIntactWhileFramesAreProcessed) {
  auto board = MakeBoard(GetParam());
  const std::vector<uint8_t> blob = RandomBytes(1024, 17);
  std::vector<WireByte> wire;
  std::vector<uint64_t> delimiter_ns;
  uint64_t t = 200000;  // the first byte lands inside the loop's first frame
  size_t sent_bytes = 0;
  for (const auto& f : UploadFrames(blob)) {
    t = Transmit(wire, t, f);
    delimiter_ns.push_back(t);
    sent_bytes += f.size();
  }
  const RunResult r = RunLine(*board, wire, LoopModel{});

  ASSERT_EQ(r.frames.size(), delimiter_ns.size());
  std::vector<uint8_t> got;
  uint64_t worst_latency_ns = 0, worst_stamp_err_ns = 0;
  for (size_t i = 0; i < r.frames.size(); ++i) {
    const Received& f = r.frames[i];
    EXPECT_EQ(f.seq, 100 + i);
    if (i >= 1 && i + 1 < r.frames.size())
      got.insert(got.end(), f.payload.begin() + 5, f.payload.end());
    worst_latency_ns = std::max(worst_latency_ns, f.loop_ns - delimiter_ns[i]);
    const uint64_t stamp_ns = f.stamp_us * 1000;
    const uint64_t err =
        stamp_ns > delimiter_ns[i] ? stamp_ns - delimiter_ns[i] : delimiter_ns[i] - stamp_ns;
    worst_stamp_err_ns = std::max(worst_stamp_err_ns, err);
  }
  EXPECT_EQ(got, blob);
  EXPECT_EQ(r.bytes_read, sent_bytes);
  EXPECT_EQ(r.decoder.errors(), 0u);
  EXPECT_EQ(r.rx.overruns, 0u);
  EXPECT_EQ(r.rx.ring_full, 0u);
  // The loop reads only between 1.5 ms frames: a frame waits at most one frame (+1 µs step).
  EXPECT_LE(worst_latency_ns, 1500000u + 1000u + kCharNs);
  // Stamps are taken in the interrupt: within the clock's 1 µs resolution of the true arrival
  // (the H7 back-dates the delimiter from its idle / half-transfer interrupt).
  EXPECT_LE(worst_stamp_err_ns, 2000u);
  std::printf(
      "[%s] 1 KB upload: %zu wire bytes in %.2f ms during 1.5 ms frames; bytes lost %zu; "
      "worst receive latency (delimiter on the wire -> frame decoded by the loop) "
      "%.1f us; worst arrival-stamp error %.2f us\n",
      board->name(), sent_bytes, (t - 200000) / 1e6, sent_bytes - r.bytes_read,
      worst_latency_ns / 1e3, worst_stamp_err_ns / 1e3);
}

// The interrupt side alone: a loop that reads every 1 µs sees each frame as soon as the driver
// has moved its delimiter into the ring. QEMU: at once (one interrupt per byte); H7: at the next
// half/full-transfer interrupt (every 32 characters) or one idle character after a burst.
TEST_P(UartRx, InterruptPathLatencyIsBounded) {
  auto board = MakeBoard(GetParam());
  std::vector<WireByte> wire;
  std::vector<uint64_t> delimiter_ns;
  uint64_t t = 0;
  for (const auto& f : UploadFrames(RandomBytes(1024, 18))) {
    t = Transmit(wire, t, f);
    delimiter_ns.push_back(t);
  }
  LoopModel loop;
  loop.frame_ns = 1000;
  const RunResult r = RunLine(*board, wire, loop);
  ASSERT_EQ(r.frames.size(), delimiter_ns.size());
  uint64_t worst_ns = 0;
  for (size_t i = 0; i < r.frames.size(); ++i) {
    worst_ns = std::max(worst_ns, r.frames[i].loop_ns - delimiter_ns[i]);
  }
  const uint64_t bound_ns = GetParam() ? H7Board::Driver::kRxDmaBytes / 2 * kCharNs + 1000 : 1000;
  EXPECT_LE(worst_ns, bound_ns);
  std::printf(
      "[%s] worst interrupt-path latency (delimiter on the wire -> readable by the loop) "
      "%.1f us (bound %.1f us)\n",
      board->name(), worst_ns / 1e3, bound_ns / 1e3);
}

// A flood of small frames, back to back, while the loop reads only every 30 ms: the ring fills.
TEST_P(UartRx, FloodFasterThanTheLoopDrainsDropsWholeFramesAndResyncs) {
  auto board = MakeBoard(GetParam());
  std::vector<WireByte> wire;
  uint64_t t = 0;
  constexpr uint32_t kFrames = 300;
  for (uint32_t i = 0; i < kFrames; ++i) {
    t = Transmit(wire, t, Frame(protocol::MsgType::kSetParam, i, RandomBytes(80, i)));
  }
  // After the flood and a pause, one more frame: the link must work (no stall).
  t = Transmit(wire, t + 40000000, Frame(protocol::MsgType::kRequestStatus, kFrames, {}));
  LoopModel loop;
  loop.frame_ns = 30000000;
  const RunResult r = RunLine(*board, wire, loop);

  EXPECT_GT(r.rx.ring_full, 0u);
  EXPECT_EQ(r.rx.overruns, 0u);
  // Every frame is either delivered intact or counted as dropped, never both or neither.
  EXPECT_EQ(r.frames.size() + r.rx.ring_full, kFrames + 1);
  for (size_t i = 1; i < r.frames.size(); ++i) EXPECT_GT(r.frames[i].seq, r.frames[i - 1].seq);
  ASSERT_FALSE(r.frames.empty());
  EXPECT_EQ(r.frames.back().seq, kFrames);
  EXPECT_LE(r.decoder.errors(), r.rx.ring_full);  // only stubs of dropped frames
  std::printf(
      "[%s] flood: %u frames, %zu delivered intact, %u dropped (ring full), decoder "
      "errors %u\n",
      board->name(), kFrames + 1, r.frames.size(), r.rx.ring_full, r.decoder.errors());
}

// The QEMU board's replay hold (rx_bytes=N) waits on the bytes the loop is done with. Frames the
// full ring dropped count too: a drop ends the hold, and the test fails on the missing replies
// instead of running to its timeout (fw_qemu_commands hung so, 1 run in 12).
TEST(UartRxQemu, BytesTheRingDroppedCountAsDoneForTheReplayHold) {
  QemuBoard board;
  std::vector<WireByte> wire;
  uint64_t t = 0;
  for (uint32_t i = 0; i < 100; ++i) {
    t = Transmit(wire, t, Frame(protocol::MsgType::kSetParam, i, RandomBytes(80, i)));
  }
  LoopModel loop;
  loop.frame_ns = 30000000;
  const RunResult r = RunLine(board, wire, loop);
  ASSERT_GT(r.rx.ring_full, 0u);
  EXPECT_LT(r.bytes_read, wire.size());
  EXPECT_EQ(*board.driver().rx_bytes(), wire.size());
}

TEST_P(UartRx, NoiseBetweenFramesCostsAtMostTheFrameItTouches) {
  auto board = MakeBoard(GetParam());
  std::vector<WireByte> wire;
  std::mt19937 rng(5);
  uint64_t t = 0;
  std::vector<uint32_t> expected;
  for (uint32_t i = 0; i < 40; ++i) {
    std::vector<uint8_t> noise = RandomBytes(1 + rng() % 30, 1000 + i);
    // Odd frames: the noise ends on a 0x00 (a glitch seen as a delimiter): the frame survives.
    // Even frames: the noise runs straight into the frame, which is lost (and only it).
    std::replace(noise.begin(), noise.end(), uint8_t{0}, uint8_t{0x55});
    if (i % 2 == 1) noise.back() = 0;
    t = Transmit(wire, t + 50000, noise);
    t = Transmit(wire, t, Frame(protocol::MsgType::kSetParam, i, RandomBytes(6, i)));
    if (i % 2 == 1) expected.push_back(i);
  }
  const RunResult r = RunLine(*board, wire, LoopModel{});
  std::vector<uint32_t> got;
  for (const Received& f : r.frames) got.push_back(f.seq);
  EXPECT_EQ(got, expected);
  EXPECT_EQ(r.rx.ring_full, 0u);
  EXPECT_GE(r.decoder.errors(), 20u);  // the even frames (and some noise-only frames)
}

INSTANTIATE_TEST_SUITE_P(Boards, UartRx, ::testing::Values(true, false),
                         [](const auto& p) { return p.param ? "Stm32h7" : "QemuMps2"; });

TEST(UartRxH7, LineBreakAndFramingErrorsAreCountedAndTheNextFrameDecodes) {
  H7Board board;
  std::vector<WireByte> wire;
  uint64_t t = Transmit(wire, 0, Frame(protocol::MsgType::kSetParam, 1, RandomBytes(20, 1)));
  // Half a frame, then a line break: the USART reads it as 0x00 with a framing error.
  const std::vector<uint8_t> cut = Frame(protocol::MsgType::kSetParam, 2, RandomBytes(40, 2));
  t = Transmit(wire, t, std::span(cut).first(20));
  const uint8_t brk[3] = {0, 0, 0};
  t = Transmit(wire, t, brk, /*framing_error=*/true);
  // A byte with a bad stop bit inside an otherwise good frame: that frame is rejected.
  std::vector<uint8_t> bad = Frame(protocol::MsgType::kSetParam, 3, RandomBytes(20, 3));
  t = Transmit(wire, t, std::span(bad).first(10));
  t = Transmit(wire, t, std::span(bad).subspan(10, 1), /*framing_error=*/true);
  t = Transmit(wire, t, std::span(bad).subspan(11));
  t = Transmit(wire, t + 100000, Frame(protocol::MsgType::kSetParam, 4, RandomBytes(20, 4)));
  const RunResult r = RunLine(board, wire, LoopModel{});
  ASSERT_EQ(r.frames.size(), 3u);
  EXPECT_EQ(r.frames[0].seq, 1u);
  EXPECT_EQ(r.frames[1].seq, 3u);  // the flagged byte itself was intact: COBS + CRC decide
  EXPECT_EQ(r.frames[2].seq, 4u);
  EXPECT_GE(r.rx.line_errors, 2u);
  EXPECT_EQ(r.decoder.errors(), 1u);  // the frame the break cut
}

TEST(UartRxH7, DriverProgramsTheHardwareAsTheReferenceManualRequires) {
  H7Board board;
  EXPECT_EQ(board.dmamux().CCR[1], h7::kDmamuxReqUsart1Rx);
  EXPECT_EQ(board.dmamux().CCR[0], h7::kDmamuxReqUsart1Tx);
  const uint32_t rx_cr = board.dma().S[1].CR.v;
  EXPECT_TRUE(rx_cr & h7::kDmaCrEn);
  EXPECT_TRUE(rx_cr & h7::kDmaCrCirc);
  EXPECT_EQ(rx_cr & (3u << 6), 0u);  // peripheral to memory
  EXPECT_TRUE(board.usart().CR3.v & h7::kUsartCr3Dmar);
  EXPECT_EQ(board.usart().CR3.v & (1u << 13), 0u);  // DDRE off: errors do not stop the DMA
  EXPECT_TRUE(board.usart().CR1.v & h7::kUsartCr1Idleie);
  EXPECT_EQ(board.usart().BRR.v, (h7::kPclkHz + 921600 / 2) / 921600);
  for (int irq : {h7::kIrqDma1Stream0, h7::kIrqDma1Stream1, h7::kIrqUsart1}) {
    EXPECT_TRUE(board.nvic().enabled(irq)) << irq;
  }
}

// Transmit stamps: a reply queued behind a long packet is stamped with the time its first byte
// starts on the line (the driver's documented bound: at most 2 characters early).
TEST(UartTx, H7StampsTheFirstByteOfTheLastPacket) {
  H7Board board;
  board.Advance(1000000);
  const std::vector<uint8_t> a = RandomBytes(300, 8), b = RandomBytes(40, 9);
  ASSERT_TRUE(board.uart().Write(a).ok());
  board.Advance(1500000);
  ASSERT_TRUE(board.uart().Write(b).ok());
  EXPECT_EQ(board.uart().LastTxStartUs().status().code(), StatusCode::kUnavailable);
  board.Advance(1000000 + 400 * kCharNs);
  ASSERT_EQ(board.sent.size(), a.size() + b.size());
  const uint64_t actual_ns = board.sent[a.size()].first;
  EXPECT_EQ(board.sent[a.size()].second, b[0]);
  Result<uint64_t> stamp = board.uart().LastTxStartUs();
  ASSERT_TRUE(stamp.ok());
  const int64_t early_ns = static_cast<int64_t>(actual_ns) - static_cast<int64_t>(*stamp * 1000);
  EXPECT_GE(early_ns, -1000);
  EXPECT_LE(early_ns, static_cast<int64_t>(2 * kCharNs + 1000));
  for (size_t i = 0; i < a.size(); ++i) ASSERT_EQ(board.sent[i].second, a[i]);
}

TEST(UartTx, QemuStampsTheWriteThatSendsTheFirstByte) {
  QemuBoard board;
  board.Advance(2500000);
  const std::vector<uint8_t> a = RandomBytes(50, 10);
  ASSERT_TRUE(board.uart().Write(a).ok());
  ASSERT_EQ(board.sent.size(), a.size());
  const Result<uint64_t> stamp = board.uart().LastTxStartUs();
  ASSERT_TRUE(stamp.ok());
  EXPECT_EQ(*stamp, 2500u);
}

// Interrupts held off for 200 µs: the CMSDK UART's single holding register overruns; the lost
// byte is counted and costs only its frame.
TEST(UartRxQemu, MaskedInterruptOverrunIsCountedAndCostsOneFrame) {
  QemuBoard board;
  std::vector<WireByte> wire;
  uint64_t t = 0;
  size_t frame5 = 0;
  for (uint32_t i = 0; i < 10; ++i) {
    if (i == 5) frame5 = wire.size();
    t = Transmit(wire, t + 20000, Frame(protocol::MsgType::kSetParam, i, RandomBytes(30, i)));
  }
  LoopModel loop;
  loop.mask_from_ns = wire[frame5 + 5].t_ns;  // inside frame 5 (about 46 wire bytes)
  loop.mask_to_ns = loop.mask_from_ns + 200000;
  const RunResult r = RunLine(board, wire, loop);
  EXPECT_GT(r.rx.overruns, 0u);
  EXPECT_EQ(r.frames.size(), 9u);
  EXPECT_EQ(r.decoder.errors(), 1u);
}

// The shared ring on its own: the corner cases a protocol-sized stream does not reach.
TEST(UartRxRing, OverflowAfterTheReaderTookAFrameStartEndsItWithABareDelimiter) {
  cm7::UartRxRing<64, 4> ring;
  for (int i = 0; i < 10; ++i) ring.Push(0x11, 1);
  uint8_t out[128];
  EXPECT_EQ(ring.Read(out), 10u);                    // the reader holds the start of a frame
  for (int i = 0; i < 100; ++i) ring.Push(0x22, 2);  // no delimiter: the ring overflows once
  EXPECT_EQ(ring.stats().ring_full, 1u);
  EXPECT_EQ(ring.size(), 0u);  // the unread part of the doomed frame is gone
  ring.Push(0, 3);             // its delimiter
  for (uint8_t b : {0x33, 0x34, 0x00}) ring.Push(b, 4);
  ASSERT_EQ(ring.Read(out), 1u);  // a bare delimiter ends the reader's stub
  EXPECT_EQ(out[0], 0);
  ASSERT_EQ(ring.Read(out), 3u);
  EXPECT_EQ(out[0], 0x33);
  EXPECT_EQ(*ring.LastFrameUs(), 4u);
  EXPECT_EQ(ring.stats().ring_full, 1u);
}

TEST(UartRxRing, StampTableFullDropsTheNewFrameAndKeepsTheQueuedOnes) {
  cm7::UartRxRing<64, 4> ring;
  for (uint64_t f = 0; f < 5; ++f) {
    ring.Push(static_cast<uint8_t>(0x40 + f), 10 * f);
    ring.Push(0, 10 * f + 1);
  }
  ring.Push(0, 99);  // an empty frame: neither stored nor stamped
  EXPECT_EQ(ring.stats().ring_full, 1u);
  uint8_t out[8];
  for (uint64_t f = 0; f < 4; ++f) {
    ASSERT_EQ(ring.Read(out), 2u);
    EXPECT_EQ(out[0], 0x40 + f);
    EXPECT_EQ(*ring.LastFrameUs(), 10 * f + 1);
  }
  EXPECT_EQ(ring.Read(out), 0u);
}

}  // namespace
}  // namespace bv
