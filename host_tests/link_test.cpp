// Clock sync and capture messages (core/protocol/link.h), their command handling, and the
// main computer's clock-sync estimator (tools/ballvision/clock_sync.h).
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>
#include <vector>

#include "core/common/bytes.h"
#include "core/common/image.h"
#include "core/protocol/commands.h"
#include "core/protocol/link.h"
#include "tools/ballvision/clock_sync.h"

namespace bv {
namespace {

using protocol::CaptureMode;
using protocol::ClockSyncReply;
using protocol::CommandError;
using protocol::MsgType;
using tools::ClockSync;

// One wire frame back through the decoder.
protocol::FrameView DecodeOne(std::span<const uint8_t> wire, protocol::Decoder& d) {
  protocol::FrameView f;
  bool got = false;
  for (uint8_t b : wire) got |= d.Push(b, f);
  EXPECT_TRUE(got);
  return f;
}

TEST(LinkMessages, ClockSyncRoundTripAndRefusals) {
  std::array<uint8_t, protocol::kMaxWireFrameBytes> wire{};
  ClockSyncReply in{7, 1700000000123456ull, 5000000, 5000420};
  const Result<size_t> n = protocol::EncodeClockSyncReply(in, 3, wire);
  ASSERT_TRUE(n.ok());
  protocol::Decoder d;
  const protocol::FrameView f = DecodeOne(std::span<const uint8_t>(wire.data(), *n), d);
  EXPECT_EQ(f.type, MsgType::kClockSyncReply);
  ClockSyncReply out;
  ASSERT_TRUE(protocol::ParseClockSyncReply(f.payload, out).ok());
  EXPECT_EQ(out.id, 7u);
  EXPECT_EQ(out.t1_host_us, in.t1_host_us);
  EXPECT_EQ(out.t2_rx_us, 5000000u);
  EXPECT_EQ(out.t3_tx_us, 5000420u);

  std::vector<uint8_t> p(f.payload.begin(), f.payload.end());
  // Replied before it was received: impossible, refused.
  std::swap_ranges(p.begin() + 12, p.begin() + 20, p.begin() + 20);
  const Status s = protocol::ParseClockSyncReply(p, out);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_STREQ(s.message(), "clock sync reply: sent before received");
  p.pop_back();
  EXPECT_STREQ(protocol::ParseClockSyncReply(p, out).message(),
               "clock sync reply: length is not 28 bytes");
}

TEST(LinkMessages, CaptureFrameChecksSizeAgainstMode) {
  protocol::CaptureFrame f;
  f.capture_id = 2, f.pair_index = 4, f.count = 5, f.mode = CaptureMode::kHalf, f.cameras = 3;
  f.width = 320, f.height = 240, f.image_bytes = 320 * 240 * 2, f.exposure_us = 99;
  std::array<uint8_t, protocol::kMaxWireFrameBytes> wire{};
  const Result<size_t> n = protocol::EncodeCaptureFrame(f, 0, wire);
  ASSERT_TRUE(n.ok());
  protocol::Decoder d;
  const protocol::FrameView v = DecodeOne(std::span<const uint8_t>(wire.data(), *n), d);
  protocol::CaptureFrame out;
  ASSERT_TRUE(protocol::ParseCaptureFrame(v.payload, out).ok());
  EXPECT_EQ(out.image_bytes, f.image_bytes);
  EXPECT_EQ(out.pair_index, 4);
  // Full-size dimensions announced with the half mode: refused.
  f.width = 640, f.height = 480, f.image_bytes = kFrameBytes;
  ASSERT_TRUE(protocol::EncodeCaptureFrame(f, 0, wire).ok());
  protocol::Decoder d2;
  const protocol::FrameView bad = DecodeOne(wire, d2);
  EXPECT_STREQ(protocol::ParseCaptureFrame(bad.payload, out).message(),
               "capture frame: size disagrees with the mode");
}

// Scanlines: 640x480 (the image the samples lie in), image_bytes the pair's streams (each at
// least a header and one sample, at most a full table's).
TEST(LinkMessages, ScanlineCaptureFrameBoundsItsStreams) {
  protocol::CaptureFrame f;
  f.count = 1, f.mode = CaptureMode::kScanlines, f.cameras = 3, f.width = 640, f.height = 480;
  const auto parses = [&f](uint32_t image_bytes) {
    f.image_bytes = image_bytes;
    std::array<uint8_t, protocol::kMaxWireFrameBytes> wire{};
    const Result<size_t> n = protocol::EncodeCaptureFrame(f, 0, wire);
    EXPECT_TRUE(n.ok());
    protocol::Decoder d;
    const protocol::FrameView v = DecodeOne(std::span<const uint8_t>(wire.data(), *n), d);
    protocol::CaptureFrame out;
    return protocol::ParseCaptureFrame(v.payload, out).ok();
  };
  EXPECT_TRUE(parses(16 + 3 * 28401));
  EXPECT_TRUE(parses(2 * 11));
  EXPECT_FALSE(parses(2 * 11 - 1));
  EXPECT_TRUE(parses(2 * (8 + 3 * 65535)));
  EXPECT_FALSE(parses(2 * (8 + 3 * 65535) + 1));
  f.cameras = 1;
  EXPECT_TRUE(parses(11));
  EXPECT_FALSE(parses(8 + 3 * 65535 + 1));
  f.width = 160, f.height = 120;
  EXPECT_FALSE(parses(11)) << "scanlines lie in the full image";
  std::vector<uint8_t> src(kFrameBytes), out(16);
  EXPECT_FALSE(protocol::CopyCaptureBytes(src.data(), 1280, CaptureMode::kScanlines, 0, out));
}

TEST(LinkMessages, BlobDataRoundTripAndBounds) {
  uint8_t data[protocol::kBlobDataBytes + 1] = {};
  for (size_t i = 0; i < sizeof data; ++i) data[i] = static_cast<uint8_t>(i * 7);
  protocol::BlobData in;
  in.cmd_seq = 41, in.target = 2, in.total_len = 65552, in.blob_crc32 = 0xA1B2C3D4u;
  in.offset = 65552 - 16, in.data = std::span<const uint8_t>(data, 16);
  std::array<uint8_t, protocol::kMaxWireFrameBytes> wire{};
  const Result<size_t> n = protocol::EncodeBlobData(in, 9, wire);
  ASSERT_TRUE(n.ok());
  protocol::Decoder d;
  const protocol::FrameView f = DecodeOne(std::span<const uint8_t>(wire.data(), *n), d);
  EXPECT_EQ(f.type, MsgType::kBlobData);
  protocol::BlobData out;
  ASSERT_TRUE(protocol::ParseBlobData(f.payload, out).ok());
  EXPECT_EQ(out.cmd_seq, 41u);
  EXPECT_EQ(out.total_len, 65552u);
  EXPECT_EQ(out.blob_crc32, 0xA1B2C3D4u);
  EXPECT_EQ(out.offset, 65536u);
  EXPECT_TRUE(std::equal(out.data.begin(), out.data.end(), data, data + 16));
  // One byte past the blob's end, an unknown target, 513 bytes: refused.
  std::vector<uint8_t> p(f.payload.begin(), f.payload.end());
  p.push_back(0);
  EXPECT_STREQ(protocol::ParseBlobData(p, out).message(),
               "blob data: bytes beyond the blob's length");
  p.pop_back();
  p[4] = 4;
  EXPECT_STREQ(protocol::ParseBlobData(p, out).message(), "blob data: target not 1, 2 or 3");
  in.data = std::span<const uint8_t>(data, protocol::kBlobDataBytes + 1);
  EXPECT_FALSE(protocol::EncodeBlobData(in, 0, wire).ok());
  // The read command's layout.
  const Result<size_t> r = protocol::EncodeReadBlob({2, 1024, 512}, 5, wire);
  ASSERT_TRUE(r.ok());
  protocol::Decoder d2;
  const protocol::FrameView rf = DecodeOne(std::span<const uint8_t>(wire.data(), *r), d2);
  EXPECT_EQ(rf.type, MsgType::kReadBlob);
  protocol::ReadBlobRequest req;
  ASSERT_TRUE(protocol::ParseReadBlob(rf.payload, req).ok());
  EXPECT_EQ(req.target, 2);
  EXPECT_EQ(req.offset, 1024u);
  EXPECT_EQ(req.length, 512);
  EXPECT_FALSE(protocol::ParseReadBlob(rf.payload.first(6), req).ok());
}

TEST(LinkMessages, CommandRepliesParseAsEncoded) {
  std::array<uint8_t, protocol::kMaxWireFrameBytes> wire{};
  protocol::CommandReply r;
  const Result<size_t> e = protocol::EncodeCommandReply(MsgType::kReadBlob, 77,
                                                        CommandError::kBadOffset, 65556, 3, wire);
  ASSERT_TRUE(e.ok());
  protocol::Decoder d;
  ASSERT_TRUE(protocol::ParseCommandReply(DecodeOne({wire.data(), *e}, d), r).ok());
  EXPECT_EQ(r.cmd_type, MsgType::kReadBlob);
  EXPECT_EQ(r.cmd_seq, 77u);
  EXPECT_EQ(r.error, CommandError::kBadOffset);
  EXPECT_EQ(r.detail, 65556u);
  const Result<size_t> a =
      protocol::EncodeCommandReply(MsgType::kCaptureStart, 5, CommandError::kNone, 0, 4, wire);
  ASSERT_TRUE(a.ok());
  protocol::Decoder d2;
  ASSERT_TRUE(protocol::ParseCommandReply(DecodeOne({wire.data(), *a}, d2), r).ok());
  EXPECT_EQ(r.cmd_type, MsgType::kCaptureStart);
  EXPECT_EQ(r.error, CommandError::kNone);
  protocol::FrameView other;  // another type, or a reply of the wrong length
  other.type = MsgType::kBallState;
  EXPECT_FALSE(protocol::ParseCommandReply(other, r).ok());
  other.type = MsgType::kError;
  EXPECT_FALSE(protocol::ParseCommandReply(other, r).ok());
}

TEST(LinkMessages, CaptureChunkBounds) {
  uint8_t data[protocol::kCaptureChunkBytes + 1] = {};
  protocol::CaptureChunk c;
  c.data = std::span<const uint8_t>(data, protocol::kCaptureChunkBytes + 1);
  std::array<uint8_t, protocol::kMaxWireFrameBytes> wire{};
  EXPECT_FALSE(protocol::EncodeCaptureChunk(c, 0, wire).ok());
  // A chunk that would run past the end of a 640x480 image.
  uint8_t p[protocol::kCaptureChunkHeaderBytes + 16] = {};
  ByteWriter w(p);
  w.U16(1), w.U16(0), w.U8(0), w.U8(0), w.U32(kFrameBytes - 8);
  protocol::CaptureChunk out;
  EXPECT_STREQ(protocol::ParseCaptureChunk(p, out).message(),
               "capture chunk: beyond a 640x480 image");
  ByteWriter w2(p);
  w2.U16(1), w2.U16(0), w2.U8(2), w2.U8(0), w2.U32(0);
  EXPECT_STREQ(protocol::ParseCaptureChunk(p, out).message(),
               "capture chunk: camera not 0/1 or reserved set");
}

// Decimation against a per-pixel reading of the source: every byte of the source encodes its
// own position, so any index slip shows.
TEST(LinkMessages, DecimationKeepsEveryKthPixelAndItsChroma) {
  const size_t stride = 1280 + 64;  // padded rows, as the H7's merged frames
  std::vector<uint8_t> src(stride * 480);
  for (size_t i = 0; i < src.size(); ++i) src[i] = static_cast<uint8_t>((i * 2654435761u) >> 13);
  for (CaptureMode mode : {CaptureMode::kFull, CaptureMode::kHalf, CaptureMode::kQuarter}) {
    uint16_t w = 0, h = 0;
    ASSERT_TRUE(protocol::CaptureSize(mode, w, h));
    const int k = 640 / w;
    std::vector<uint8_t> out(size_t{w} * h * 2);
    // In odd pieces, so pieces start mid-row and mid-macropixel.
    for (size_t off = 0; off < out.size(); off += 333) {
      const size_t n = std::min<size_t>(333, out.size() - off);
      ASSERT_TRUE(protocol::CopyCaptureBytes(src.data(), stride, mode, off,
                                             std::span<uint8_t>(out.data() + off, n)));
    }
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const uint8_t* srow = src.data() + size_t(k * y) * stride;
        const int sx = k * x;
        const uint8_t* o = out.data() + (size_t(y) * w + x) * 2;
        ASSERT_EQ(o[0], srow[2 * sx]) << "Y at " << x << "," << y << " mode " << int(mode);
        const int sm = (k * (x - x % 2)) / 2;  // source macropixel of the output pair's first pixel
        ASSERT_EQ(o[1], srow[4 * sm + (x % 2 == 0 ? 1 : 3)]) << "chroma at " << x << "," << y;
      }
    }
    EXPECT_FALSE(protocol::CopyCaptureBytes(src.data(), stride, mode, out.size() - 4,
                                            std::span<uint8_t>(out.data(), 8)));
  }
}

