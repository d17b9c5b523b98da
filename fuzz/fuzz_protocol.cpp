// Bytes from the serial link: the stream decoder, the payload parsers and the command handler.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/protocol/commands.h"
#include "core/protocol/link.h"
#include "core/protocol/protocol.h"

namespace {

class NullSink : public bv::protocol::UploadSink {
 public:
  std::vector<uint8_t> staging;
  size_t capacity(bv::protocol::UploadTarget) const override { return 70000; }
  bv::Status Begin(bv::protocol::UploadTarget, size_t n) override {
    staging.assign(n, 0xFF);
    return {};
  }
  bv::Status Write(bv::protocol::UploadTarget, size_t off, std::span<const uint8_t> d) override {
    if (off + d.size() > staging.size()) __builtin_trap();  // the handler must prevent this
    for (size_t i = 0; i < d.size(); ++i) staging[off + i] = d[i];
    return {};
  }
  bv::Status Commit(bv::protocol::UploadTarget, uint32_t) override {
    return bv::Status(bv::StatusCode::kDataLoss, "never valid in the fuzzer");
  }
  void Abort(bv::protocol::UploadTarget) override { staging.clear(); }
};

class NullParams : public bv::protocol::ParamSink {
 public:
  bv::Status SetParam(uint16_t, float) override { return {}; }
};

// Serves a 2000-byte blob; the handler must keep every answer inside it.
class RamReadback : public bv::protocol::ReadbackSink {
 public:
  uint8_t blob[2000] = {};
  bool snapshot = false;
  bv::Status ReadBlob(bv::protocol::UploadTarget, uint32_t offset, size_t max_len,
                      bv::protocol::BlobData& out) override {
    if (max_len == 0 || max_len > bv::protocol::kBlobDataBytes) __builtin_trap();
    if (offset == 0) snapshot = true;
    if (!snapshot) return bv::Status(bv::StatusCode::kFailedPrecondition, "no snapshot");
    out.total_len = sizeof blob;
    if (offset >= sizeof blob) return bv::Status(bv::StatusCode::kOutOfRange, "end");
    const size_t n = max_len < sizeof blob - offset ? max_len : sizeof blob - offset;
    out.data = std::span<const uint8_t>(blob + offset, n);
    return {};
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static bv::protocol::Decoder decoder;  // keeps state across inputs, like a long-lived link
  NullSink sink;
  NullParams params;
  RamReadback readback;
  bv::protocol::CommandHandler handler(sink, params, nullptr, nullptr, nullptr, &readback);
  bv::protocol::FrameView frame;
  uint8_t reply[bv::protocol::kMaxWireFrameBytes];
  for (size_t i = 0; i < size; ++i) {
    if (!decoder.Push(data[i], frame)) continue;
    bv::BallState s;
    bv::protocol::StatusReport st;
    (void)bv::protocol::ParseBallState(frame.payload, s).ok();
    (void)bv::protocol::ParseStatus(frame.payload, st).ok();
    bv::protocol::PoseReport pose;
    bv::protocol::LinePointsReport lines;
    bv::protocol::ObstaclesReport obstacles;
    (void)bv::protocol::ParsePose(frame.payload, pose).ok();
    (void)bv::protocol::ParseLinePoints(frame.payload, lines).ok();
    (void)bv::protocol::ParseObstacles(frame.payload, obstacles).ok();
    bv::protocol::BlobData blob;
    if (bv::protocol::ParseBlobData(frame.payload, blob).ok() &&
        blob.offset + blob.data.size() > blob.total_len) {
      __builtin_trap();  // the parser must keep the bytes inside the announced blob
    }
    size_t reply_len = 0;
    handler.Handle(frame, 0, reply, reply_len);
    if (reply_len > sizeof reply) __builtin_trap();
  }
  // COBS primitives directly on the raw input.
  uint8_t out[4096];
  (void)bv::protocol::CobsDecode({data, size}, out).ok();
  return 0;
}
