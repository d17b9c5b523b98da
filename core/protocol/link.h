#pragma once
// Clock sync and frame capture over the serial link (docs/protocol.md, "Clock sync" and
// "Capture"). Payload layouts, little endian:
//   clock sync request (0x28): id u32 | t1_host_us u64
//   clock sync reply   (0x0A): id u32 | t1_host_us u64 | t2_rx_us u64 | t3_tx_us u64
//   capture start      (0x29): count u16 | mode u8 | cameras u8
//   capture stop       (0x2A): empty
//   capture frame      (0x0B): capture_id u16 | pair_index u16 | count u16 | mode u8 |
//                              cameras u8 | width u16 | height u16 | exposure_us u64 |
//                              omni_exposure_us u64 | persp_exposure_us u64 |
//                              omni_sequence u32 | persp_sequence u32 | image_bytes u32
//   capture chunk      (0x0C): capture_id u16 | pair_index u16 | camera u8 | reserved u8 |
//                              offset u32 | data (1..kCaptureChunkBytes)
//   capture end        (0x0D): capture_id u16 | requested u16 | pairs_sent u16 | reason u8
//   read blob          (0x2C): target u8 | offset u32 | length u16 (1..kBlobDataBytes)
//   blob data          (0x0E): cmd_seq u32 | target u8 | total_len u32 | blob_crc32 u32 |
//                              offset u32 | data (1..kBlobDataBytes)
#include <cstddef>
#include <cstdint>
#include <span>

#include "core/common/status.h"
#include "core/protocol/protocol.h"