// --- command handling ---

class NoUploads : public protocol::UploadSink {
 public:
  size_t capacity(protocol::UploadTarget) const override { return 0; }
  Status Begin(protocol::UploadTarget, size_t) override { return Status(); }
  Status Write(protocol::UploadTarget, size_t, std::span<const uint8_t>) override {
    return Status();
  }
  Status Commit(protocol::UploadTarget, uint32_t) override { return Status(); }
  void Abort(protocol::UploadTarget) override {}
};
class NoParams : public protocol::ParamSink {
 public:
  Status SetParam(uint16_t, float) override { return Status(StatusCode::kNotFound, "none"); }
};
class CaptureRecorder : public protocol::CaptureSink {
 public:
  bool running = false;
  bool can_hold = true;
  int starts = 0;
  protocol::CaptureRequest last;
  Status StartCapture(const protocol::CaptureRequest& r) override {
    if (running) return Status(StatusCode::kFailedPrecondition, "running");
    if (!can_hold) return Status(StatusCode::kUnimplemented, "no");
    running = true;
    ++starts;
    last = r;
    return Status();
  }
  Status StopCapture() override {
    if (!running) return Status(StatusCode::kFailedPrecondition, "none");
    running = false;
    return Status();
  }
};

class LinkCommands : public ::testing::Test {
 protected:
  // The reply's error code (kNone for an ack or no reply); `result` gets the handler's result.
  CommandError Send(MsgType type, std::span<const uint8_t> payload,
                    protocol::CommandResult* result = nullptr, uint32_t* detail = nullptr) {
    std::array<uint8_t, protocol::kMaxWireFrameBytes> reply{};
    size_t len = 0;
    const protocol::CommandResult r =
        handler_.Handle(protocol::FrameView{type, 9, payload}, 0, reply, len);
    if (result != nullptr) *result = r;
    if (len == 0) return CommandError::kNone;
    protocol::Decoder d;
    const protocol::FrameView f = DecodeOne(std::span<const uint8_t>(reply.data(), len), d);
    if (f.type != MsgType::kError) return CommandError::kNone;
    ByteReader rd(f.payload);
    rd.U8(), rd.U32();
    const auto code = static_cast<CommandError>(rd.U8());
    if (detail != nullptr) *detail = rd.U32();
    return code;
  }
  CommandError Start(uint16_t count, uint8_t mode, uint8_t cameras, uint32_t* detail = nullptr) {
    uint8_t p[4] = {static_cast<uint8_t>(count), static_cast<uint8_t>(count >> 8), mode, cameras};
    return Send(MsgType::kCaptureStart, p, nullptr, detail);
  }
  NoUploads uploads_;
  NoParams params_;
  CaptureRecorder capture_;
  protocol::CommandHandler handler_{uploads_, params_, nullptr, &capture_};
};

