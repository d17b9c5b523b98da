#include <array>
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "core/common/bytes.h"
#include "core/common/crc32.h"
#include "core/protocol/commands.h"

namespace bv::protocol {
namespace {

// Stages uploads in a separate buffer and swaps them in only on a verified commit, like the
// firmware's A/B store.
class RamSink : public UploadSink {
 public:
  std::vector<uint8_t> active = {1, 2, 3};
  std::vector<uint8_t> staging;
  size_t capacity(UploadTarget) const override { return 4096; }
  Status Begin(UploadTarget, size_t n) override {
    staging.assign(n, 0xFF);
    return Status();
  }
  Status Write(UploadTarget, size_t off, std::span<const uint8_t> d) override {
    std::copy(d.begin(), d.end(), staging.begin() + static_cast<ptrdiff_t>(off));
    return Status();
  }
  Status Commit(UploadTarget, uint32_t crc) override {
    if (Crc32(staging) != crc) return Status(StatusCode::kDataLoss, "crc");
    active = staging;
    return Status();
  }
  void Abort(UploadTarget) override { staging.clear(); }
};

class Params : public ParamSink {
 public:
  float gain = 1;
  Status SetParam(uint16_t id, float v) override {
    if (id != 7) return Status(StatusCode::kNotFound, "param");
    if (v < 0 || v > 10) return Status(StatusCode::kOutOfRange, "range");
    gain = v;
    return Status();
  }
};

struct Reply {
  MsgType type;
  CommandError error;
};

// One command through `h`, its reply decoded (no reply: reported as a status stand-in).
Reply Exchange(CommandHandler& h, const FrameView& f, CommandResult* result = nullptr) {
  std::array<uint8_t, kMaxWireFrameBytes> reply{};
  size_t len = 0;
  const CommandResult res = h.Handle(f, 0, reply, len);
  if (result != nullptr) *result = res;
  if (len == 0) return {MsgType::kStatus, CommandError::kNone};
  Decoder d;
  FrameView r;
  bool got = false;
  for (size_t i = 0; i < len; ++i) got |= d.Push(reply[i], r);
  EXPECT_TRUE(got);
  Reply out{r.type, CommandError::kNone};
  if (r.type == MsgType::kError) out.error = static_cast<CommandError>(r.payload[5]);
  return out;
}

class CommandsTest : public ::testing::Test {
 protected:
  Reply Send(MsgType type, std::span<const uint8_t> payload) {
    return Exchange(handler_, FrameView{type, seq_++, payload}, &last_);
  }
  Reply Begin(size_t len, uint32_t crc, uint8_t target = 1) {
    uint8_t p[9];
    ByteWriter w(p);
    w.U8(target), w.U32(static_cast<uint32_t>(len)), w.U32(crc);
    return Send(MsgType::kUploadBegin, p);
  }
  Reply Chunk(size_t offset, std::span<const uint8_t> data) {
    std::vector<uint8_t> p(5 + data.size());
    ByteWriter w(p);
    w.U8(1), w.U32(static_cast<uint32_t>(offset)), w.Bytes(data);
    return Send(MsgType::kUploadChunk, p);
  }
  Reply Commit() {
    const uint8_t p[1] = {1};
    return Send(MsgType::kUploadCommit, p);
  }

