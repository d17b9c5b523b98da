#pragma once
// Serial protocol between the coprocessor and the robot's main computer (docs/protocol.md).
// A frame on the wire: COBS( header | payload | crc32(header|payload) ) 0x00
//   header: version u8 | type u8 | schema u16 | seq u32 | payload_len u16   (10 bytes, LE)
// COBS removes every 0x00 from the frame, so 0x00 marks frame ends and a receiver resyncs at
// the next delimiter after any corruption.
#include <cstddef>
#include <cstdint>
#include <span>

#include "core/common/ball_state.h"
#include "core/common/status.h"
#include "core/field/features.h"
#include "core/field/localise.h"

namespace bv::protocol {

// 2: the ball state's sigma; 3: its prediction's; 4: the cameras' checks (core/health)
inline constexpr uint8_t kVersion = 4;
inline constexpr size_t kHeaderBytes = 10;
inline constexpr size_t kCrcBytes = 4;
inline constexpr size_t kMaxPayloadBytes = 1024;
inline constexpr size_t kMaxRawFrameBytes = kHeaderBytes + kMaxPayloadBytes + kCrcBytes;
// COBS adds one byte per 254 plus the leading code byte; +1 for the delimiter.
inline constexpr size_t kMaxWireFrameBytes = kMaxRawFrameBytes + kMaxRawFrameBytes / 254 + 2;
/// Upper bound of the wire size of a frame with `payload` bytes (COBS worst case + delimiter).
constexpr size_t WireFrameBytes(size_t payload) {
  return kHeaderBytes + payload + kCrcBytes + (kHeaderBytes + payload + kCrcBytes) / 254 + 2;
}

enum class MsgType : uint8_t {
  kBallState = 0x01,
  kStatus = 0x02,
  kPose = 0x03,        // self-localisation, one per frame pair
  kLinePoints = 0x04,  // floor points on field lines, one per frame pair (decimated)
  kObstacles = 0x05,   // obstacle footprints, one per frame pair
  kGoals = 0x06,       // goal mouths seen, one per frame pair
  // Clock sync and capture over the link (core/protocol/link.h); ids left free before them.
  kClockSyncReply = 0x0A,
  kCaptureFrame = 0x0B,  // one captured pair: exposure times, size, mode
  kCaptureChunk = 0x0C,  // image bytes of a captured pair
  kCaptureEnd = 0x0D,    // a capture finished, was stopped or cut short
  kBlobData = 0x0E,      // bytes of a blob in use, answering kReadBlob
  kAck = 0x10,
  kError = 0x11,
  kRequestStatus = 0x20,
  kSetParam = 0x21,
  kUploadBegin = 0x22,
  kUploadChunk = 0x23,
  kUploadCommit = 0x24,
  kSetFieldHalf = 0x25,
  kOdometry = 0x26,
  kSetPose = 0x27,
  kClockSync = 0x28,     // NTP-style request: answered by kClockSyncReply
  kCaptureStart = 0x29,  // stream the next N pairs (ack / error)
  kCaptureStop = 0x2A,   // end a running capture (ack; kCaptureEnd follows)
  kTeachBall = 0x2B,     // learn the ball's colour where it lies (ack / error after a pair)
  kReadBlob = 0x2C,      // read back the colour table or calibration in use (kBlobData)
};

/// 16-bit hash of the payload layouts below; bumped automatically when they change, so a
/// listener built from another revision refuses the stream instead of misreading it.
uint16_t SchemaHash();

inline constexpr size_t kBallStatePayloadBytes = 110;
inline constexpr size_t kStatusPayloadBytes = 118;
inline constexpr size_t kPosePayloadBytes = 42;
// Line points per packet: the 35-51 a frame typically has fit whole; beyond, an evenly spread
// subset is sent (docs/protocol.md has the link budget).
inline constexpr size_t kMaxLinePointsPerPacket = 64;
inline constexpr size_t kLinePointsHeaderBytes = 12;
inline constexpr size_t kLinePointBytes = 4;
inline constexpr size_t kMaxObstaclesPerPacket = FieldFeatures::kMaxObstacles;
inline constexpr size_t kObstaclesHeaderBytes = 10;
inline constexpr size_t kObstacleBytes = 6;
inline constexpr size_t kMaxGoalsPerPacket = FieldFeatures::kMaxGoals;
inline constexpr size_t kGoalsHeaderBytes = 10;
inline constexpr size_t kGoalBytes = 12;

/// Health of the coprocessor, sent at least once per second.
struct StatusReport {
  uint64_t uptime_us = 0;
  uint32_t frames_processed = 0;
  uint32_t frame_rate_mhz = 0;  // millihertz over the last report interval
  uint32_t frames_dropped = 0;  // overwritten in DMA before the loop got to them
  uint32_t deadline_overruns = 0;
  uint32_t packets_dropped = 0;  // UART backpressure
  uint32_t pairs_omni_missing = 0;
  uint32_t pairs_persp_missing = 0;
  uint32_t pairs_out_of_sync = 0;
  uint32_t pairs_out_of_order = 0;
  uint32_t pairs_torn = 0;
  uint32_t calibration_id = 0;
  uint32_t lut_id = 0;
  uint8_t calibration_state = 0;  // BlobState
  uint8_t lut_state = 0;          // BlobState
  uint8_t check_omni = 0;         // CameraCheck::Byte() of the last pair (core/health)
  uint8_t check_persp = 0;
  uint32_t rx_errors = 0;       // corrupt frames received from the main computer
  uint32_t command_errors = 0;  // well-formed but refused commands
  uint32_t pipeline_errors = 0;
  uint32_t last_proc_us = 0;
  uint32_t max_proc_us = 0;
  uint32_t fault_flags = 0;  // board-specific fault bits (watchdog, camera stalled, ...)
  // Receive side of the UART link (hal::UartRxStats); appended, so older fields keep offsets.
  uint32_t rx_overruns = 0;     // bytes the UART hardware lost
  uint32_t rx_ring_full = 0;    // frames dropped: the receive ring had no room
  uint32_t rx_line_errors = 0;  // framing / noise / parity errors (line breaks)
  // Field-feature stream (appended): pose / line / obstacle packets the TX ring had no room for
  // (the ball state keeps priority), and line points found but not sent (decimation, capacity).
  uint32_t feature_packets_dropped = 0;
  uint32_t line_points_unsent = 0;
  // Pairs whose camera was kUnusable (frozen, blind, missing: not used), since start.
  uint32_t pairs_omni_unusable = 0;
  uint32_t pairs_persp_unusable = 0;
  // Each camera's estimated pose change since calibration (CameraCheck::change_deg), centidegrees
  // saturated at 65535, and its confidence in percent (issue 40: a knocked mirror, a turned
  // camera).
  uint16_t change_omni_cdeg = 0, change_persp_cdeg = 0;
  uint8_t confidence_omni_pct = 0, confidence_persp_pct = 0;
};

/// Decoded pose packet (the localiser's PoseEstimate at the pair's exposure time).
struct PoseReport {
  uint64_t t_us = 0;
  uint8_t state = 0;  // PoseEstimate::State
  bool ambiguous = false;
  bool hint_rejected = false;
  bool usable = false;  // PoseEstimate::usable() on the coprocessor
  uint16_t points_used = 0;
  uint16_t inliers = 0;
  float x_m = 0, y_m = 0, heading_rad = 0;
  float sigma_x_m = 0, sigma_y_m = 0, sigma_heading_rad = 0;
  float quality = 0;
};
enum PoseFlags : uint8_t { kPoseAmbiguous = 1, kPoseHintRejected = 2, kPoseUsable = 4 };

struct PointMm {
  int16_t x_mm = 0, y_mm = 0;  // robot frame, floor
};
/// Decoded line-points packet.
struct LinePointsReport {
  uint64_t t_us = 0;
  uint16_t found = 0;  // line points the extractor found this frame (over capacity included)
  uint8_t count = 0;   // points in this packet
  PointMm points[kMaxLinePointsPerPacket];
};

struct ObstacleMm {
  int16_t x_mm = 0, y_mm = 0;  // footprint centre, robot frame
  uint16_t radius_mm = 0;
};
/// Decoded obstacles packet.
struct ObstaclesReport {
  uint64_t t_us = 0;
  uint8_t found = 0;  // obstacles found this frame (over capacity included), saturated at 255
  uint8_t count = 0;
  ObstacleMm obstacles[kMaxObstaclesPerPacket];
};

struct GoalMm {
  int16_t x_mm = 0, y_mm = 0;    // centre of the seen part of the mouth, robot frame
  int16_t bearing_mrad = 0;      // robot frame, CCW from +x
  uint16_t half_width_mrad = 0;  // seen range: bearing +- half width
  uint8_t rays = 0, post_rays = 0;
  int8_t which = 0;  // +1 goal at field +X, -1 at -X, 0 unknown
  bool which_ambiguous = false;
};
enum GoalFlags : uint8_t { kGoalWhichAmbiguous = 1 };
/// Decoded goals packet.
struct GoalsReport {
  uint64_t t_us = 0;
  uint8_t found = 0;  // goals found this frame (over capacity included)
  uint8_t count = 0;
  GoalMm goals[kMaxGoalsPerPacket];
};

// kBuiltIn*: lut_state only: no usable stored table (missing / corrupt), the built-in colour
// model's table (core/color_lut/color_model.h) is in use.
enum class BlobState : uint8_t {
  kOk = 0,
  kMissing = 1,
  kCorrupt = 2,
  kBuiltInMissing = 3,
  kBuiltInCorrupt = 4,
};

// --- encoding: whole wire frames (COBS + delimiter), ready for Uart::Write ---

/// Encodes any payload. Errors: kInvalidArgument (payload > kMaxPayloadBytes),
/// kResourceExhausted (`out` smaller than the wire frame).
Result<size_t> EncodeFrame(MsgType type, uint32_t seq, std::span<const uint8_t> payload,
                           std::span<uint8_t> out);
/// A position 1-sigma as the ball state carries it: whole millimetres rounded up, saturated at
/// 65535 (also for a non-finite value: "unknown" is as large as it gets).
uint16_t BallSigmaMm(float sigma_m);
/// A camera check's change_deg as the packets carry it: centidegrees, saturated at 65535, a
/// negative or NaN value as 0.
uint16_t ChangeCentiDegrees(float deg);
Result<size_t> EncodeBallState(const BallState& state, uint32_t seq, std::span<uint8_t> out);
Result<size_t> EncodeStatus(const StatusReport& status, uint32_t seq, std::span<uint8_t> out);
Result<size_t> EncodePose(const PoseEstimate& pose, uint64_t t_us, uint32_t seq,
                          std::span<uint8_t> out);
/// At most `max_points` (<= kMaxLinePointsPerPacket) line points, evenly spread over the
/// frame's when there are more; points that do not fit int16 mm (or are NaN) are skipped.
/// `sent` receives the number of points in the packet.
Result<size_t> EncodeLinePoints(const FieldFeatures& features, uint64_t t_us, uint32_t seq,
                                std::span<uint8_t> out, size_t& sent,
                                size_t max_points = kMaxLinePointsPerPacket);
/// All obstacles (FieldFeatures holds at most kMaxObstaclesPerPacket); unencodable ones skipped.
Result<size_t> EncodeObstacles(const FieldFeatures& features, uint64_t t_us, uint32_t seq,
                               std::span<uint8_t> out);

/// All goals (FieldFeatures holds at most kMaxGoalsPerPacket); unencodable ones skipped.
Result<size_t> EncodeGoals(const FieldFeatures& features, uint64_t t_us, uint32_t seq,
                           std::span<uint8_t> out);

// --- decoding ---

struct FrameView {
  MsgType type{};
  uint32_t seq = 0;
  std::span<const uint8_t> payload;  // valid until the next Decoder::Push
};

/// Payload parsers; kInvalidArgument if the length is wrong or a value is impossible (NaN
/// position, unknown mode).
Status ParseBallState(std::span<const uint8_t> payload, BallState& out);
Status ParseStatus(std::span<const uint8_t> payload, StatusReport& out);
Status ParsePose(std::span<const uint8_t> payload, PoseReport& out);
Status ParseLinePoints(std::span<const uint8_t> payload, LinePointsReport& out);
Status ParseObstacles(std::span<const uint8_t> payload, ObstaclesReport& out);
Status ParseGoals(std::span<const uint8_t> payload, GoalsReport& out);

struct DecoderStats {
  uint32_t frames_ok = 0;
  uint32_t crc_errors = 0;
  uint32_t cobs_errors = 0;     // malformed COBS (code byte pointing past the frame)
  uint32_t oversize = 0;        // frame longer than the receive buffer: discarded to the next 0x00
  uint32_t short_frames = 0;    // shorter than header + CRC
  uint32_t version_errors = 0;  // other protocol version or schema
  uint32_t length_errors = 0;   // header length disagrees with the frame
  uint32_t bytes_discarded = 0;
  uint32_t errors() const {
    return crc_errors + cobs_errors + oversize + short_frames + version_errors + length_errors;
  }
};

/// Streaming decoder: feed bytes as they arrive; a complete, verified frame is returned at
/// each delimiter. Never allocates; a corrupt frame costs at most that frame.
class Decoder {
 public:
  /// Consumes one byte. Returns true when `out` holds a verified frame.
  bool Push(uint8_t byte, FrameView& out);
  const DecoderStats& stats() const { return stats_; }

 private:
  bool Finish(FrameView& out);
  uint8_t buf_[kMaxWireFrameBytes] = {};
  uint8_t raw_[kMaxRawFrameBytes] = {};
  size_t len_ = 0;
  bool overflow_ = false;
  DecoderStats stats_;
};

// --- COBS primitives (exposed for tests and the fuzzers) ---
/// Encodes `in` (no delimiter appended). Returns the encoded size or kResourceExhausted.
Result<size_t> CobsEncode(std::span<const uint8_t> in, std::span<uint8_t> out);
/// Decodes one frame without its delimiter. kDataLoss for malformed input (a zero byte, a code
/// pointing past the end), kResourceExhausted if `out` is too small.
Result<size_t> CobsDecode(std::span<const uint8_t> in, std::span<uint8_t> out);

}  // namespace bv::protocol
