#pragma once
// The board-independent firmware: init (blobs from storage, camera start) and the frame loop
//   acquire newest pair -> pipeline -> ball-state packet -> UART -> release
//   -> pose, obstacle and line-point packets (lower priority: dropped first)
// with deadline accounting and a status packet at least once per second. Never allocates and
// never blocks: a missing camera pair is polled again, a full UART drops (and counts) a packet.
#include <cstddef>
#include <cstdint>
#include <span>

#include "core/calibration/calibration.h"
#include "core/color_lut/color_adapt.h"
#include "core/color_lut/color_lut.h"
#include "core/common/blob.h"
#include "core/common/status.h"
#include "core/pipeline.h"
#include "core/protocol/commands.h"
#include "core/protocol/protocol.h"
#include "core/protocol/scan_capture.h"
#include "hal/camera.h"
#include "hal/clock.h"
#include "hal/storage.h"
#include "hal/uart.h"
#include "hal/watchdog.h"

namespace bv::fw {

/// Largest blob validated at boot (calibration or colour LUT, header included).
inline constexpr size_t kBlobScratchBytes =
    kCalibrationBlobMaxBytes > kColorLutBlobBytes ? kCalibrationBlobMaxBytes : kColorLutBlobBytes;

/// Upload buffer: a staging half for the incoming blob and a verification half (read-back and
/// the trial parse), then the colour adapter's state (core/color_lut/color_adapt.h) and the ball
/// classifier's weights in use (core/ball_check); in external RAM on the boards.
inline constexpr size_t kAdapterOffset = 2 * kBlobScratchBytes;
inline constexpr size_t kClassifierOffset =
    (kAdapterOffset + sizeof(ColorAdapter) + alignof(BallClassifier) - 1) /
    alignof(BallClassifier) * alignof(BallClassifier);
inline constexpr size_t kUploadBufferBytes = kClassifierOffset + sizeof(BallClassifier);
static_assert(kBallClassifierBlobMaxBytes <= kBlobScratchBytes);

/// Received bytes decoded per Poll() at most: a full receive ring (2 KB), so commands keep up
/// with the line while a flood cannot hold up the frame loop.
inline constexpr size_t kMaxRxBytesPerPoll = 2048;

/// TX ring bytes the field-feature packets (pose, obstacles, goals, line points) leave free: room
/// for the next pair's ball state and a status packet, so a backlog of low-priority packets can
/// never make the loop drop those.
inline constexpr size_t kTxReserveBytes =
    protocol::WireFrameBytes(protocol::kBallStatePayloadBytes) +
    protocol::WireFrameBytes(protocol::kStatusPayloadBytes);

/// Capture chunks are queued only while the TX ring keeps this much free (ball state, status,
/// a clock sync reply and a worst-case set of field packets) ...
inline constexpr size_t kCaptureReserveBytes =
    kTxReserveBytes + protocol::WireFrameBytes(protocol::kClockSyncReplyBytes) +
    protocol::WireFrameBytes(protocol::kPosePayloadBytes) +
    protocol::WireFrameBytes(protocol::kObstaclesHeaderBytes +
                             protocol::kMaxObstaclesPerPacket * protocol::kObstacleBytes) +
    protocol::WireFrameBytes(protocol::kLinePointsHeaderBytes +
                             protocol::kMaxLinePointsPerPacket * protocol::kLinePointBytes);
/// ... and only while at most this much is queued, so a ball state never waits behind more
/// than two chunks (2 x 540 bytes: 11.7 ms at 921600 Bd).
inline constexpr size_t kCaptureQueueLimitBytes =
    2 * protocol::WireFrameBytes(protocol::kCaptureChunkHeaderBytes + protocol::kCaptureChunkBytes);

/// Longest a clock sync reply waits for the TX ring to empty (a full ring drains in 22 ms at
/// 921600 Bd).
inline constexpr uint64_t kSyncMaxWaitUs = 50000;

/// Parameters the main computer may set (protocol kSetParam).
enum ParamId : uint16_t {
  kParamFramePeriodUs = 1,     // 1000 .. 1000000
  kParamStatusIntervalUs = 2,  // 100000 .. 10000000
  // The robot's pose in the field from the main computer (ball choice: inside the field).
  // Setting x, y or heading makes the pose known; kParamRobotPoseKnown = 0 forgets it.
  kParamRobotFieldX = 10,      // m, |x| <= 20
  kParamRobotFieldY = 11,      // m, |y| <= 20
  kParamRobotHeadingRad = 12,  // rad, |h| <= 10
  kParamRobotPoseKnown = 13,   // 0 or 1
  // Online colour adaptation (docs/protocol.md, "Teach"): 1 on, 0 off (the table stays as
  // adapted); needs a table whose model the device knows (built-in or taught). Writing 1 to
  // kParamSaveColorTable stores the table in use A/B, as an upload: only then does an adapted
  // table survive a reboot.
  kParamColorAdaptation = 20,
  kParamSaveColorTable = 21,
  // Writing 1 stores the calibration in use with the persp camera's correction folded in (A/B,
  // as an upload, under a new calibration id) and makes it the calibration: only then does a
  // correction survive a reboot. Refused while no correction stands.
  kParamSaveCorrection = 22,
};

struct MainLoopConfig {
  uint32_t frame_period_us = 33333;       // processing longer than this is an overrun
  uint32_t status_interval_us = 1000000;  // of exposure time (and of clock time when idle)
  int calibration_slots[2] = {0, 1};      // A/B storage slots (hal/common/blob_store.h)
  int lut_slots[2] = {2, 3};
  int classifier_slots[2] = {4, 5};  // the ball classifier's weights (built-in when empty)
  /// Capture chunks queued per Poll() at most. At 921600 Bd the queue limit allows ~2 anyway;
  /// this bounds the work where the UART drains faster (QEMU's is instantaneous).
  uint32_t capture_chunks_per_poll = 4;
  bool color_adaptation = false;  // at boot (the parameter switches it later)
  PipelineConfig pipeline;
};

/// Bits of StatusReport::fault_flags set by the main loop.
enum FaultFlags : uint32_t {
  kFaultPipelineNotReady = 1u << 0,  // no usable calibration / LUT: ball states are "not found"
  kFaultCameraBadInput = 1u << 1,    // the camera layer rejected input (Camera::BadInputCount)
  kFaultCameraStart = 1u << 2,       // Camera::Start failed
  kFaultTimestampJump = 1u << 3,     // a pair's exposure time jumped forward by more than
                                     // kTimestampJumpPeriods frame periods (sticky)
  kFaultNoSelfMask = 1u << 4,  // the omni calibration has no self-mask: the reference rig's body,
                               // rim and struts stand in for this robot's
};

/// A forward gap between consecutive pairs' exposure times above this many frame periods is
/// reported as kFaultTimestampJump (a backward step is kPairOutOfOrder).
inline constexpr uint32_t kTimestampJumpPeriods = 10;

class MainLoop {
 public:
  /// `blob_scratch` holds one blob while it is validated in Init() (>= kBlobScratchBytes); it
  /// is not used afterwards, so a board may lend a camera DMA slot before Camera::Start().
  /// `upload_buffer` (>= kUploadBufferBytes, else uploads are refused) receives calibration /
  /// LUT uploads from the main computer.
  /// `watchdog` (optional) is fed once per Poll().
  /// `tables` hold the pipeline's scan tables (external RAM on the boards: BoardPipelineTables).
  MainLoop(hal::Camera& camera, hal::Uart& uart, hal::Clock& clock, hal::Storage& storage,
           PipelineTables& tables, std::span<uint8_t> blob_scratch,
           const MainLoopConfig& config = MainLoopConfig(), hal::Watchdog* watchdog = nullptr,
           std::span<uint8_t> upload_buffer = std::span<uint8_t>());