TEST_F(LinkCommands, ClockSyncIsHandedToTheCallerWithoutAck) {
  uint8_t p[12];
  ByteWriter w(p);
  w.U32(41), w.U64(123456789);
  protocol::CommandResult r;
  EXPECT_EQ(Send(MsgType::kClockSync, p, &r), CommandError::kNone);
  EXPECT_TRUE(r.clock_sync);
  EXPECT_EQ(r.sync.id, 41u);
  EXPECT_EQ(r.sync.t1_host_us, 123456789u);
  EXPECT_EQ(Send(MsgType::kClockSync, std::span<const uint8_t>(p, 11), &r),
            CommandError::kBadLength);
  EXPECT_FALSE(r.clock_sync);
}

TEST_F(LinkCommands, CaptureRequestsAreBoundedAndExclusive) {
  uint32_t detail = 0;
  EXPECT_EQ(Start(0, 0, 3), CommandError::kBadValue);
  EXPECT_EQ(Start(protocol::kMaxCapturePairs + 1, 0, 3, &detail), CommandError::kBadValue);
  EXPECT_EQ(detail, protocol::kMaxCapturePairs);  // the limit, for the sender's message
  EXPECT_EQ(Start(65535, 0, 3), CommandError::kBadValue);
  EXPECT_EQ(Start(1, 4, 3), CommandError::kBadValue);  // no such mode (3 is scanlines)
  EXPECT_EQ(Start(1, 0, 0), CommandError::kBadValue);  // no camera
  EXPECT_EQ(Start(1, 0, 4), CommandError::kBadValue);
  EXPECT_EQ(capture_.starts, 0) << "a refused request must not reach the loop";
  EXPECT_EQ(Start(protocol::kMaxCapturePairs, 2, 1), CommandError::kNone);
  EXPECT_EQ(capture_.last.mode, CaptureMode::kQuarter);
  EXPECT_EQ(capture_.last.cameras, 1);
  EXPECT_EQ(Start(1, 0, 3), CommandError::kBusy);
  EXPECT_EQ(capture_.starts, 1);
  EXPECT_EQ(Send(MsgType::kCaptureStop, {}), CommandError::kNone);
  EXPECT_EQ(Send(MsgType::kCaptureStop, {}), CommandError::kNotRunning);
  uint8_t one = 0;
  EXPECT_EQ(Send(MsgType::kCaptureStop, std::span<const uint8_t>(&one, 1)),
            CommandError::kBadLength);
  EXPECT_EQ(Start(2, 3, 3), CommandError::kNone);
  EXPECT_EQ(capture_.last.mode, CaptureMode::kScanlines);
  EXPECT_EQ(Send(MsgType::kCaptureStop, {}), CommandError::kNone);
  capture_.can_hold = false;
  EXPECT_EQ(Start(1, 0, 3), CommandError::kUnsupported);
}

