// The main computer's read-back client (tools/ballvision/blob_reader.h) against the device's
// command handler (core/protocol/commands.h) with a RAM snapshot: whole blobs only.
#include "tools/ballvision/blob_reader.h"

#include <gtest/gtest.h>

#include <memory>
#include <vector>

#include "core/color_lut/color_lut.h"
#include "core/common/crc32.h"
#include "tools/ballvision/run_common.h"

namespace bv::cli {
namespace {

using protocol::UploadTarget;

struct NoUploads : protocol::UploadSink {
  size_t capacity(UploadTarget) const override { return 0; }
  Status Begin(UploadTarget, size_t) override { return Status(StatusCode::kResourceExhausted, ""); }
  Status Write(UploadTarget, size_t, std::span<const uint8_t>) override { return Status(); }
  Status Commit(UploadTarget, uint32_t) override { return Status(); }
  void Abort(UploadTarget) override {}
};
struct NoParams : protocol::ParamSink {
  Status SetParam(uint16_t, float) override { return Status(StatusCode::kNotFound, ""); }
};

// A device serving `blob` as its table in use; `busy_every` > 0 answers every n-th read busy,
// `replace_at` > 0 drops the snapshot once that many reads were served (an upload came).
struct FakeDevice : protocol::ReadbackSink {
  std::vector<uint8_t> blob, snapshot;
  bool valid = false;
  int reads = 0, busy_every = 0, replace_at = 0;
  Status ReadBlob(UploadTarget target, uint32_t offset, size_t max_len,
                  protocol::BlobData& out) override {
    ++reads;
    if (target != UploadTarget::kLut) return Status(StatusCode::kNotFound, "");
    if (busy_every > 0 && reads % busy_every == 0) return Status(StatusCode::kUnavailable, "");
    if (reads == replace_at) valid = false;
    if (offset == 0) snapshot = blob, valid = true;
    if (!valid) return Status(StatusCode::kFailedPrecondition, "");
    out.total_len = static_cast<uint32_t>(snapshot.size());
    out.blob_crc32 = Crc32(snapshot);
    if (offset >= snapshot.size()) return Status(StatusCode::kOutOfRange, "");
    out.data = std::span<const uint8_t>(snapshot).subspan(
        offset, std::min(max_len, snapshot.size() - offset));
    return Status();
  }
};

class BlobReaderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto lut = std::make_unique<ColorLut>();
    FillBuiltInLut(*lut);
    device_.blob.resize(kColorLutBlobBytes);
    const Result<size_t> n = SerializeLut(*lut, device_.blob);
    ASSERT_TRUE(n.ok());
    device_.blob.resize(*n);
  }
  // Request -> wire -> handler -> wire -> reader until done or failed (or `max_exchanges`).
  void Run(BlobReader& reader, int max_exchanges = 1000) {
    for (int i = 0; i < max_exchanges && !reader.done() && !reader.failed(); ++i) {
      protocol::ReadBlobRequest req;
      uint32_t seq = 0;
      ASSERT_TRUE(reader.NextRequest(req, seq));
      uint8_t wire[protocol::kMaxWireFrameBytes], reply[protocol::kMaxWireFrameBytes];
      const Result<size_t> n = protocol::EncodeReadBlob(req, seq, wire);
      ASSERT_TRUE(n.ok());
      protocol::Decoder in, out;
      protocol::FrameView f;
      for (size_t k = 0; k < *n; ++k) {
        if (!in.Push(wire[k], f)) continue;
        size_t len = 0;
        handler_.Handle(f, 0, reply, len);
        for (size_t j = 0; j < len; ++j) {
          if (out.Push(reply[j], f)) reader.OnFrame(f);
        }
      }
    }
  }
  NoUploads uploads_;
  NoParams params_;
  FakeDevice device_;
  protocol::CommandHandler handler_{uploads_, params_, nullptr, nullptr, nullptr, &device_};
};

TEST_F(BlobReaderTest, TheWholeTableComesBackThroughBusyAnswers) {
  device_.busy_every = 5;
  BlobReader reader(UploadTarget::kLut);
  Run(reader);
  ASSERT_TRUE(reader.done()) << reader.error();
  EXPECT_EQ(reader.blob(), device_.blob);
  EXPECT_GT(reader.busy_answers(), 20);
  EXPECT_EQ(reader.restarts(), 0);
}

TEST_F(BlobReaderTest, ALostSnapshotStartsAgainFromZero) {
  device_.replace_at = 40;
  BlobReader reader(UploadTarget::kLut);
  Run(reader);
  ASSERT_TRUE(reader.done()) << reader.error();
  EXPECT_EQ(reader.restarts(), 1);
  EXPECT_EQ(reader.blob(), device_.blob);
}

TEST_F(BlobReaderTest, InterruptedHalfWayNothingIsAccepted) {
  BlobReader reader(UploadTarget::kLut);
  Run(reader, 60);
  EXPECT_FALSE(reader.done());
  EXPECT_FALSE(reader.failed());
  EXPECT_EQ(reader.blob().size(), 60u * 512u);
  // Answers that arrive late or to nobody change nothing.
  protocol::FrameView stray;
  stray.type = protocol::MsgType::kBlobData;
  reader.OnFrame(stray);
  EXPECT_EQ(reader.blob().size(), 60u * 512u);
}

TEST_F(BlobReaderTest, AnUnparsableBlobIsRefusedAndABadTargetNamed) {
  device_.blob[20] ^= 0xFF;  // payload byte: the blob's own CRC no longer matches
  BlobReader reader(UploadTarget::kLut);
  Run(reader);
  EXPECT_FALSE(reader.done());
  ASSERT_TRUE(reader.failed());
  EXPECT_NE(reader.error().find("does not parse"), std::string::npos) << reader.error();

  BlobReader cal(UploadTarget::kCalibration);
  Run(cal);
  ASSERT_TRUE(cal.failed());
  EXPECT_EQ(cal.error(), "the device has no calibration in use");
}

}  // namespace
}  // namespace bv::cli
