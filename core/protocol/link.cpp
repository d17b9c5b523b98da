#include "core/protocol/link.h"

#include <cstring>

#include "core/common/bytes.h"
#include "core/common/image.h"
#include "core/protocol/scan_capture.h"

namespace bv::protocol {
namespace {

constexpr uint8_t kAllCameras = kCaptureOmni | kCapturePersp;

int Factor(CaptureMode mode) {
  switch (mode) {
    case CaptureMode::kFull:
      return 1;
    case CaptureMode::kHalf:
      return 2;
    case CaptureMode::kQuarter:
      return 4;
    case CaptureMode::kScanlines:
      return 0;  // not a decimation
  }
  return 0;
}

// image_bytes of a frame: the image size, or for scanlines one or two camera streams (each at
// least its header and a sample, at most a full table's).
bool ImageBytesFit(const CaptureFrame& f) {
  if (f.mode != CaptureMode::kScanlines) return f.image_bytes == uint32_t{f.width} * f.height * 2u;
  const uint32_t streams =
      (f.cameras & kCaptureOmni ? 1u : 0u) + (f.cameras & kCapturePersp ? 1u : 0u);
  return f.image_bytes >= streams * ScanStreamBytes(1) &&
         f.image_bytes <= streams * ScanStreamBytes(kMaxScanSamples);
}

Result<size_t> Finish(MsgType type, uint32_t seq, const ByteWriter& w, std::span<uint8_t> out) {
  if (!w.ok()) return w.status();
  return EncodeFrame(type, seq, w.written(), out);
}

}  // namespace

Result<size_t> EncodeClockSyncRequest(const ClockSyncRequest& req, uint32_t seq,
                                      std::span<uint8_t> out) {
  uint8_t p[kClockSyncRequestBytes];
  ByteWriter w(p);
  w.U32(req.id);
  w.U64(req.t1_host_us);
  return Finish(MsgType::kClockSync, seq, w, out);
}

Result<size_t> EncodeClockSyncReply(const ClockSyncReply& reply, uint32_t seq,
                                    std::span<uint8_t> out) {
  uint8_t p[kClockSyncReplyBytes];
  ByteWriter w(p);
  w.U32(reply.id);
  w.U64(reply.t1_host_us);
  w.U64(reply.t2_rx_us);
  w.U64(reply.t3_tx_us);
  return Finish(MsgType::kClockSyncReply, seq, w, out);
}

Status ParseClockSyncRequest(std::span<const uint8_t> payload, ClockSyncRequest& out) {
  if (payload.size() != kClockSyncRequestBytes) {
    return Status(StatusCode::kInvalidArgument, "clock sync request: length is not 12 bytes");
  }
  ByteReader r(payload);
  out.id = r.U32();
  out.t1_host_us = r.U64();
  return Status();
}

Status ParseClockSyncReply(std::span<const uint8_t> payload, ClockSyncReply& out) {
  if (payload.size() != kClockSyncReplyBytes) {
    return Status(StatusCode::kInvalidArgument, "clock sync reply: length is not 28 bytes");
  }
  ByteReader r(payload);
  ClockSyncReply v;
  v.id = r.U32();
  v.t1_host_us = r.U64();
  v.t2_rx_us = r.U64();
  v.t3_tx_us = r.U64();
  if (v.t3_tx_us < v.t2_rx_us) {
    return Status(StatusCode::kInvalidArgument, "clock sync reply: sent before received");
  }
  out = v;
  return Status();
}

bool CaptureSize(CaptureMode mode, uint16_t& width, uint16_t& height) {
  const int k = mode == CaptureMode::kScanlines ? 1 : Factor(mode);
  if (k == 0) return false;
  width = static_cast<uint16_t>(kFrameWidth / k);
  height = static_cast<uint16_t>(kFrameHeight / k);
  return true;
}

Status ParseCaptureStart(std::span<const uint8_t> payload, CaptureRequest& out) {
  if (payload.size() != kCaptureStartBytes) {
    return Status(StatusCode::kInvalidArgument, "capture start: length is not 4 bytes");
  }
  ByteReader r(payload);
  out.count = r.U16();
  out.mode = static_cast<CaptureMode>(r.U8());
  out.cameras = r.U8();
  return Status();
}

Result<size_t> EncodeCaptureFrame(const CaptureFrame& f, uint32_t seq, std::span<uint8_t> out) {
  uint8_t p[kCaptureFrameBytes];
  ByteWriter w(p);
  w.U16(f.capture_id), w.U16(f.pair_index), w.U16(f.count);
  w.U8(static_cast<uint8_t>(f.mode)), w.U8(f.cameras);
  w.U16(f.width), w.U16(f.height);
  w.U64(f.exposure_us), w.U64(f.omni_exposure_us), w.U64(f.persp_exposure_us);
  w.U32(f.omni_sequence), w.U32(f.persp_sequence);
  w.U32(f.image_bytes);
  return Finish(MsgType::kCaptureFrame, seq, w, out);
}

Result<size_t> EncodeCaptureChunk(const CaptureChunk& c, uint32_t seq, std::span<uint8_t> out) {
  if (c.data.empty() || c.data.size() > kCaptureChunkBytes) {
    return Status(StatusCode::kInvalidArgument, "capture chunk: 1..512 data bytes");
  }
  uint8_t p[kCaptureChunkHeaderBytes + kCaptureChunkBytes];
  ByteWriter w(p);
  w.U16(c.capture_id), w.U16(c.pair_index);
  w.U8(c.camera), w.U8(0);
  w.U32(c.offset);
  w.Bytes(c.data);
  return Finish(MsgType::kCaptureChunk, seq, w, out);
}

Result<size_t> EncodeCaptureEnd(const CaptureEnd& e, uint32_t seq, std::span<uint8_t> out) {
  uint8_t p[kCaptureEndBytes];
  ByteWriter w(p);
  w.U16(e.capture_id), w.U16(e.requested), w.U16(e.pairs_sent);
  w.U8(static_cast<uint8_t>(e.reason));
  return Finish(MsgType::kCaptureEnd, seq, w, out);
}

Status ParseCaptureFrame(std::span<const uint8_t> payload, CaptureFrame& out) {
  if (payload.size() != kCaptureFrameBytes) {
    return Status(StatusCode::kInvalidArgument, "capture frame: length is not 48 bytes");
  }
  ByteReader r(payload);
  CaptureFrame f;
  f.capture_id = r.U16(), f.pair_index = r.U16(), f.count = r.U16();
  const uint8_t mode = r.U8();
  f.cameras = r.U8();
  f.width = r.U16(), f.height = r.U16();
  f.exposure_us = r.U64(), f.omni_exposure_us = r.U64(), f.persp_exposure_us = r.U64();
  f.omni_sequence = r.U32(), f.persp_sequence = r.U32();
  f.image_bytes = r.U32();
  f.mode = static_cast<CaptureMode>(mode);
  uint16_t w = 0, h = 0;
  if (!CaptureSize(f.mode, w, h)) {
    return Status(StatusCode::kInvalidArgument, "capture frame: unknown mode");
  }
  if (f.cameras == 0 || (f.cameras & ~kAllCameras) != 0) {
    return Status(StatusCode::kInvalidArgument, "capture frame: camera bits not 1..3");
  }
  if (f.width != w || f.height != h || !ImageBytesFit(f)) {
    return Status(StatusCode::kInvalidArgument, "capture frame: size disagrees with the mode");
  }
  if (f.count == 0 || f.count > kMaxCapturePairs || f.pair_index >= f.count) {
    return Status(StatusCode::kInvalidArgument, "capture frame: pair index beyond the count");
  }
  out = f;
  return Status();
}

Status ParseCaptureChunk(std::span<const uint8_t> payload, CaptureChunk& out) {
  if (payload.size() <= kCaptureChunkHeaderBytes ||
      payload.size() > kCaptureChunkHeaderBytes + kCaptureChunkBytes) {
    return Status(StatusCode::kInvalidArgument, "capture chunk: 1..512 data bytes");
  }
  ByteReader r(payload);
  CaptureChunk c;
  c.capture_id = r.U16(), c.pair_index = r.U16();
  c.camera = r.U8();
  const uint8_t reserved = r.U8();
  c.offset = r.U32();
  c.data = payload.subspan(kCaptureChunkHeaderBytes);
  if (c.camera > 1 || reserved != 0) {
    return Status(StatusCode::kInvalidArgument, "capture chunk: camera not 0/1 or reserved set");
  }
  if (c.offset > kFrameBytes || c.data.size() > kFrameBytes - c.offset) {
    return Status(StatusCode::kInvalidArgument, "capture chunk: beyond a 640x480 image");
  }
  out = c;
  return Status();
}

Status ParseCaptureEnd(std::span<const uint8_t> payload, CaptureEnd& out) {
  if (payload.size() != kCaptureEndBytes) {
    return Status(StatusCode::kInvalidArgument, "capture end: length is not 7 bytes");
  }
  ByteReader r(payload);
  CaptureEnd e;
  e.capture_id = r.U16(), e.requested = r.U16(), e.pairs_sent = r.U16();
  const uint8_t reason = r.U8();
  if (reason > static_cast<uint8_t>(CaptureEndReason::kCameraFinished)) {
    return Status(StatusCode::kInvalidArgument, "capture end: unknown reason");
  }
  if (e.pairs_sent > e.requested) {
    return Status(StatusCode::kInvalidArgument, "capture end: more pairs sent than requested");
  }
  e.reason = static_cast<CaptureEndReason>(reason);
  out = e;
  return Status();
}

bool CopyCaptureBytes(const uint8_t* src, size_t stride, CaptureMode mode, size_t offset,
                      std::span<uint8_t> out) {
  uint16_t w = 0, h = 0;
  if (mode == CaptureMode::kScanlines || !CaptureSize(mode, w, h)) return false;
  const size_t row_bytes = size_t{w} * 2;
  const size_t total = row_bytes * h;
  if (offset > total || out.size() > total - offset) return false;
  const size_t k = static_cast<size_t>(Factor(mode));
  if (k == 1) {  // rows as they are: copy row segments
    size_t done = 0;
    while (done < out.size()) {
      const size_t b = offset + done;
      const size_t in_row = b % row_bytes;
      size_t n = row_bytes - in_row;
      if (n > out.size() - done) n = out.size() - done;
      std::memcpy(out.data() + done, src + (b / row_bytes) * stride + in_row, n);
      done += n;
    }
    return true;
  }
  for (size_t i = 0; i < out.size(); ++i) {
    const size_t b = offset + i;
    const size_t y = b / row_bytes;
    const size_t in_row = b % row_bytes;
    const size_t m = in_row / 4;  // output macropixel
    const uint8_t* row = src + k * y * stride;
    switch (in_row % 4) {
      case 0:
        out[i] = row[2 * (k * 2 * m)];  // Y of output pixel 2m
        break;
      case 2:
        out[i] = row[2 * (k * (2 * m + 1))];  // Y of output pixel 2m+1
        break;
      case 1:
        out[i] = row[4 * (k * m) + 1];  // U of the source macropixel of pixel 2m
        break;
      default:
        out[i] = row[4 * (k * m) + 3];  // V
        break;
    }
  }
  return true;
}

Result<size_t> EncodeReadBlob(const ReadBlobRequest& r, uint32_t seq, std::span<uint8_t> out) {
  uint8_t p[kReadBlobBytes];
  ByteWriter w(p);
  w.U8(r.target), w.U32(r.offset), w.U16(r.length);
  return Finish(MsgType::kReadBlob, seq, w, out);
}

Status ParseReadBlob(std::span<const uint8_t> payload, ReadBlobRequest& out) {
  if (payload.size() != kReadBlobBytes) {
    return Status(StatusCode::kInvalidArgument, "read blob: length is not 7 bytes");
  }
  ByteReader r(payload);
  out.target = r.U8(), out.offset = r.U32(), out.length = r.U16();
  return Status();
}

Result<size_t> EncodeBlobData(const BlobData& d, uint32_t seq, std::span<uint8_t> out) {
  if (d.data.empty() || d.data.size() > kBlobDataBytes) {
    return Status(StatusCode::kInvalidArgument, "blob data: 1..512 data bytes");
  }
  uint8_t p[kBlobDataHeaderBytes + kBlobDataBytes];
  ByteWriter w(p);
  w.U32(d.cmd_seq), w.U8(d.target);
  w.U32(d.total_len), w.U32(d.blob_crc32), w.U32(d.offset);
  w.Bytes(d.data);
  return Finish(MsgType::kBlobData, seq, w, out);
}

Status ParseBlobData(std::span<const uint8_t> payload, BlobData& out) {
  if (payload.size() <= kBlobDataHeaderBytes ||
      payload.size() > kBlobDataHeaderBytes + kBlobDataBytes) {
    return Status(StatusCode::kInvalidArgument, "blob data: 1..512 data bytes");
  }
  ByteReader r(payload);
  BlobData d;
  d.cmd_seq = r.U32(), d.target = r.U8();
  d.total_len = r.U32(), d.blob_crc32 = r.U32(), d.offset = r.U32();
  d.data = payload.subspan(kBlobDataHeaderBytes);
  if (d.target < 1 || d.target > 3) {
    return Status(StatusCode::kInvalidArgument, "blob data: target not 1, 2 or 3");
  }
  if (d.offset > d.total_len || d.data.size() > d.total_len - d.offset) {
    return Status(StatusCode::kInvalidArgument, "blob data: bytes beyond the blob's length");
  }
  out = d;
  return Status();
}

}  // namespace bv::protocol