// --- the estimator ---

// A simulated exchange: true host time t (µs), device clock dev(t) = dev0 + t * (1 + ppm),
// path delays given; returns the reply as the coprocessor would send it.
struct SimLink {
  double dev0 = 4e6;
  double ppm = 50;
  int64_t host0 = 1'700'000'000'000'000;
  double byte_us = 10.0 / 921600.0 * 1e6;
  double dev(double t) const { return dev0 + t * (1.0 + ppm * 1e-6); }
  // out / back: latencies beyond the wire time; hold: reply queued at the coprocessor.
  ClockSyncReply Exchange(ClockSync& s, uint32_t id, double t, double out, double back, double hold,
                          int64_t& t4) const {
    const double req = byte_us * protocol::WireFrameBytes(protocol::kClockSyncRequestBytes);
    const double rep = byte_us * protocol::WireFrameBytes(protocol::kClockSyncReplyBytes);
    const int64_t t1 = host0 + static_cast<int64_t>(t);
    s.OnRequestSent(id, t1);
    const double arrive = t + out + req;
    ClockSyncReply r{id, static_cast<uint64_t>(t1), static_cast<uint64_t>(dev(arrive)),
                     static_cast<uint64_t>(dev(arrive + 300))};
    t4 = host0 + static_cast<int64_t>(arrive + 300 + hold + rep + back);
    return r;
  }
  // Host time error of the estimate for an event at true time t.
  double Error(const ClockSync& s, double t) const {
    const double d = dev(t);
    return static_cast<double>(s.ToHostTime(static_cast<uint64_t>(d))) + (d - std::floor(d)) -
           (static_cast<double>(host0) + t);
  }
};