  /// Loads calibration and LUT (problems are reported in the status packet, not fatal), starts
  /// the camera and sends the first status packet. Errors: the camera's Start() error.
  Status Init();
  /// One non-blocking iteration: serves received commands, then at most one frame pair.
  /// Returns true when a frame pair was handled.
  bool Poll();
  /// Polls until the camera reports Finished() (captured sequences) and a running capture has
  /// sent what it holds, then sends a final status packet. A live camera never finishes: this
  /// is then the firmware's forever loop.
  void RunUntilFinished();
  /// Encodes and queues the status packet now.
  void SendStatus();

  const protocol::StatusReport& status() const { return status_; }
  uint32_t ball_packets_sent() const { return ball_packets_sent_; }
  uint32_t status_packets_sent() const { return status_packets_sent_; }
  uint32_t feature_packets_sent() const { return feature_packets_sent_; }
  uint32_t capture_chunks_sent() const { return capture_chunks_sent_; }
  uint32_t sync_replies_sent() const { return sync_replies_sent_; }
  bool capture_active() const { return capture_.active; }
  bool pipeline_ready() const { return pipeline_ready_; }
  const ColorLut& lut() const { return lut_; }
  const Pipeline& pipeline() const { return pipeline_; }

 private:
  protocol::BlobState LoadCalibration();
  protocol::BlobState LoadLut();
  protocol::BlobState UseBuiltInLut(protocol::BlobState stored);
  /// The classifier's weights from their slots, else the built-in ones.
  void LoadClassifier();
  /// Loads the current blob of `kind` from an A/B slot pair (hal::BlobStore) into
  /// blob_scratch_ and points `blob` at it; returns the state for the status packet.
  protocol::BlobState ReadSlotPair(const int (&slots)[2], BlobKind kind, uint16_t max_version,
                                   std::span<const uint8_t>& blob);
  void Send(std::span<const uint8_t> frame);
  /// Queues a pose / line / obstacle packet only if kTxReserveBytes stay free; false (and
  /// counted) otherwise.
  bool SendLowPriority(const Result<size_t>& encoded);
  void SendFieldPackets(uint64_t exposure_us, bool omni_seen);
  void PollCommands();
  void InitPipeline();