  RamSink sink_;
  Params params_;
  CommandHandler handler_{sink_, params_};
  CommandResult last_;
  uint32_t seq_ = 0;
};

TEST_F(CommandsTest, ChunkedUploadActivatesOnlyAfterVerifiedCommit) {
  std::vector<uint8_t> blob(1500);
  for (size_t i = 0; i < blob.size(); ++i) blob[i] = static_cast<uint8_t>(i * 7);
  EXPECT_EQ(Begin(blob.size(), Crc32(blob)).type, MsgType::kAck);
  for (size_t off = 0; off < blob.size(); off += kMaxChunkBytes) {
    const size_t n = std::min(kMaxChunkBytes, blob.size() - off);
    EXPECT_EQ(Chunk(off, std::span(blob).subspan(off, n)).type, MsgType::kAck);
    EXPECT_EQ(sink_.active, (std::vector<uint8_t>{1, 2, 3})) << "nothing visible before commit";
  }
  EXPECT_EQ(Commit().type, MsgType::kAck);
  EXPECT_EQ(sink_.active, blob);
}

TEST_F(CommandsTest, UploadCutHalfwayKeepsOldData) {
  std::vector<uint8_t> blob(1000, 0xAB);
  EXPECT_EQ(Begin(blob.size(), Crc32(blob)).type, MsgType::kAck);
  EXPECT_EQ(Chunk(0, std::span(blob).first(500)).type, MsgType::kAck);
  EXPECT_EQ(Commit().error, CommandError::kIncomplete);
  EXPECT_EQ(sink_.active, (std::vector<uint8_t>{1, 2, 3}));
  // The link drops, a new upload starts: the old one is abandoned cleanly.
  EXPECT_EQ(Begin(blob.size(), Crc32(blob) ^ 1).type, MsgType::kAck);
  EXPECT_EQ(Chunk(0, std::span(blob).first(500)).type, MsgType::kAck);
  EXPECT_EQ(Chunk(500, std::span(blob).subspan(500)).type, MsgType::kAck);
  EXPECT_EQ(Commit().error, CommandError::kVerifyFailed) << "wrong total CRC";
  EXPECT_EQ(sink_.active, (std::vector<uint8_t>{1, 2, 3}));
}

TEST_F(CommandsTest, BadCommandsGetErrorRepliesAndChangeNothing) {
  const uint8_t junk[3] = {9, 9, 9};
  EXPECT_EQ(Send(static_cast<MsgType>(0x7F), junk).error, CommandError::kUnknownCommand);
  EXPECT_EQ(Send(MsgType::kRequestStatus, junk).error, CommandError::kBadLength);
  EXPECT_EQ(Send(MsgType::kUploadBegin, junk).error, CommandError::kBadLength);
  EXPECT_EQ(Begin(100000, 0).error, CommandError::kTooLarge);
  EXPECT_EQ(Begin(10, 0, 9).error, CommandError::kBadTarget);
  EXPECT_EQ(Chunk(0, junk).error, CommandError::kNoUpload);
  EXPECT_EQ(Commit().error, CommandError::kNoUpload);
  EXPECT_EQ(Begin(10, 0).type, MsgType::kAck);
  EXPECT_EQ(Chunk(4, junk).error, CommandError::kBadOffset);
  std::vector<uint8_t> big(11);
  EXPECT_EQ(Chunk(0, big).error, CommandError::kTooLarge);
  EXPECT_EQ(sink_.active, (std::vector<uint8_t>{1, 2, 3}));

  uint8_t set[6];
  ByteWriter w(set);
  w.U16(7), w.F32(NAN);
  EXPECT_EQ(Send(MsgType::kSetParam, set).error, CommandError::kBadValue);
  ByteWriter w2(set);
  w2.U16(8), w2.F32(1);
  EXPECT_EQ(Send(MsgType::kSetParam, set).error, CommandError::kUnknownParam);
  ByteWriter w3(set);
  w3.U16(7), w3.F32(2.5f);
  EXPECT_EQ(Send(MsgType::kSetParam, set).type, MsgType::kAck);
  EXPECT_EQ(params_.gain, 2.5f);
  EXPECT_GE(handler_.errors(), 10u);

  EXPECT_EQ(Send(MsgType::kRequestStatus, {}).type, MsgType::kStatus);
  EXPECT_TRUE(last_.send_status);
}

TEST_F(CommandsTest, RandomCommandsNeverCorruptActiveData) {
  std::mt19937 rng(5);
  for (int i = 0; i < 20000; ++i) {
    std::vector<uint8_t> p(rng() % 40);
    for (auto& b : p) b = static_cast<uint8_t>(rng() % 4 == 0 ? 1 : rng());
    const auto type = static_cast<MsgType>(0x20 + rng() % 6);
    Send(type, p);
  }
  // Random bytes never carry the right CRC: the old data must still be active.
  EXPECT_EQ(sink_.active, (std::vector<uint8_t>{1, 2, 3}));
}

}  // namespace
}  // namespace bv::protocol