namespace bv::protocol {

inline constexpr size_t kClockSyncRequestBytes = 12;
inline constexpr size_t kClockSyncReplyBytes = 28;

struct ClockSyncRequest {
  uint32_t id = 0;
  uint64_t t1_host_us = 0;  // main computer's clock when it sent the request (echoed back)
};

struct ClockSyncReply {
  uint32_t id = 0;
  uint64_t t1_host_us = 0;
  uint64_t t2_rx_us = 0;  // coprocessor clock: the request's delimiter arrived
  uint64_t t3_tx_us = 0;  // coprocessor clock: the reply was queued for sending
};

Result<size_t> EncodeClockSyncRequest(const ClockSyncRequest& req, uint32_t seq,
                                      std::span<uint8_t> out);
Result<size_t> EncodeClockSyncReply(const ClockSyncReply& reply, uint32_t seq,
                                    std::span<uint8_t> out);
/// kInvalidArgument for a wrong length.
Status ParseClockSyncRequest(std::span<const uint8_t> payload, ClockSyncRequest& out);
/// kInvalidArgument for a wrong length or a reply sent before its request arrived (t3 < t2).
Status ParseClockSyncReply(std::span<const uint8_t> payload, ClockSyncReply& out);

// --- capture ---

enum class CaptureMode : uint8_t {
  kFull = 0,     // 640x480 YUYV
  kHalf = 1,     // 320x240: every 2nd row and pixel (chroma of the kept pixel's macropixel)
  kQuarter = 2,  // 160x120: every 4th
  // The scan-table samples only, per camera a stream of core/protocol/scan_capture.h; the
  // frame's width x height is the image they lie in (640x480), image_bytes the pair's streams.
  kScanlines = 3,
};
enum CaptureCameras : uint8_t { kCaptureOmni = 1, kCapturePersp = 2 };
enum class CaptureEndReason : uint8_t {
  kComplete = 0,        // all requested pairs sent
  kStopped = 1,         // capture stop command
  kCameraFinished = 2,  // the camera has no more frames (replay ended)
};

/// Pairs one request may ask for: at full resolution a pair is ~14 s of link time at
/// 921600 Bd, so 100 is already 20 minutes.
inline constexpr uint16_t kMaxCapturePairs = 100;
/// Image bytes per chunk packet: divides every image size (614400, 153600, 38400) and keeps the
/// wait a chunk adds before a ball state at 921600 Bd under 6 ms.
inline constexpr size_t kCaptureChunkBytes = 512;
inline constexpr size_t kCaptureStartBytes = 4;
inline constexpr size_t kCaptureFrameBytes = 48;
inline constexpr size_t kCaptureChunkHeaderBytes = 10;
inline constexpr size_t kCaptureEndBytes = 7;

/// Where the ball lies for a teach: a floor point (robot frame, m) or a pixel of one camera.
enum class TeachWhere : uint8_t { kFloorPoint = 0, kOmniPixel = 1, kPerspPixel = 2 };
inline constexpr size_t kTeachBallBytes = 9;  // where u8 | a f32 | b f32
struct TeachRequest {
  TeachWhere where = TeachWhere::kFloorPoint;
  float a = 0, b = 0;  // x, y (m) or u, v (px)
};

struct CaptureRequest {
  uint16_t count = 0;
  CaptureMode mode = CaptureMode::kFull;
  uint8_t cameras = 0;  // CaptureCameras bits
};

struct CaptureFrame {
  uint16_t capture_id = 0;
  uint16_t pair_index = 0;  // 0..count-1 within the capture
  uint16_t count = 0;       // pairs requested
  CaptureMode mode = CaptureMode::kFull;
  uint8_t cameras = 0;  // images that follow (requested and present in the pair)
  uint16_t width = 0, height = 0;
  uint64_t exposure_us = 0;  // the pair's timestamp (the ball state's t_us)
  uint64_t omni_exposure_us = 0, persp_exposure_us = 0;
  uint32_t omni_sequence = 0, persp_sequence = 0;
  uint32_t image_bytes = 0;  // per camera: width * height * 2; scanlines: both streams
};

struct CaptureChunk {
  uint16_t capture_id = 0;
  uint16_t pair_index = 0;
  uint8_t camera = 0;  // 0 omni, 1 persp
  uint32_t offset = 0;
  std::span<const uint8_t> data;  // points into the parsed payload
};

struct CaptureEnd {
  uint16_t capture_id = 0;
  uint16_t requested = 0;
  uint16_t pairs_sent = 0;
  CaptureEndReason reason = CaptureEndReason::kComplete;
};

/// kInvalidArgument: wrong length. Ranges are the command handler's business.
Status ParseCaptureStart(std::span<const uint8_t> payload, CaptureRequest& out);
/// Image size of a mode (scanlines: the image the samples lie in): false for an unknown mode.
bool CaptureSize(CaptureMode mode, uint16_t& width, uint16_t& height);

Result<size_t> EncodeCaptureFrame(const CaptureFrame& f, uint32_t seq, std::span<uint8_t> out);
Result<size_t> EncodeCaptureChunk(const CaptureChunk& c, uint32_t seq, std::span<uint8_t> out);
Result<size_t> EncodeCaptureEnd(const CaptureEnd& e, uint32_t seq, std::span<uint8_t> out);
/// kInvalidArgument for a wrong length, unknown mode or camera bits, a size that does not
/// match the mode, a chunk beyond its image or an unknown end reason.
Status ParseCaptureFrame(std::span<const uint8_t> payload, CaptureFrame& out);
Status ParseCaptureChunk(std::span<const uint8_t> payload, CaptureChunk& out);
Status ParseCaptureEnd(std::span<const uint8_t> payload, CaptureEnd& out);

// --- read-back of a blob in use (docs/protocol.md, "Read-back") ---

inline constexpr size_t kReadBlobBytes = 7;
inline constexpr size_t kBlobDataBytes = 512;
inline constexpr size_t kBlobDataHeaderBytes = 17;

struct ReadBlobRequest {
  uint8_t target = 0;  // UploadTarget: 1 calibration, 2 colour table, 3 ball classifier
  uint32_t offset = 0;
  uint16_t length = 0;
};

/// Bytes of the device's snapshot of the blob in use. The snapshot is taken by a read at
/// offset 0; blob_crc32 (the whole blob's CRC) names it, so a reader notices when another read
/// from 0 replaced it.
struct BlobData {
  uint32_t cmd_seq = 0;  // the read command answered
  uint8_t target = 0;
  uint32_t total_len = 0;
  uint32_t blob_crc32 = 0;
  uint32_t offset = 0;
  std::span<const uint8_t> data;
};

Result<size_t> EncodeReadBlob(const ReadBlobRequest& r, uint32_t seq, std::span<uint8_t> out);
/// kInvalidArgument: wrong length. Target and range are the handler's business.
Status ParseReadBlob(std::span<const uint8_t> payload, ReadBlobRequest& out);
Result<size_t> EncodeBlobData(const BlobData& d, uint32_t seq, std::span<uint8_t> out);
/// kInvalidArgument: wrong length, unknown target, bytes beyond total_len.
Status ParseBlobData(std::span<const uint8_t> payload, BlobData& out);

/// Bytes [offset, offset + out.size()) of the decimated YUYV image of a 640x480 source with
/// `stride` bytes per row. Decimation keeps pixel (k*x, k*y); its chroma is that of the
/// source macropixel holding it. False if the range is beyond the image, or for scanlines
/// (core/protocol/scan_capture.h streams those).
bool CopyCaptureBytes(const uint8_t* src, size_t stride, CaptureMode mode, size_t offset,
                      std::span<uint8_t> out);

}  // namespace bv::protocol