TEST(ClockSync, SymmetricDelaysGiveOffsetAndDrift) {
  SimLink link;
  ClockSync s;
  int64_t t4 = 0;
  for (uint32_t i = 0; i < 100; ++i) {  // 10 s at 10 Hz
    const ClockSyncReply r = link.Exchange(s, i, i * 1e5, 200, 200, 0, t4);
    ASSERT_EQ(s.OnReply(r, t4), ClockSync::Verdict::kAccepted);
  }
  EXPECT_NEAR(link.Error(s, 10e6), 0.0, 2.0);  // µs: integer timestamps only
  // Device runs 50 ppm fast: host advances 1/(1+50e-6) - 1 = -49.9975 ppm per device µs.
  EXPECT_NEAR(s.DriftPpm(), -49.9975, 0.3);
  EXPECT_EQ(s.accepted(), 100u);
}

TEST(ClockSync, MinimumDelayExchangesDecideUnderAsymmetricJitter) {
  SimLink link;
  ClockSync s;
  std::mt19937 rng(5);
  std::exponential_distribution<double> jitter(1.0 / 2000.0);  // mean 2 ms, one way only
  std::uniform_real_distribution<double> u(0, 1);
  int64_t t4 = 0;
  double naive_sum = 0;
  int n = 0;
  for (uint32_t i = 0; i < 600; ++i) {  // 60 s
    const double back = 150 + jitter(rng);
    const double hold = u(rng) < 0.3 ? u(rng) * 10000 : 0;  // queued behind a capture chunk
    const ClockSyncReply r = link.Exchange(s, i, i * 1e5, 150, back, hold, t4);
    ASSERT_NE(s.OnReply(r, t4), ClockSync::Verdict::kRestarted) << "exchange " << i;
    // What plain averaging of the NTP offsets would give, for comparison.
    naive_sum += (back + hold - 150) / 2;
    ++n;
  }
  const double err = link.Error(s, 60e6);
  EXPECT_LT(std::fabs(err), 60.0) << "minimum-delay fit";
  EXPECT_GT(naive_sum / n, 10 * std::fabs(err)) << "the jitter must matter to a naive mean";
  EXPECT_NEAR(s.DriftPpm(), -49.9975, 2.0);
}