namespace bv::protocol {
namespace {

// Records what reached it; refuses nothing (the handler's checks are under test).
class PoseRecorder : public PoseSink {
 public:
  int calls = 0;
  int8_t half = 7;
  float odo[3] = {};
  bool known = false;
  float pose[3] = {};
  Status SetFieldHalf(int8_t h) override {
    ++calls;
    half = h;
    return Status();
  }
  Status SetOdometry(float dx, float dy, float dh) override {
    ++calls;
    odo[0] = dx, odo[1] = dy, odo[2] = dh;
    return Status();
  }
  Status SetRobotPose(bool k, float x, float y, float h) override {
    ++calls;
    known = k, pose[0] = x, pose[1] = y, pose[2] = h;
    return Status();
  }
};

class PoseCommandsTest : public CommandsTest {
 protected:
  Reply Half(int8_t h) {
    const uint8_t p[1] = {static_cast<uint8_t>(h)};
    return Send2(MsgType::kSetFieldHalf, p);
  }
  Reply Odometry(float dx, float dy, float dh) {
    uint8_t p[12];
    ByteWriter w(p);
    w.F32(dx), w.F32(dy), w.F32(dh);
    return Send2(MsgType::kOdometry, p);
  }
  Reply Pose(uint8_t known, float x, float y, float h) {
    uint8_t p[13];
    ByteWriter w(p);
    w.U8(known), w.F32(x), w.F32(y), w.F32(h);
    return Send2(MsgType::kSetPose, p);
  }
  Reply Send2(MsgType type, std::span<const uint8_t> payload) {
    return Exchange(pose_handler_, FrameView{type, 1, payload});
  }
  PoseRecorder rec_;
  CommandHandler pose_handler_{sink_, params_, &rec_};
};

TEST_F(PoseCommandsTest, ValidHintsReachTheSinkAndAreAcked) {
  EXPECT_EQ(Half(-1).type, MsgType::kAck);
  EXPECT_EQ(rec_.half, -1);
  EXPECT_EQ(Half(0).type, MsgType::kAck);
  EXPECT_EQ(rec_.half, 0);
  EXPECT_EQ(Odometry(0.1f, -0.05f, 0.02f).type, MsgType::kAck);
  EXPECT_EQ(rec_.odo[0], 0.1f);
  EXPECT_EQ(rec_.odo[1], -0.05f);
  EXPECT_EQ(rec_.odo[2], 0.02f);
  EXPECT_EQ(Pose(1, 3.0f, -2.0f, 1.5f).type, MsgType::kAck);
  EXPECT_TRUE(rec_.known);
  EXPECT_EQ(rec_.pose[0], 3.0f);
  EXPECT_EQ(rec_.pose[1], -2.0f);
  EXPECT_EQ(rec_.pose[2], 1.5f);
  EXPECT_EQ(Pose(0, 0, 0, 0).type, MsgType::kAck);
  EXPECT_FALSE(rec_.known);
  EXPECT_EQ(rec_.calls, 5);
}

TEST_F(PoseCommandsTest, BadHintsAreRefusedAndNothingChanges) {
  ASSERT_EQ(Half(1).type, MsgType::kAck);
  ASSERT_EQ(rec_.calls, 1);
  for (int8_t h : {int8_t{2}, int8_t{-2}, int8_t{127}, int8_t{-128}}) {
    const Reply r = Half(h);
    EXPECT_EQ(r.type, MsgType::kError);
    EXPECT_EQ(r.error, CommandError::kBadValue);
  }
  EXPECT_EQ(rec_.half, 1);
  EXPECT_EQ(Odometry(NAN, 0, 0).error, CommandError::kBadValue);
  EXPECT_EQ(Odometry(0, INFINITY, 0).error, CommandError::kBadValue);
  EXPECT_EQ(Odometry(0, 0, 3.3f).error, CommandError::kBadValue);
  EXPECT_EQ(Odometry(2.5f, 0, 0).error, CommandError::kBadValue);
  EXPECT_EQ(Pose(1, NAN, 0, 0).error, CommandError::kBadValue);
  EXPECT_EQ(Pose(1, 0, 21.0f, 0).error, CommandError::kBadValue);
  EXPECT_EQ(Pose(1, 0, 0, -11.0f).error, CommandError::kBadValue);
  EXPECT_EQ(Pose(2, 0, 0, 0).error, CommandError::kBadValue);  // known must be 0/1
  // Wrong lengths (truncated, oversize).
  const uint8_t two[2] = {1, 0};
  EXPECT_EQ(Send2(MsgType::kSetFieldHalf, two).error, CommandError::kBadLength);
  EXPECT_EQ(Send2(MsgType::kSetFieldHalf, {}).error, CommandError::kBadLength);
  const uint8_t eleven[11] = {};
  EXPECT_EQ(Send2(MsgType::kOdometry, eleven).error, CommandError::kBadLength);
  const uint8_t fourteen[14] = {};
  EXPECT_EQ(Send2(MsgType::kSetPose, fourteen).error, CommandError::kBadLength);
  EXPECT_EQ(rec_.calls, 1);  // nothing after the first ack reached the sink
  EXPECT_EQ(pose_handler_.errors(), 16u);
}

TEST_F(CommandsTest, PoseCommandsWithoutASinkAreUnknown) {
  const uint8_t p[1] = {1};
  const Reply r = Send(MsgType::kSetFieldHalf, p);
  EXPECT_EQ(r.type, MsgType::kError);
  EXPECT_EQ(r.error, CommandError::kUnknownCommand);
}

}  // namespace
}  // namespace bv::protocol
