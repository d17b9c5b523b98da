#pragma once
// Commands from the main computer, parsed with the same care as everything else from outside:
// every field checked, every command answered with an ack or an error code, nothing applied
// until it is complete and verified.
//   request status  (0x20): empty payload                  -> status packet (by the caller)
//   set parameter   (0x21): id u16 | value f32              -> ack / error
//   upload begin    (0x22): target u8 | total_len u32 | total_crc32 u32
//   upload chunk    (0x23): target u8 | offset u32 | data (1..kMaxChunkBytes)
//   upload commit   (0x24): target u8                       -> verified and activated, or error
//   set field half  (0x25): half i8 (-1, 0, +1)             -> ack / error
//   odometry        (0x26): dx f32 | dy f32 | dheading f32   -> ack / error
//   set pose        (0x27): known u8 | x f32 | y f32 | heading f32 -> ack / error
//   clock sync      (0x28): id u32 | t1_host_us u64         -> sync reply (by the caller)
//   capture start   (0x29): count u16 | mode u8 | cameras u8 -> ack / error
//   capture stop    (0x2A): empty                           -> ack / error
//   teach ball      (0x2B): where u8 | a f32 | b f32        -> ack / error once the next
//                   frame pair was taught from (where: 0 floor point x y m, 1 omni / 2 persp
//                   pixel u v); refused during an upload
//   read blob       (0x2C): target u8 | offset u32 | length u16 -> blob data (0x0E) / error;
//                   offset 0 takes a new snapshot of what the target has in use
// Replies: ack (0x10): cmd_type u8 | cmd_seq u32
//          error (0x11): cmd_type u8 | cmd_seq u32 | code u8 (CommandError) | detail u32
#include <cstddef>
#include <cstdint>
#include <span>

#include "core/common/status.h"
#include "core/protocol/link.h"
#include "core/protocol/protocol.h"

namespace bv::protocol {

inline constexpr size_t kMaxChunkBytes = 512;

enum class UploadTarget : uint8_t { kCalibration = 1, kLut = 2, kClassifier = 3 };

enum class CommandError : uint8_t {
  kNone = 0,
  kUnknownCommand = 1,
  kBadLength = 2,      // payload length wrong for the command
  kBadTarget = 3,      // unknown upload target
  kNoUpload = 4,       // chunk / commit without a matching begin
  kBadOffset = 5,      // chunk not contiguous with the previous one
  kTooLarge = 6,       // total or chunk beyond capacity
  kVerifyFailed = 7,   // complete upload's CRC or content check failed; old data kept
  kStorageFailed = 8,  // storage refused the write; old data kept
  kUnknownParam = 9,
  kBadValue = 10,    // NaN or out of the parameter's range
  kIncomplete = 11,  // commit before all bytes arrived