  // Uploads over the A/B blob stores; nothing changes until an upload is verified and saved.
  class Uploads : public protocol::UploadSink {
   public:
    explicit Uploads(MainLoop& loop) : loop_(loop) {}
    size_t capacity(protocol::UploadTarget target) const override;
    Status Begin(protocol::UploadTarget target, size_t total_len) override;
    Status Write(protocol::UploadTarget target, size_t offset,
                 std::span<const uint8_t> data) override;
    Status Commit(protocol::UploadTarget target, uint32_t total_crc32) override;
    void Abort(protocol::UploadTarget target) override;
    bool open() const { return length_ != 0; }

   private:
    MainLoop& loop_;
    size_t length_ = 0;
  };
  class Params : public protocol::ParamSink {
   public:
    explicit Params(MainLoop& loop) : loop_(loop) {}
    Status SetParam(uint16_t id, float value) override;

   private:
    MainLoop& loop_;
  };
  // Localisation hints from the main computer (protocol kSetFieldHalf, kOdometry, kSetPose).
  class Hints : public protocol::PoseSink {
   public:
    explicit Hints(MainLoop& loop) : loop_(loop) {}
    Status SetFieldHalf(int8_t half) override { return loop_.pipeline_.SetFieldHalf(half); }
    Status SetOdometry(float dx_m, float dy_m, float dheading_rad) override {
      return loop_.pipeline_.SetOdometry(dx_m, dy_m, dheading_rad);
    }
    Status SetRobotPose(bool known, float x_m, float y_m, float heading_rad) override;

   private:
    MainLoop& loop_;
  };
  // Capture over the link: one pair held in its camera slots and streamed in chunks between
  // frames, lowest priority (docs/protocol.md, "Capture").
  class Capture : public protocol::CaptureSink {
   public:
    explicit Capture(MainLoop& loop) : loop_(loop) {}
    Status StartCapture(const protocol::CaptureRequest& request) override;
    Status StopCapture() override;

   private:
    MainLoop& loop_;
  };
  // Teaching the ball colour (docs/protocol.md, "Teach"): the request waits for the next pair.
  class Teacher : public protocol::TeachSink {
   public:
    explicit Teacher(MainLoop& loop) : loop_(loop) {}
    Status RequestTeach(const protocol::TeachRequest& request, uint32_t cmd_seq) override;

   private:
    MainLoop& loop_;
  };
  // Read-back of the blob in use (docs/protocol.md, "Read-back"): a snapshot in the upload
  // buffer's first half, served in chunks; any other use of that half drops it.
  class Readback : public protocol::ReadbackSink {
   public:
    explicit Readback(MainLoop& loop) : loop_(loop) {}
    Status ReadBlob(protocol::UploadTarget target, uint32_t offset, size_t max_len,
                    protocol::BlobData& out) override;

