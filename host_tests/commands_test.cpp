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

class CommandsTest : public ::testing::Test {
 protected:
  Reply Send(MsgType type, std::span<const uint8_t> payload) {
    FrameView f{type, seq_++, payload};
    std::array<uint8_t, kMaxWireFrameBytes> reply{};
    size_t len = 0;
    last_ = handler_.Handle(f, 0, reply, len);
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
