#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/protocol/protocol.h"

namespace bv::protocol {
namespace {

BallState SampleState(uint64_t t) {
  BallState s;
  s.t_us = t;
  s.found = true;
  s.x_m = 0.25f, s.y_m = 3.5f, s.z_m = 0.11f;
  s.vx_mps = -1.f, s.vy_mps = 0.5f, s.vz_mps = 0.f;
  s.mode = BallMode::kRolling;
  s.flags = kFlagSeenOmni | kFlagTriangulated | kFlagSeenPersp;
  s.ray_gap_m = 0.004f;
  s.omni = {true, 100.5f, 200.25f, 30, 3, 0.9f, 1};
  s.persp = {true, 300.f, 240.f, 30, 3, 0.9f, 1};
  s.proc_us = 1234;
  return s;
}

std::vector<uint8_t> Encode(const BallState& s, uint32_t seq) {
  std::vector<uint8_t> out(kMaxWireFrameBytes);
  auto n = EncodeBallState(s, seq, out);
  EXPECT_TRUE(n.ok());
  out.resize(*n);
  return out;
}

TEST(Cobs, RoundTripAllLengthsAndZeroPatterns) {
  std::mt19937 rng(1);
  for (size_t len = 0; len < 700; len += (len < 300 ? 1 : 37)) {
    for (int pattern = 0; pattern < 3; ++pattern) {
      std::vector<uint8_t> in(len);
      for (auto& b : in)
        b = pattern == 0 ? 0 : pattern == 1 ? uint8_t(1 + rng() % 255) : uint8_t(rng());
      std::vector<uint8_t> enc(len + len / 254 + 2), dec(len + 1);
      auto n = CobsEncode(in, enc);
      ASSERT_TRUE(n.ok());
      for (size_t i = 0; i < *n; ++i) ASSERT_NE(enc[i], 0) << "len " << len;
      auto m = CobsDecode({enc.data(), *n}, dec);
      ASSERT_TRUE(m.ok()) << len;
      ASSERT_EQ(*m, len);
      if (len > 0) {
        EXPECT_EQ(0, std::memcmp(in.data(), dec.data(), len));
      }
    }
  }
}

TEST(Protocol, BallStateRoundTripIsBitExact) {
  const BallState s = SampleState(123456789);
  auto wire = Encode(s, 7);
  EXPECT_EQ(wire.back(), 0);
  Decoder d;
  FrameView f;
  int frames = 0;
  for (uint8_t b : wire) frames += d.Push(b, f);
  ASSERT_EQ(frames, 1);
  EXPECT_EQ(f.type, MsgType::kBallState);
  EXPECT_EQ(f.seq, 7u);
  BallState r;
  ASSERT_TRUE(ParseBallState(f.payload, r).ok());
  EXPECT_EQ(r.t_us, s.t_us);
  EXPECT_EQ(r.x_m, s.x_m);
  EXPECT_EQ(r.y_m, s.y_m);
  EXPECT_EQ(r.mode, s.mode);
  EXPECT_EQ(r.flags, s.flags);
  EXPECT_EQ(r.omni.u_px, s.omni.u_px);
  EXPECT_EQ(r.proc_us, s.proc_us);
}

TEST(Protocol, StatusRoundTrip) {
  StatusReport s;
  s.uptime_us = 99;
  s.frames_dropped = 3;
  s.deadline_overruns = 2;
  s.calibration_id = 0xDEADBEEF;
  s.lut_state = static_cast<uint8_t>(BlobState::kCorrupt);
  s.fault_flags = 5;
  s.rx_overruns = 7;
  s.rx_ring_full = 11;
  s.rx_line_errors = 13;
  std::vector<uint8_t> out(kMaxWireFrameBytes);
  auto n = EncodeStatus(s, 1, out);
  ASSERT_TRUE(n.ok());
  Decoder d;
  FrameView f;
  bool got = false;
  for (size_t i = 0; i < *n; ++i) got |= d.Push(out[i], f);
  ASSERT_TRUE(got);
  StatusReport r;
  ASSERT_TRUE(ParseStatus(f.payload, r).ok());
  EXPECT_EQ(r.frames_dropped, 3u);
  EXPECT_EQ(r.deadline_overruns, 2u);
  EXPECT_EQ(r.calibration_id, 0xDEADBEEFu);
  EXPECT_EQ(r.lut_state, static_cast<uint8_t>(BlobState::kCorrupt));
  EXPECT_EQ(r.fault_flags, 5u);
  EXPECT_EQ(r.rx_overruns, 7u);
  EXPECT_EQ(r.rx_ring_full, 11u);
  EXPECT_EQ(r.rx_line_errors, 13u);
  EXPECT_EQ(f.payload.size(), kStatusPayloadBytes);
}

TEST(Protocol, RejectsNaNAndBadLengths) {
  BallState s = SampleState(1);
  s.x_m = NAN;
  auto wire = Encode(s, 1);
  Decoder d;
  FrameView f;
  bool got = false;
  for (uint8_t b : wire) got |= d.Push(b, f);
  ASSERT_TRUE(got);  // the frame is intact; the payload check refuses it
  BallState r;
  EXPECT_EQ(ParseBallState(f.payload, r).code(), StatusCode::kInvalidArgument);
  EXPECT_FALSE(ParseBallState(f.payload.first(10), r).ok());
  std::vector<uint8_t> big(kMaxPayloadBytes + 1), out(2 * kMaxWireFrameBytes);
  EXPECT_EQ(EncodeFrame(MsgType::kBallState, 0, big, out).status().code(),
            StatusCode::kInvalidArgument);
  std::vector<uint8_t> tiny(10);
  EXPECT_EQ(EncodeBallState(SampleState(1), 0, tiny).status().code(),
            StatusCode::kResourceExhausted);
}

// A seeded corrupter: 1 % byte flips, dropped and inserted bytes. No corrupt packet may be
// accepted, and the decoder must resync within one packet after every corruption.
TEST(Protocol, CorruptLinkNeverAcceptsBadPacketsAndResyncs) {
  std::mt19937 rng(42);
  std::vector<uint8_t> link;
  std::vector<bool> packet_damaged;
  const int kPackets = 3000;
  for (int i = 0; i < kPackets; ++i) {
    auto wire = Encode(SampleState(1000u * static_cast<uint64_t>(i)), static_cast<uint32_t>(i));
    bool damaged = false;
    std::vector<uint8_t> sent;
    for (uint8_t b : wire) {
      const uint32_t roll = rng() % 1000;
      if (roll < 4) {  // flip
        sent.push_back(static_cast<uint8_t>(b ^ (1u + rng() % 255)));
        damaged = true;
      } else if (roll < 7) {  // drop
        damaged = true;
      } else if (roll < 10) {  // insert a random byte before this one
        sent.push_back(static_cast<uint8_t>(rng()));
        sent.push_back(b);
        damaged = true;
      } else {
        sent.push_back(b);
      }
    }
    link.insert(link.end(), sent.begin(), sent.end());
    packet_damaged.push_back(damaged);
  }
  Decoder d;
  FrameView f;
  std::vector<bool> received(kPackets, false);
  int accepted = 0;
  for (uint8_t b : link) {
    if (!d.Push(b, f)) continue;
    ASSERT_EQ(f.type, MsgType::kBallState);
    BallState s;
    ASSERT_TRUE(ParseBallState(f.payload, s).ok());
    ASSERT_LT(f.seq, static_cast<uint32_t>(kPackets));
    // The accepted packet must be exactly what was sent with that sequence number.
    ASSERT_EQ(s.t_us, 1000u * f.seq);
    ASSERT_EQ(s.x_m, 0.25f);
    received[f.seq] = true;
    ++accepted;
  }
  // Resync within one packet: every packet that arrived undamaged and whose predecessor's
  // delimiter arrived is decoded.
  int undamaged = 0, lost_undamaged = 0;
  for (int i = 1; i < kPackets; ++i) {
    if (packet_damaged[i]) continue;
    ++undamaged;
    if (!received[i]) ++lost_undamaged;
  }
  EXPECT_EQ(accepted, undamaged - lost_undamaged + (received[0] ? 1 : 0));
  // An undamaged packet can only be lost if the previous packet's trailing 0x00 was dropped
  // (then both merge into one bad frame). That needs the drop to hit that one byte.
  EXPECT_LT(lost_undamaged, undamaged / 100 + 5);
  EXPECT_GT(d.stats().errors(), 0u);
  printf("packets %d, undamaged %d, accepted %d, lost undamaged %d, decoder errors %u\n", kPackets,
         undamaged, accepted, lost_undamaged, d.stats().errors());
}

TEST(Protocol, OversizeGarbageIsDiscardedAndDecoderRecovers) {
  Decoder d;
  FrameView f;
  for (int i = 0; i < 5000; ++i) EXPECT_FALSE(d.Push(0x55, f));
  EXPECT_FALSE(d.Push(0, f));
  EXPECT_EQ(d.stats().oversize, 1u);
  auto wire = Encode(SampleState(5), 9);
  bool got = false;
  for (uint8_t b : wire) got |= d.Push(b, f);
  EXPECT_TRUE(got);
  EXPECT_EQ(f.seq, 9u);
}

}  // namespace
}  // namespace bv::protocol