   private:
    MainLoop& loop_;
  };
  struct Snapshot {
    bool valid = false;
    protocol::UploadTarget target = protocol::UploadTarget::kLut;
    uint32_t length = 0;
    uint32_t crc32 = 0;
  };
  struct TeachPending {
    bool active = false;
    protocol::TeachRequest request;
    uint32_t cmd_seq = 0;
  };
  /// Teaches from `in` (the pending request), stores and activates the table, replies.
  void RunTeach(const FrameInput& in);
  protocol::CommandError TeachAndStore(const FrameInput& in, uint32_t& detail);
  /// `table` into the A/B slots as an upload would store it; its id becomes `lut_id`.
  protocol::CommandError StoreTable(const ColorLut& table);
  /// kParamSaveCorrection: the corrected calibration stored A/B and activated.
  Status StoreCorrection();
  bool reinit_pending_ = false;  // the calibration changed under a command: InitPipeline next
  // The upload buffer holds an open upload or waits for a teach's pair.
  bool UploadBufferBusy() const { return uploads_.open() || teach_.active; }
  Status SetAdaptation(bool on);
  struct CaptureState {
    bool active = false;
    bool holding = false;  // `pair` is held in the camera for streaming
    bool header_sent = false;
    bool end_pending = false;
    uint16_t id = 0;
    uint16_t count = 0;
    uint16_t pairs_sent = 0;
    protocol::CaptureMode mode = protocol::CaptureMode::kFull;
    uint8_t cameras = 0;       // requested
    uint8_t pair_cameras = 0;  // requested and present in the held pair
    uint8_t camera = 0;        // image being streamed: 0 omni, 1 persp
    uint32_t offset = 0;
    uint32_t image_bytes = 0;         // of the image being streamed
    uint32_t tables_generation = 0;   // scanlines: the tables the samples come from
    uint32_t scan_crc[2] = {0, 0};    // scanlines: ScanPositionsCrc per camera
    protocol::ScanSampleStream scan;  // scanlines: the image being streamed
    hal::FramePair pair;
    protocol::CaptureEnd end;
  };
  /// Keeps the pair for the capture (true) or leaves it to be released.
  bool TakeForCapture(const hal::FramePair& pair);
  const ScanlineTableBase& ScanTable(uint8_t camera) const;  // 0 omni, 1 persp
  bool ScanTablesUnchanged() const;
  /// Starts streaming `camera`'s image of the held pair.
  void BeginCaptureImage(uint8_t camera);
  bool SendCaptureHeader();
  bool FillCaptureChunk(std::span<uint8_t> out);
  void PumpCapture();
  bool SendCapturePacket(const Result<size_t>& encoded, size_t reserve);
  void EndCapture(protocol::CaptureEndReason reason);
  void AnswerClockSync(const protocol::ClockSyncRequest& request);
  void SendPendingSync();
  void CountPairFlags(const hal::FramePair& pair);
  void MaybeSendStatus(uint64_t exposure_us);

  hal::Camera& camera_;
  hal::Uart& uart_;
  hal::Clock& clock_;
  hal::Storage& storage_;
  std::span<uint8_t> blob_scratch_;
  MainLoopConfig config_;
  hal::Watchdog* watchdog_;
  std::span<uint8_t> upload_buffer_;

  RigCalibration calibration_;
  ColorLut lut_;       // 64 KB: the loop object is meant to be static, never on the stack
  Pipeline pipeline_;  // its scan tables are outside the loop object
  bool pipeline_ready_ = false;
  uint32_t tables_generation_ = 0;  // +1 each time the pipeline (and its scan tables) is built
  protocol::StatusReport status_;
  uint32_t seq_ = 0;
  uint32_t ball_packets_sent_ = 0;
  uint32_t status_packets_sent_ = 0;
  uint32_t feature_packets_sent_ = 0;
  uint32_t capture_chunks_sent_ = 0;
  uint32_t sync_replies_sent_ = 0;
  size_t tx_capacity_ = 0;  // WriteSpace() of the empty ring at Init()
  CaptureState capture_;
  protocol::ClockSyncReply sync_;  // t1, t2 of a request whose reply waits for an empty ring
  bool sync_pending_ = false;
  // Status cadence and frame rate: the pairs since the last status packet.
  uint32_t interval_pairs_ = 0;
  uint64_t interval_first_exposure_us_ = 0;
  uint64_t interval_last_exposure_us_ = 0;
  uint64_t last_status_clock_us_ = 0;
  bool have_status_exposure_ = false;
  uint64_t last_status_exposure_us_ = 0;  // exposure time at which the last status went out
  uint8_t packet_[protocol::kMaxWireFrameBytes] = {};
  Uploads uploads_{*this};
  Params params_{*this};
  Hints hints_{*this};
  Capture capture_sink_{*this};
  Teacher teacher_{*this};
  TeachPending teach_;
  Readback readback_{*this};
  Snapshot snapshot_;
  ColorAdapter* adapter_ = nullptr;  // in the upload buffer; null without one
  // The ball classifier's weights in use (uploaded, else built-in), in the upload buffer; null
  // without one (no appearance check then).
  BallClassifier* classifier_ = nullptr;
  bool classifier_uploaded_ = false;
  BallColorModel lut_model_;  // what the table in use was built from, if known
  bool lut_model_known_ = false;
  protocol::Decoder rx_;
  protocol::CommandHandler commands_{uploads_,       params_,   &hints_,
                                     &capture_sink_, &teacher_, &readback_};
};

}  // namespace bv::fw

/// Marker functions for the instruction-count plugin (firmware/tools/insncount.c); they do
/// nothing. bv_perf_*: around Pipeline::Process. bv_pair_*: a whole pair in the loop (after
/// the camera handed it out: pipeline, packet encoding, UART queueing, release, status).
extern "C" void bv_perf_begin();
extern "C" void bv_perf_end();
extern "C" void bv_pair_begin();
extern "C" void bv_pair_end();