TEST(ClockSync, DuplicateUnknownAndMismatchedRepliesAreRefused) {
  SimLink link;
  ClockSync s;
  int64_t t4a = 0, t4b = 0;
  const ClockSyncReply a = link.Exchange(s, 1, 0, 200, 200, 0, t4a);
  const ClockSyncReply b = link.Exchange(s, 2, 1e5, 200, 200, 0, t4b);
  // b arrives before a (out of order): both are good exchanges.
  EXPECT_EQ(s.OnReply(b, t4b), ClockSync::Verdict::kAccepted);
  EXPECT_EQ(s.OnReply(a, t4a + 100000), ClockSync::Verdict::kAccepted);
  EXPECT_EQ(s.OnReply(b, t4b + 5000), ClockSync::Verdict::kDuplicate);
  ClockSyncReply stranger = b;
  stranger.id = 77;
  EXPECT_EQ(s.OnReply(stranger, t4b), ClockSync::Verdict::kUnknownId);
  int64_t t4c = 0;
  ClockSyncReply c = link.Exchange(s, 3, 2e5, 200, 200, 0, t4c);
  c.t1_host_us += 1;  // not the time this id was sent with
  EXPECT_EQ(s.OnReply(c, t4c), ClockSync::Verdict::kMismatch);
  c.t1_host_us -= 1;
  EXPECT_EQ(s.OnReply(c, c.t1_host_us - 1), ClockSync::Verdict::kInconsistent);  // t4 < t1
  EXPECT_EQ(s.OnReply(c, t4c), ClockSync::Verdict::kAccepted);
  EXPECT_EQ(s.duplicates(), 1u);
  EXPECT_EQ(s.unknown(), 1u);
  EXPECT_EQ(s.rejected(), 2u);
  EXPECT_EQ(s.accepted(), 3u);
  EXPECT_NEAR(link.Error(s, 2e5), 0.0, 15.0) << "the late duplicate must not have entered";
}