namespace bv::protocol {
namespace {

// The byte-level example of docs/protocol.md and the fixture the Python decoder is tested on:
// the encoder must reproduce it exactly (a layout change must update both, knowingly).
TEST(Protocol, GoldenStreamMatchesCommittedFixture) {
  std::vector<uint8_t> stream(2 * kMaxWireFrameBytes);
  BallState s = SampleState(1000000);
  s.flags |= kFlagHasBounce;
  s.t_bounce_us = 1250000;
  auto a = EncodeBallState(s, 41, stream);
  ASSERT_TRUE(a.ok());
  StatusReport st;
  st.uptime_us = 1000000;
  st.frames_processed = 30;
  st.frame_rate_mhz = 30000;
  st.calibration_id = 0x1234;
  st.rx_overruns = 1;  // the appended receive-loss fields, at distinct values
  st.rx_ring_full = 2;
  st.rx_line_errors = 3;
  auto b = EncodeStatus(st, 42, std::span(stream).subspan(*a));
  ASSERT_TRUE(b.ok());
  stream.resize(*a + *b);
  const std::string path = std::string(BV_TEST_DATA_DIR) + "/protocol_golden.bin";
  FILE* f = std::fopen(path.c_str(), "rb");
  if (!f && std::getenv("BV_REGENERATE_GOLDEN")) {
    f = std::fopen(path.c_str(), "wb");
    std::fwrite(stream.data(), 1, stream.size(), f);
    std::fclose(f);
    GTEST_SKIP() << "regenerated " << path;
  }
  ASSERT_NE(f, nullptr) << path;
  std::vector<uint8_t> golden(4096);
  golden.resize(std::fread(golden.data(), 1, golden.size(), f));
  std::fclose(f);
  EXPECT_EQ(golden, stream);
}

}  // namespace
}  // namespace bv::protocol