  // Capture over the link.
  kBusy = 12,         // a capture is already running (teach: an upload open, a teach pending)
  kUnsupported = 13,  // the board cannot do this (capture without a spare frame slot)
  kNotRunning = 14,   // capture stop without a capture
  // Teaching the ball colour (detail: which camera, 0 omni / 1 persp, where it applies).
  kNoBall = 15,        // nothing ball-like at the point: no region to learn from; old table kept
  kTeachRefused = 16,  // the learnt colour would take the field or lines; old table kept
  // Read-back: a read beyond offset 0 with no snapshot (none taken, or its buffer was used since
  // by an upload or a teach): read again from offset 0.
  kNoSnapshot = 17,
};

/// Where uploads go: the firmware implements it over the A/B blob store, tests with RAM.
class UploadSink {
 public:
  virtual ~UploadSink() = default;
  virtual size_t capacity(UploadTarget target) const = 0;
  /// Prepares the inactive slot. Nothing visible changes until Commit succeeds. kUnavailable:
  /// the buffer is in use (a teach waits for its pair): answered "busy".
  virtual Status Begin(UploadTarget target, size_t total_len) = 0;
  virtual Status Write(UploadTarget target, size_t offset, std::span<const uint8_t> data) = 0;
  /// Verifies (CRC of all bytes == total_crc32, content parses) and activates.
  virtual Status Commit(UploadTarget target, uint32_t total_crc32) = 0;
  virtual void Abort(UploadTarget target) = 0;
};

/// Runtime parameters the main computer may set.
class ParamSink {
 public:
  virtual ~ParamSink() = default;
  /// kNotFound for an unknown id (error 9), kUnavailable when not now (12, busy); any other
  /// error is a bad value (10).
  virtual Status SetParam(uint16_t id, float value) = 0;
};

/// Localisation hints from the main computer (the firmware forwards them to the Pipeline).
/// Values reach it only after the handler's range checks; a refusal leaves everything unchanged.
class PoseSink {
 public:
  virtual ~PoseSink() = default;
  virtual Status SetFieldHalf(int8_t half) = 0;
  virtual Status SetOdometry(float dx_m, float dy_m, float dheading_rad) = 0;
  virtual Status SetRobotPose(bool known, float x_m, float y_m, float heading_rad) = 0;
};

/// Frame capture over the link (the firmware streams from a held camera pair).
class CaptureSink {
 public:
  virtual ~CaptureSink() = default;
  /// Called with a checked request. kFailedPrecondition: a capture runs; kUnimplemented: the
  /// board cannot hold a pair while the loop goes on.
  virtual Status StartCapture(const CaptureRequest& request) = 0;
  /// kFailedPrecondition when no capture runs.
  virtual Status StopCapture() = 0;
};

/// Learning the ball colour on the device. The request is checked by the handler; the sink
/// takes it (kFailedPrecondition: one is pending already) and answers it later, with
/// EncodeCommandReply, once a frame pair was taught from.
class TeachSink {
 public:
  virtual ~TeachSink() = default;
  virtual Status RequestTeach(const TeachRequest& request, uint32_t cmd_seq) = 0;
};

/// Read-back of the blob in use (the colour table as adapted, or the calibration).
class ReadbackSink {
 public:
  virtual ~ReadbackSink() = default;
  /// At offset 0 serialises what `target` has in use into a snapshot; any offset then returns
  /// up to `max_len` of the snapshot's bytes from `offset` in `out` (total_len, blob_crc32 and
  /// data set). kFailedPrecondition: no snapshot; kUnavailable: not now (a teach is pending, or
  /// no room on the link for the reply: retry); kOutOfRange: offset at or beyond the end
  /// (total_len set); kNotFound: nothing in use to read; kUnimplemented: no snapshot buffer.
  virtual Status ReadBlob(UploadTarget target, uint32_t offset, size_t max_len, BlobData& out) = 0;
};

/// The ack (error == kNone) or error reply to command `cmd_type` / `cmd_seq`, as a wire frame.
Result<size_t> EncodeCommandReply(MsgType cmd_type, uint32_t cmd_seq, CommandError error,
                                  uint32_t detail, uint32_t reply_seq, std::span<uint8_t> out);

/// An ack or error reply as the main computer reads it.
struct CommandReply {
  MsgType cmd_type{};
  uint32_t cmd_seq = 0;
  CommandError error = CommandError::kNone;  // kNone for an ack
  uint32_t detail = 0;
};
/// kInvalidArgument: not an ack (5 bytes) or an error (10 bytes) frame.
Status ParseCommandReply(const FrameView& frame, CommandReply& out);

// Ranges the handler accepts (the Pipeline and the pose parameters use the same limits).
inline constexpr float kMaxOdometryStepM = 2.0f;
inline constexpr float kMaxOdometryStepRad = 3.2f;
inline constexpr float kMaxPoseFieldM = 20.0f;
inline constexpr float kMaxPoseHeadingRad = 10.0f;

struct CommandResult {
  bool send_status = false;  // the caller must send a status packet
  bool clock_sync = false;   // the caller must send a clock sync reply to `sync`
  ClockSyncRequest sync;
  bool reply_is_error = false;
  bool deferred = false;  // accepted; the sink answers later (teach)
  CommandError error = CommandError::kNone;
};

class CommandHandler {
 public:
  /// Without a PoseSink the pose commands are answered kUnknownCommand.
  /// Without a CaptureSink the capture commands are answered kUnknownCommand.
  /// Without a TeachSink the teach command is answered kUnknownCommand.
  /// Without a ReadbackSink the read command is answered kUnknownCommand.
  CommandHandler(UploadSink& uploads, ParamSink& params, PoseSink* pose = nullptr,
                 CaptureSink* capture = nullptr, TeachSink* teach = nullptr,
                 ReadbackSink* readback = nullptr)
      : uploads_(uploads),
        params_(params),
        pose_(pose),
        capture_(capture),
        teach_(teach),
        readback_(readback) {}

  /// Handles one verified frame from the Decoder and encodes the reply (ack or error) into
  /// `reply` (a whole wire frame). Returns the reply's size in `reply_len` (0: no reply).
  CommandResult Handle(const FrameView& frame, uint32_t reply_seq, std::span<uint8_t> reply,
                       size_t& reply_len);
  uint32_t errors() const { return errors_; }

 private:
  CommandError Dispatch(const FrameView& frame, CommandResult& result, uint32_t& detail);
  CommandError CaptureCommand(MsgType type, std::span<const uint8_t> p, uint32_t& detail);
  CommandError UploadBegin(std::span<const uint8_t> p);
  CommandError UploadChunk(std::span<const uint8_t> p);
  CommandError UploadCommit(std::span<const uint8_t> p);
  CommandError PoseCommand(MsgType type, std::span<const uint8_t> p);
  CommandError TeachCommand(std::span<const uint8_t> p, uint32_t cmd_seq, CommandResult& result);
  CommandError ReadCommand(std::span<const uint8_t> p, uint32_t cmd_seq, uint32_t& detail);

  UploadSink& uploads_;
  ParamSink& params_;
  PoseSink* pose_;
  CaptureSink* capture_;
  TeachSink* teach_;
  ReadbackSink* readback_;
  BlobData read_;  // a read's answer, encoded by Handle()
  bool uploading_ = false;
  UploadTarget target_ = UploadTarget::kCalibration;
  size_t total_len_ = 0;
  size_t received_ = 0;
  uint32_t total_crc_ = 0;
  uint32_t errors_ = 0;
};

}  // namespace bv::protocol