TEST(ClockSync, CoprocessorResetRestartsTheEstimate) {
  SimLink link;
  ClockSync s;
  int64_t t4 = 0;
  for (uint32_t i = 0; i < 50; ++i) {
    const ClockSyncReply r = link.Exchange(s, i, i * 1e5, 200, 200, 0, t4);
    ASSERT_EQ(s.OnReply(r, t4), ClockSync::Verdict::kAccepted);
  }
  link.dev0 = 1000 - 5e6 * (1 + link.ppm * 1e-6);  // rebooted at t = 5 s: uptime 1 ms
  link.ppm = 20;
  bool restarted = false;
  for (uint32_t i = 50; i < 100; ++i) {
    const ClockSyncReply r = link.Exchange(s, i, i * 1e5, 200, 200, 0, t4);
    const ClockSync::Verdict v = s.OnReply(r, t4);
    if (i == 50) {
      EXPECT_EQ(v, ClockSync::Verdict::kHeld) << "one odd exchange is not enough";
    } else if (i == 51) {
      EXPECT_EQ(v, ClockSync::Verdict::kRestarted);
      restarted = true;
    } else {
      ASSERT_EQ(v, ClockSync::Verdict::kAccepted) << "exchange " << i;
    }
  }
  EXPECT_TRUE(restarted);
  EXPECT_EQ(s.restarts(), 1u);
  EXPECT_EQ(s.samples(), 50u) << "only exchanges after the reset";
  EXPECT_NEAR(link.Error(s, 10e6), 0.0, 3.0);
  EXPECT_NEAR(s.DriftPpm(), -19.9996, 0.5);
}

TEST(ClockSync, OneOutlierIsHeldThenDropped) {
  SimLink link;
  ClockSync s;
  int64_t t4 = 0;
  for (uint32_t i = 0; i < 30; ++i) {
    const ClockSyncReply r = link.Exchange(s, i, i * 1e5, 200, 200, 0, t4);
    ASSERT_EQ(s.OnReply(r, t4), ClockSync::Verdict::kAccepted);
  }
  ClockSyncReply odd = link.Exchange(s, 30, 30e5, 200, 200, 0, t4);
  odd.t2_rx_us += 20000, odd.t3_tx_us += 20000;  // e.g. a stamp from the wrong frame
  EXPECT_EQ(s.OnReply(odd, t4), ClockSync::Verdict::kHeld);
  const ClockSyncReply next = link.Exchange(s, 31, 31e5, 200, 200, 0, t4);
  EXPECT_EQ(s.OnReply(next, t4), ClockSync::Verdict::kAccepted);
  EXPECT_EQ(s.restarts(), 0u);
  EXPECT_EQ(s.outliers(), 1u);
  EXPECT_EQ(s.rejected(), 0u) << "a delayed answer is not a fault";
  EXPECT_FALSE(s.holding());
  EXPECT_EQ(s.samples(), 31u);
  EXPECT_NEAR(link.Error(s, 31e5), 0.0, 3.0);
}

TEST(ClockSync, SmallDriftChangesDoNotLookLikeJumps) {
  // 150 ppm between exchanges 10 s apart: 1.5 ms, inside the jump test's drift allowance.
  SimLink link;
  link.ppm = 150;
  ClockSync s;
  int64_t t4 = 0;
  for (uint32_t i = 0; i < 8; ++i) {
    const ClockSyncReply r = link.Exchange(s, i, i * 10e6, 200, 200, 0, t4);
    ASSERT_EQ(s.OnReply(r, t4), ClockSync::Verdict::kAccepted);
  }
}

}  // namespace
}  // namespace bv
