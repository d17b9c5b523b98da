#include "firmware/main_loop.h"

#include <cmath>
#include <cstring>
#include <new>

#include "core/color_lut/color_model.h"
#include "core/color_lut/color_teach.h"
#include "core/common/blob.h"
#include "core/common/crc32.h"
#include "hal/common/blob_store.h"

extern "C" __attribute__((noinline, used)) void bv_perf_begin() { asm volatile("" ::: "memory"); }
extern "C" __attribute__((noinline, used)) void bv_perf_end() { asm volatile("" ::: "memory"); }
extern "C" __attribute__((noinline, used)) void bv_pair_begin() { asm volatile("" ::: "memory"); }
extern "C" __attribute__((noinline, used)) void bv_pair_end() { asm volatile("" ::: "memory"); }

namespace bv::fw {
namespace {

using protocol::BlobState;

// A frame the camera layer handed out, as the pipeline's image view; invalid (skipped by the
// pipeline) when absent or too short for 640x480 at its stride.
YuyvImage ToImage(const hal::Frame& f) {
  const size_t stride = f.stride_bytes != 0 ? f.stride_bytes : kFrameWidth * kYuyvBytesPerPixel;
  if (!f.present || f.data == nullptr || stride < kFrameWidth * kYuyvBytesPerPixel ||
      f.size_bytes < stride * (kFrameHeight - 1) + kFrameWidth * kYuyvBytesPerPixel) {
    return YuyvImage{};
  }
  return YuyvImage{f.data, kFrameWidth, kFrameHeight, static_cast<int>(stride)};
}

// A camera check's confidence as the status packet carries it: saturated, NaN as 0.
uint8_t Percent(float fraction) {
  const float p = fraction * 100.0f + 0.5f;
  return p >= 100.0f ? uint8_t{100} : p >= 0.0f ? static_cast<uint8_t>(p) : uint8_t{0};
}

}  // namespace

MainLoop::MainLoop(hal::Camera& camera, hal::Uart& uart, hal::Clock& clock, hal::Storage& storage,
                   PipelineTables& tables, std::span<uint8_t> blob_scratch,
                   const MainLoopConfig& config, hal::Watchdog* watchdog,
                   std::span<uint8_t> upload_buffer)
    : camera_(camera),
      uart_(uart),
      clock_(clock),
      storage_(storage),
      blob_scratch_(blob_scratch),
      config_(config),
      watchdog_(watchdog),
      upload_buffer_(upload_buffer.size() >= kUploadBufferBytes ? upload_buffer
                                                                : std::span<uint8_t>()),
      pipeline_(tables) {
  static_assert(kAdapterOffset % alignof(ColorAdapter) == 0);
  static_assert(kClassifierOffset % alignof(BallClassifier) == 0);
  if (!upload_buffer_.empty()) {
    adapter_ = new (upload_buffer_.data() + kAdapterOffset) ColorAdapter;
    classifier_ = new (upload_buffer_.data() + kClassifierOffset) BallClassifier;
  }
}

BlobState MainLoop::ReadSlotPair(const int (&slots)[2], BlobKind kind, uint16_t max_version,
                                 std::span<const uint8_t>& blob) {
  hal::BlobStore store(storage_, slots[0], slots[1], kind, max_version);
  const Result<size_t> n = store.Load(blob_scratch_);
  if (n.ok()) {
    blob = blob_scratch_.first(*n);
    return BlobState::kOk;
  }
  // Nothing valid: tell "never written" (erased) from "written but damaged".
  for (int slot : slots) {
    uint8_t head[16];
    if (!storage_.Read(slot, 0, head).ok()) return BlobState::kCorrupt;
    for (uint8_t b : head) {
      if (b != 0xFF) return BlobState::kCorrupt;
    }
  }
  return BlobState::kMissing;
}

BlobState MainLoop::LoadCalibration() {
  std::span<const uint8_t> blob;
  const BlobState state = ReadSlotPair(config_.calibration_slots, BlobKind::kCalibration,
                                       kCalibrationBlobVersion, blob);
  if (state != BlobState::kOk) return state;
  // ParseCalibration checks ranges too; `calibration_` is untouched on failure.
  if (!ParseCalibration(blob, calibration_).ok()) return BlobState::kCorrupt;
  status_.calibration_id = calibration_.calibration_id;
  return BlobState::kOk;
}

BlobState MainLoop::LoadLut() {
  std::span<const uint8_t> blob;
  const BlobState state =
      ReadSlotPair(config_.lut_slots, BlobKind::kColorLut, kColorLutBlobVersion, blob);
  if (state != BlobState::kOk) return state;
  if (!ParseLut(blob, lut_).ok()) return BlobState::kCorrupt;
  status_.lut_id = lut_.Id();
  return BlobState::kOk;
}

// No usable stored table: the built-in colour model's (red to orange balls in sun and shade) is
// built in place, so a new board finds the ball before anything was uploaded or taught.
BlobState MainLoop::UseBuiltInLut(BlobState stored) {
  if (!BuildLut(BallColorModel{}, lut_).ok()) return stored;
  status_.lut_id = lut_.Id();
  lut_model_ = BallColorModel{};
  lut_model_known_ = true;
  return stored == BlobState::kCorrupt ? BlobState::kBuiltInCorrupt : BlobState::kBuiltInMissing;
}

void MainLoop::LoadClassifier() {
  if (classifier_ == nullptr) return;
  std::span<const uint8_t> blob;
  classifier_uploaded_ = ReadSlotPair(config_.classifier_slots, BlobKind::kBallClassifier,
                                      kBallClassifierBlobVersion, blob) == BlobState::kOk &&
                         classifier_->Parse(blob).ok();
  // The built-in weights are checked like a stored blob (CRC, sizes); they cannot fail to parse
  // but for a build error, which leaves the look check off rather than the device down.
  if (!classifier_uploaded_) classifier_->Parse(BuiltInBallClassifierBlob()).IgnoreError();
}

Status MainLoop::Init() {
  status_ = protocol::StatusReport{};
  const BlobState cal = LoadCalibration();
  LoadClassifier();
  BlobState lut = LoadLut();
  if (lut != BlobState::kOk) lut = UseBuiltInLut(lut);
  status_.calibration_state = static_cast<uint8_t>(cal);
  status_.lut_state = static_cast<uint8_t>(lut);
  InitPipeline();
  if (config_.color_adaptation) SetAdaptation(true).IgnoreError();  // no model: stays off

  const Status camera = camera_.Start();
  if (!camera.ok()) status_.fault_flags |= kFaultCameraStart;
  tx_capacity_ = uart_.WriteSpace();
  SendStatus();
  return camera;
}

void MainLoop::InitPipeline() {
  ++tables_generation_;  // a scanline capture in progress checks that its samples stayed
  config_.pipeline.classifier =
      classifier_ != nullptr && classifier_->loaded() ? classifier_ : nullptr;
  pipeline_ready_ = status_.calibration_state == static_cast<uint8_t>(BlobState::kOk) &&
                    status_.lut_state != static_cast<uint8_t>(BlobState::kMissing) &&
                    status_.lut_state != static_cast<uint8_t>(BlobState::kCorrupt) &&
                    pipeline_.Init(calibration_, lut_, config_.pipeline).ok();
  if (pipeline_ready_) {
    status_.fault_flags &= ~kFaultPipelineNotReady;
  } else {
    status_.fault_flags |= kFaultPipelineNotReady;
  }
  if (pipeline_ready_ && calibration_.omni.valid && !calibration_.omni.self_mask.known) {
    status_.fault_flags |= kFaultNoSelfMask;
  } else {
    status_.fault_flags &= ~kFaultNoSelfMask;
  }
}

size_t MainLoop::Uploads::capacity(protocol::UploadTarget target) const {
  if (loop_.upload_buffer_.empty()) return 0;
  switch (target) {
    case protocol::UploadTarget::kCalibration:
      return kCalibrationBlobMaxBytes;
    case protocol::UploadTarget::kLut:
      return kColorLutBlobBytes;
    case protocol::UploadTarget::kClassifier:
      return kBallClassifierBlobMaxBytes;
  }
  return 0;
}

Status MainLoop::Uploads::Begin(protocol::UploadTarget target, size_t total_len) {
  if (loop_.teach_.active) {
    return Status(StatusCode::kUnavailable, "upload: a teach is using the buffer");
  }
  if (total_len > capacity(target)) {
    return Status(StatusCode::kResourceExhausted, "upload: larger than the target allows");
  }
  length_ = total_len;
  loop_.snapshot_.valid = false;  // the staging half is about to be overwritten
  return Status();
}

Status MainLoop::Readback::ReadBlob(protocol::UploadTarget target, uint32_t offset, size_t max_len,
                                    protocol::BlobData& out) {
  MainLoop& m = loop_;
  Snapshot& snap = m.snapshot_;
  if (m.upload_buffer_.empty()) return Status(StatusCode::kUnimplemented, "read-back: no buffer");
  if (m.teach_.active) return Status(StatusCode::kUnavailable, "read-back: a teach is pending");
  // The reply is low priority: it never takes the room kept for ball states and status.
  const size_t reply = protocol::WireFrameBytes(protocol::kBlobDataHeaderBytes + max_len);
  if (m.uart_.WriteSpace() < reply + kTxReserveBytes) {
    return Status(StatusCode::kUnavailable, "read-back: no room on the link now");
  }
  if (offset == 0) {
    snap.valid = false;
    const std::span<uint8_t> buf = m.upload_buffer_.first(kBlobScratchBytes);
    const bool calibration = target == protocol::UploadTarget::kCalibration;
    const bool classifier = target == protocol::UploadTarget::kClassifier;
    if (calibration && m.status_.calibration_state != static_cast<uint8_t>(BlobState::kOk)) {
      return Status(StatusCode::kNotFound, "read-back: no calibration in use");
    }
    if (classifier && (m.classifier_ == nullptr || !m.classifier_->loaded())) {
      return Status(StatusCode::kNotFound, "read-back: no ball classifier in use");
    }
    const Result<size_t> n = calibration  ? SerializeCalibration(m.calibration_, buf)
                             : classifier ? SerializeBallClassifier(m.classifier_->weights(), buf)
                                          : SerializeLut(m.lut_, buf);
    if (!n.ok()) return Status(StatusCode::kNotFound, n.status().message());
    snap = {true, target, static_cast<uint32_t>(*n), Crc32(buf.first(*n))};
  }
  if (!snap.valid || snap.target != target) {
    return Status(StatusCode::kFailedPrecondition, "read-back: no snapshot, read from 0");
  }
  out.total_len = snap.length;
  out.blob_crc32 = snap.crc32;
  if (offset >= snap.length) return Status(StatusCode::kOutOfRange, "read-back: beyond the end");
  const size_t n = max_len < snap.length - offset ? max_len : snap.length - offset;
  out.data = m.upload_buffer_.subspan(offset, n);
  return Status();
}

Status MainLoop::Uploads::Write(protocol::UploadTarget, size_t offset,
                                std::span<const uint8_t> data) {
  if (offset > length_ || data.size() > length_ - offset) {
    return Status(StatusCode::kOutOfRange, "upload: chunk outside the announced length");
  }
  std::memcpy(loop_.upload_buffer_.data() + offset, data.data(), data.size());
  return Status();
}

void MainLoop::Uploads::Abort(protocol::UploadTarget) { length_ = 0; }

namespace {
struct SlotsOf {
  const int* slots;
  BlobKind kind;
  uint16_t version;
};
}  // namespace

Status MainLoop::Uploads::Commit(protocol::UploadTarget target, uint32_t total_crc32) {
  MainLoop& m = loop_;
  const std::span<const uint8_t> blob = m.upload_buffer_.first(length_);
  const std::span<uint8_t> verify = m.upload_buffer_.subspan(kBlobScratchBytes);
  length_ = 0;
  if (Crc32(blob) != total_crc32) return Status(StatusCode::kDataLoss, "upload: CRC mismatch");
  // Trial parse into the verification half (placement, not heap) before anything is saved.
  static_assert(sizeof(RigCalibration) <= kBlobScratchBytes &&
                sizeof(ColorLut) <= kBlobScratchBytes &&
                sizeof(BallClassifier) <= kBlobScratchBytes);
  static_assert(kBlobScratchBytes % alignof(RigCalibration) == 0 &&
                kBlobScratchBytes % alignof(ColorLut) == 0 &&
                kBlobScratchBytes % alignof(BallClassifier) == 0);
  const bool calibration = target == protocol::UploadTarget::kCalibration;
  const bool classifier = target == protocol::UploadTarget::kClassifier;
  const Status parsed = calibration  ? ParseCalibration(blob, *new (verify.data()) RigCalibration)
                        : classifier ? (new (verify.data()) BallClassifier)->Parse(blob)
                                     : ParseLut(blob, *new (verify.data()) ColorLut);
  if (!parsed.ok()) return Status(StatusCode::kInvalidArgument, parsed.message());
  const SlotsOf where =
      calibration
          ? SlotsOf{m.config_.calibration_slots, BlobKind::kCalibration, kCalibrationBlobVersion}
      : classifier ? SlotsOf{m.config_.classifier_slots, BlobKind::kBallClassifier,
                             kBallClassifierBlobVersion}
                   : SlotsOf{m.config_.lut_slots, BlobKind::kColorLut, kColorLutBlobVersion};
  hal::BlobStore store(m.storage_, where.slots[0], where.slots[1], where.kind, where.version);
  BV_TRY(store.Save(blob, verify));
  // Saved and known to parse: activate.
  if (calibration) {
    BV_TRY(ParseCalibration(blob, m.calibration_));
    m.status_.calibration_id = m.calibration_.calibration_id;
    m.status_.calibration_state = static_cast<uint8_t>(BlobState::kOk);
  } else if (classifier) {
    if (m.classifier_ == nullptr) return Status(StatusCode::kUnimplemented, "upload: no buffer");
    BV_TRY(m.classifier_->Parse(blob));
    m.classifier_uploaded_ = true;
  } else {
    m.SetAdaptation(false).IgnoreError();  // an uploaded table does not carry its model
    BV_TRY(ParseLut(blob, m.lut_));
    m.status_.lut_id = m.lut_.Id();
    m.status_.lut_state = static_cast<uint8_t>(BlobState::kOk);
    m.lut_model_known_ = false;
  }
  m.InitPipeline();
  return Status();
}

Status MainLoop::Teacher::RequestTeach(const protocol::TeachRequest& request, uint32_t cmd_seq) {
  if (loop_.teach_.active) return Status(StatusCode::kFailedPrecondition, "teach: one pending");
  loop_.teach_.active = true;
  loop_.teach_.request = request;
  loop_.teach_.cmd_seq = cmd_seq;
  return Status();
}

// The ball's floor point into each camera (centre and radius), or the given pixel of one.
static void TeachTargets(const RigCalibration& cal, const protocol::TeachRequest& r,
                         TeachTarget t[2]) {
  using protocol::TeachWhere;
  if (r.where != TeachWhere::kFloorPoint) {
    TeachTarget& one = t[r.where == TeachWhere::kOmniPixel ? 0 : 1];
    one.valid = true;
    one.u_px = r.a;
    one.v_px = r.b;
    return;
  }
  const float rb = cal.ball_radius_m;
  const Eigen::Vector3f p(r.a, r.b, rb);
  float u = 0, v = 0, u2 = 0, v2 = 0;
  const float d = std::hypot(r.a, r.b);
  if (cal.omni.valid && d > 1e-3f && OmniProject(cal.omni, p, u, v).ok() &&
      OmniProject(cal.omni, p + Eigen::Vector3f(r.a / d * rb, r.b / d * rb, 0.f), u2, v2).ok()) {
    t[0] = {true, u, v, std::hypot(u2 - u, v2 - v)};
  }
  if (cal.persp.valid && PerspProject(cal.persp, p, u, v).ok()) {
    const float range = (p - cal.persp.t_robot_cam).norm();
    t[1] = {true, u, v, range > rb ? cal.persp.fx * rb / range : 0.f};
  }
}

// Teaches in the upload buffer (no upload can be open: the handler refuses a teach then):
// blob in the first half, the new table and the teach statistics in the second.
protocol::CommandError MainLoop::TeachAndStore(const FrameInput& in, uint32_t& detail) {
  using protocol::CommandError;
  const protocol::TeachRequest& r = teach_.request;
  if (upload_buffer_.empty()) return CommandError::kUnsupported;
  if (r.where == protocol::TeachWhere::kFloorPoint &&
      status_.calibration_state != static_cast<uint8_t>(BlobState::kOk)) {
    return CommandError::kUnsupported;  // a floor point needs the calibration
  }
  TeachTarget targets[2];
  TeachTargets(calibration_, r, targets);
  const YuyvImage images[2] = {in.omni, in.persp};
  const std::span<uint8_t> work = upload_buffer_.subspan(kBlobScratchBytes, kBlobScratchBytes);
  static_assert(sizeof(ColorLut) + sizeof(TeachWorkspace) <= kBlobScratchBytes);
  static_assert(sizeof(ColorLut) % alignof(TeachWorkspace) == 0);
  ColorLut& table = *new (work.data()) ColorLut;
  TeachWorkspace& ws = *new (work.data() + sizeof(ColorLut)) TeachWorkspace;
  BallColorModel model;
  int camera = -1;
  const Status taught = TeachFromImages(images, targets, BallColorModel{}, ws, model, camera);
  detail = camera < 0 ? 0xFFu : static_cast<uint32_t>(camera);
  if (!taught.ok()) {
    return taught.code() == StatusCode::kOutOfRange ? CommandError::kTeachRefused
                                                    : CommandError::kNoBall;
  }
  if (!BuildLut(model, table).ok()) return CommandError::kTeachRefused;
  // Stored exactly as an uploaded table: A/B slots with CRC, then activated.
  const CommandError stored = StoreTable(table);
  if (stored != CommandError::kNone) return stored;
  // `table` was overwritten by the read-back check; the blob in the first half is intact.
  if (!ParseLut(upload_buffer_.first(kColorLutBlobBytes), lut_).ok()) {
    return CommandError::kStorageFailed;
  }
  lut_model_ = model;
  lut_model_known_ = true;
  const bool adapting = adapter_ != nullptr && adapter_->active();
  InitPipeline();
  if (adapting) SetAdaptation(true).IgnoreError();  // from the taught model on
  return CommandError::kNone;
}

void MainLoop::RunTeach(const FrameInput& in) {
  uint32_t detail = 0;
  const protocol::CommandError e = TeachAndStore(in, detail);
  teach_.active = false;
  const Result<size_t> n = protocol::EncodeCommandReply(protocol::MsgType::kTeachBall,
                                                        teach_.cmd_seq, e, detail, seq_, packet_);
  if (n.ok()) {
    ++seq_;
    Send(std::span<const uint8_t>(packet_, *n));
  }
}

Status MainLoop::Params::SetParam(uint16_t id, float value) {
  switch (id) {
    case kParamFramePeriodUs:
      if (!(value >= 1000.0f && value <= 1000000.0f)) {
        return Status(StatusCode::kOutOfRange, "frame period must be 1000..1000000 us");
      }
      loop_.config_.frame_period_us = static_cast<uint32_t>(std::lround(value));
      return Status();
    case kParamStatusIntervalUs:
      if (!(value >= 100000.0f && value <= 10000000.0f)) {
        return Status(StatusCode::kOutOfRange, "status interval must be 0.1..10 s");
      }
      loop_.config_.status_interval_us = static_cast<uint32_t>(std::lround(value));
      return Status();
    case kParamRobotFieldX:
    case kParamRobotFieldY:
    case kParamRobotHeadingRad:
    case kParamRobotPoseKnown: {
      RobotPose pose = loop_.pipeline_.robot_pose();
      const float limit = id == kParamRobotHeadingRad  ? 10.0f
                          : id == kParamRobotPoseKnown ? 1.0f
                                                       : 20.0f;
      if (!(std::fabs(value) <= limit))
        return Status(StatusCode::kOutOfRange, "robot pose out of range");
      if (id == kParamRobotFieldX) pose.x_m = value;
      if (id == kParamRobotFieldY) pose.y_m = value;
      if (id == kParamRobotHeadingRad) pose.heading_rad = value;
      pose.known = id == kParamRobotPoseKnown ? value >= 0.5f : true;
      return loop_.pipeline_.SetRobotPose(pose);
    }
    case kParamColorAdaptation:
      if (!(value == 0.0f || value == 1.0f)) return Status(StatusCode::kOutOfRange, "0 or 1");
      return loop_.SetAdaptation(value == 1.0f);
    case kParamSaveColorTable:
    case kParamSaveCorrection:
      if (value != 1.0f) return Status(StatusCode::kOutOfRange, "1 saves");
      // Both serialise into the upload buffer: an open upload or a pending teach keeps it.
      if (loop_.UploadBufferBusy()) return Status(StatusCode::kUnavailable, "buffer in use");
      if (id == kParamSaveCorrection) return loop_.StoreCorrection();
      return loop_.StoreTable(loop_.lut_) == protocol::CommandError::kNone
                 ? Status()
                 : Status(StatusCode::kInvalidArgument, "the table could not be stored");
    default:
      return Status(StatusCode::kNotFound, "unknown parameter");
  }
}

Status MainLoop::SetAdaptation(bool on) {
  if (!on) {
    if (adapter_ != nullptr) adapter_->Stop();
    pipeline_.SetColorAdapter(nullptr);
    return Status();
  }
  if (adapter_ == nullptr || !lut_model_known_) {
    return Status(StatusCode::kFailedPrecondition,
                  "adaptation needs the model of the table in use (built-in or taught)");
  }
  adapter_->Start(lut_model_, &lut_);
  pipeline_.SetColorAdapter(adapter_);
  return Status();
}

// Serialised into the upload buffer's first half (left there), saved A/B with the read-back
// check in the second half (which overwrites a `table` placed there), reported as in use.
protocol::CommandError MainLoop::StoreTable(const ColorLut& table) {
  if (upload_buffer_.empty()) return protocol::CommandError::kUnsupported;
  snapshot_.valid = false;
  const std::span<uint8_t> blob = upload_buffer_.first(kBlobScratchBytes);
  const Result<size_t> n = SerializeLut(table, blob);
  if (!n.ok()) return protocol::CommandError::kStorageFailed;
  const uint32_t id = table.Id();  // before the read-back may overwrite it
  hal::BlobStore store(storage_, config_.lut_slots[0], config_.lut_slots[1], BlobKind::kColorLut,
                       kColorLutBlobVersion);
  if (!store.Save(blob.first(*n), upload_buffer_.subspan(kBlobScratchBytes, kBlobScratchBytes))
           .ok()) {
    return protocol::CommandError::kStorageFailed;
  }
  status_.lut_id = id;
  status_.lut_state = static_cast<uint8_t>(BlobState::kOk);
  return protocol::CommandError::kNone;
}

// The calibration copy is built in the upload buffer's second half (no room for it on the
// stack), serialised into the first, saved A/B with the second as the read-back check, then
// parsed back as the calibration in use: the pipeline restarts from it (PollCommands, once this
// command is answered), its turn estimate at 0.
Status MainLoop::StoreCorrection() {
  if (upload_buffer_.empty()) return Status(StatusCode::kUnimplemented, "no upload buffer");
  if (!pipeline_ready_) return Status(StatusCode::kFailedPrecondition, "pipeline not running");
  snapshot_.valid = false;
  const std::span<uint8_t> blob = upload_buffer_.first(kBlobScratchBytes);
  const std::span<uint8_t> verify = upload_buffer_.subspan(kBlobScratchBytes, kBlobScratchBytes);
  RigCalibration& corrected = *new (verify.data()) RigCalibration;
  if (!pipeline_.CorrectedCalibration(corrected)) {
    return Status(StatusCode::kFailedPrecondition, "no correction stands");
  }
  // A new id, from the content: the old one names the calibration as it was measured.
  corrected.calibration_id = 0;
  Result<size_t> n = SerializeCalibration(corrected, blob);
  if (!n.ok()) return n.status();
  uint32_t id = Crc32(blob.first(*n));
  if (id == calibration_.calibration_id) id ^= 1u;
  corrected.calibration_id = id;
  n = SerializeCalibration(corrected, blob);
  if (!n.ok()) return n.status();
  hal::BlobStore store(storage_, config_.calibration_slots[0], config_.calibration_slots[1],
                       BlobKind::kCalibration, kCalibrationBlobVersion);
  BV_TRY(store.Save(blob.first(*n), verify));
  BV_TRY(ParseCalibration(blob.first(*n), calibration_));
  status_.calibration_id = calibration_.calibration_id;
  reinit_pending_ = true;  // PollCommands restarts the pipeline right after this command
  return Status();
}

Status MainLoop::Hints::SetRobotPose(bool known, float x_m, float y_m, float heading_rad) {
  RobotPose pose;
  pose.known = known;
  pose.x_m = x_m;
  pose.y_m = y_m;
  pose.heading_rad = heading_rad;
  return loop_.pipeline_.SetRobotPose(pose);
}

void MainLoop::PollCommands() {
  // Drains what the receive ring holds (bounded, so a flood cannot starve the frame loop).
  // Read() stops at each delimiter, so the frame's arrival stamp is at hand for clock sync.
  uint8_t bytes[64];
  size_t budget = kMaxRxBytesPerPoll;
  while (budget > 0) {
    const Result<size_t> n = uart_.Read(std::span<uint8_t>(bytes, budget < 64 ? budget : 64));
    if (!n.ok() || *n == 0) break;
    budget -= *n;
    for (size_t i = 0; i < *n; ++i) {
      protocol::FrameView frame;
      if (!rx_.Push(bytes[i], frame)) continue;
      size_t reply_len = 0;
      const protocol::CommandResult r = commands_.Handle(frame, seq_, packet_, reply_len);
      if (reply_len > 0) {
        ++seq_;
        Send(std::span<const uint8_t>(packet_, reply_len));
      }
      if (r.send_status) SendStatus();
      if (r.clock_sync) AnswerClockSync(r.sync);
      // Here, not inside the command's handler: Pipeline::Init's stack on top of a handler's
      // would pass the budget. Before the next command, so commands keep their order.
      if (reinit_pending_) {
        reinit_pending_ = false;
        InitPipeline();
      }
    }
  }
}

// t2: the request's delimiter as the receive interrupt stamped it (the loop's reaction time does
// not enter). The reply waits until the TX ring is empty (a capture queues nothing meanwhile),
// so t3, stamped then, is when its first byte starts: bytes queued ahead of it would be path
// delay on one side only. After kSyncMaxWaitUs it goes anyway (a stalled line).
void MainLoop::AnswerClockSync(const protocol::ClockSyncRequest& request) {
  const Result<uint64_t> rx = uart_.LastRxFrameUs();
  const uint64_t now = clock_.NowUs();
  sync_.id = request.id;
  sync_.t1_host_us = request.t1_host_us;
  sync_.t2_rx_us = rx.ok() && *rx <= now ? *rx : now;
  sync_pending_ = true;  // a newer request replaces one still waiting
  SendPendingSync();
}

void MainLoop::SendPendingSync() {
  if (!sync_pending_) return;
  const uint64_t now = clock_.NowUs();
  const size_t space = uart_.WriteSpace();
  if (space < tx_capacity_ && now - sync_.t2_rx_us < kSyncMaxWaitUs) return;
  sync_pending_ = false;
  sync_.t3_tx_us = now;
  const Result<size_t> n = protocol::EncodeClockSyncReply(sync_, seq_++, packet_);
  if (!n.ok()) {
    ++status_.pipeline_errors;
    return;
  }
  const uint32_t dropped_before = status_.packets_dropped;
  Send(std::span<const uint8_t>(packet_, *n));
  if (status_.packets_dropped == dropped_before) ++sync_replies_sent_;
}

Status MainLoop::Capture::StartCapture(const protocol::CaptureRequest& request) {
  CaptureState& c = loop_.capture_;
  if (c.active) return Status(StatusCode::kFailedPrecondition, "capture: one is running");
  if (loop_.camera_.MaxHeldPairs() < 2) {
    return Status(StatusCode::kUnimplemented, "capture: the camera cannot hold a second pair");
  }
  const bool scan = request.mode == protocol::CaptureMode::kScanlines;
  for (uint8_t cam = 0; cam < 2 && scan; ++cam) {
    // The samples are those of the tables the pipeline runs on: none without a calibration.
    if ((request.cameras & (1u << cam)) != 0 &&
        (!loop_.pipeline_ready_ || !loop_.ScanTable(cam).built())) {
      return Status(StatusCode::kUnimplemented, "capture: no scan table for a camera asked for");
    }
  }
  const uint16_t id = static_cast<uint16_t>(c.id + 1);
  c = CaptureState{};
  c.active = true;
  c.id = id;
  c.count = request.count;
  c.mode = request.mode;
  c.cameras = request.cameras;
  c.tables_generation = loop_.tables_generation_;
  uint16_t w = 0, h = 0;
  (void)protocol::CaptureSize(request.mode, w, h);  // the handler checked the mode
  c.image_bytes = uint32_t{w} * h * 2u;             // scanlines: set per image
  for (uint8_t cam = 0; cam < 2 && scan; ++cam) {   // once per capture: a pass over each table
    if ((request.cameras & (1u << cam)) != 0) {
      c.scan_crc[cam] = protocol::ScanPositionsCrc(loop_.ScanTable(cam));
    }
  }
  return Status();
}

Status MainLoop::Capture::StopCapture() {
  CaptureState& c = loop_.capture_;
  if (!c.active || c.end_pending) {
    return Status(StatusCode::kFailedPrecondition, "capture: none running");
  }
  loop_.EndCapture(protocol::CaptureEndReason::kStopped);
  return Status();
}

void MainLoop::EndCapture(protocol::CaptureEndReason reason) {
  CaptureState& c = capture_;
  if (c.holding) camera_.Release(c.pair);
  c.holding = false;
  c.end_pending = true;
  c.end.capture_id = c.id;
  c.end.requested = c.count;
  c.end.pairs_sent = c.pairs_sent;
  c.end.reason = reason;
}

const ScanlineTableBase& MainLoop::ScanTable(uint8_t camera) const {
  return camera == 0 ? pipeline_.omni_scan() : pipeline_.persp_scan();
}

// After the pipeline was rebuilt (an upload or a teach) during a scanline capture: true when
// every requested camera's table still has the samples the capture started with (a new colour
// table leaves them; a new calibration may not), so the streams' cursors stay valid.
bool MainLoop::ScanTablesUnchanged() const {
  const CaptureState& c = capture_;
  for (uint8_t cam = 0; cam < 2; ++cam) {
    if ((c.cameras & (1u << cam)) == 0) continue;
    if (!pipeline_ready_ || !ScanTable(cam).built() ||
        protocol::ScanPositionsCrc(ScanTable(cam)) != c.scan_crc[cam]) {
      return false;
    }
  }
  return true;
}

void MainLoop::BeginCaptureImage(uint8_t camera) {
  CaptureState& c = capture_;
  c.camera = camera;
  c.offset = 0;
  if (c.mode != protocol::CaptureMode::kScanlines) return;  // image_bytes is the mode's
  c.scan.Start(ScanTable(camera), c.scan_crc[camera]);
  c.image_bytes = c.scan.total_bytes();
}

bool MainLoop::TakeForCapture(const hal::FramePair& pair) {
  CaptureState& c = capture_;
  if (!c.active || c.holding || c.end_pending) return false;
  uint8_t present = 0;
  if (pair.omni.present && ToImage(pair.omni).valid()) present |= protocol::kCaptureOmni;
  if (pair.persp.present && ToImage(pair.persp).valid()) present |= protocol::kCapturePersp;
  present &= c.cameras;
  if (present == 0 || (pair.flags & hal::kPairTorn) != 0) return false;  // nothing worth sending
  c.holding = true;
  c.header_sent = false;
  c.pair = pair;
  c.pair_cameras = present;
  BeginCaptureImage((present & protocol::kCaptureOmni) != 0 ? 0 : 1);
  return true;
}

bool MainLoop::SendCapturePacket(const Result<size_t>& encoded, size_t reserve) {
  if (!encoded.ok()) {
    ++status_.pipeline_errors;
    return false;
  }
  const size_t space = uart_.WriteSpace();
  const size_t queued = tx_capacity_ > space ? tx_capacity_ - space : 0;
  if (space < *encoded + reserve || queued + *encoded > kCaptureQueueLimitBytes) return false;
  return uart_.Write(std::span<const uint8_t>(packet_, *encoded)).ok();
}

bool MainLoop::SendCaptureHeader() {
  const CaptureState& c = capture_;
  protocol::CaptureFrame f;
  f.capture_id = c.id;
  f.pair_index = c.pairs_sent;
  f.count = c.count;
  f.mode = c.mode;
  f.cameras = c.pair_cameras;
  (void)protocol::CaptureSize(c.mode, f.width, f.height);
  f.exposure_us = c.pair.exposure_us;
  f.omni_exposure_us = c.pair.omni.present ? c.pair.omni.exposure_us : 0;
  f.persp_exposure_us = c.pair.persp.present ? c.pair.persp.exposure_us : 0;
  f.omni_sequence = c.pair.omni.sequence;
  f.persp_sequence = c.pair.persp.sequence;
  f.image_bytes = c.image_bytes;
  if (c.mode == protocol::CaptureMode::kScanlines) {  // both streams of the pair
    f.image_bytes = 0;
    for (uint8_t cam = 0; cam < 2; ++cam) {
      if ((c.pair_cameras & (1u << cam)) == 0) continue;
      f.image_bytes += protocol::ScanStreamBytes(ScanTable(cam).pixel_count());
    }
  }
  if (!SendCapturePacket(protocol::EncodeCaptureFrame(f, seq_, packet_), kCaptureReserveBytes)) {
    return false;
  }
  ++seq_;
  return true;
}

// The next bytes of the image being streamed: decimated rows, or scan-table samples.
bool MainLoop::FillCaptureChunk(std::span<uint8_t> out) {
  CaptureState& c = capture_;
  const hal::Frame& frame = c.camera == 0 ? c.pair.omni : c.pair.persp;
  if (c.mode == protocol::CaptureMode::kScanlines) return c.scan.Read(ToImage(frame), out);
  const size_t stride =
      frame.stride_bytes != 0 ? frame.stride_bytes : kFrameWidth * kYuyvBytesPerPixel;
  return protocol::CopyCaptureBytes(frame.data, stride, c.mode, c.offset, out);
}

// Waits for room instead of dropping: a packet is encoded (and gets its sequence number) only
// once it fits, so the capture stream has no gaps of its own.
void MainLoop::PumpCapture() {
  CaptureState& c = capture_;
  if (!c.active || sync_pending_) return;  // let the ring empty for a clock sync reply
  const size_t chunk_wire =
      protocol::WireFrameBytes(protocol::kCaptureChunkHeaderBytes + protocol::kCaptureChunkBytes);
  if (c.end_pending) {
    if (uart_.WriteSpace() <
        protocol::WireFrameBytes(protocol::kCaptureEndBytes) + kTxReserveBytes) {
      return;
    }
    if (SendCapturePacket(protocol::EncodeCaptureEnd(c.end, seq_, packet_), kTxReserveBytes)) {
      ++seq_;
      c.active = false;
      c.end_pending = false;
    }
    return;
  }
  if (!c.holding) {
    if (camera_.Finished()) EndCapture(protocol::CaptureEndReason::kCameraFinished);
    return;
  }
  if (c.mode == protocol::CaptureMode::kScanlines && c.tables_generation != tables_generation_) {
    if (!ScanTablesUnchanged()) {
      EndCapture(protocol::CaptureEndReason::kStopped);  // a new calibration moved the samples
      return;
    }
    c.tables_generation = tables_generation_;
  }
  for (uint32_t i = 0; i < config_.capture_chunks_per_poll; ++i) {
    const size_t space = uart_.WriteSpace();
    const size_t queued = tx_capacity_ > space ? tx_capacity_ - space : 0;
    if (space < chunk_wire + kCaptureReserveBytes ||
        queued + chunk_wire > kCaptureQueueLimitBytes) {
      return;  // before encoding: no sequence number is spent on a packet that waits
    }
    if (!c.header_sent) {
      if (!SendCaptureHeader()) return;
      c.header_sent = true;
      continue;
    }
    uint8_t data[protocol::kCaptureChunkBytes];
    const size_t n =
        c.image_bytes - c.offset < sizeof(data) ? c.image_bytes - c.offset : sizeof(data);
    const protocol::ScanSampleStream rewind = c.scan;  // a chunk that waits is read again
    if (!FillCaptureChunk(std::span<uint8_t>(data, n))) {
      ++status_.pipeline_errors;
      EndCapture(protocol::CaptureEndReason::kStopped);
      return;
    }
    protocol::CaptureChunk chunk;
    chunk.capture_id = c.id;
    chunk.pair_index = c.pairs_sent;
    chunk.camera = c.camera;
    chunk.offset = c.offset;
    chunk.data = std::span<const uint8_t>(data, n);
    if (!SendCapturePacket(protocol::EncodeCaptureChunk(chunk, seq_, packet_),
                           kCaptureReserveBytes)) {
      c.scan = rewind;
      return;
    }
    ++seq_;
    ++capture_chunks_sent_;
    c.offset += static_cast<uint32_t>(n);
    if (c.offset < c.image_bytes) continue;
    if (c.camera == 0 && (c.pair_cameras & protocol::kCapturePersp) != 0) {
      BeginCaptureImage(1);
      continue;
    }
    camera_.Release(c.pair);
    c.holding = false;
    ++c.pairs_sent;
    if (c.pairs_sent >= c.count) EndCapture(protocol::CaptureEndReason::kComplete);
    return;
  }
}

void MainLoop::Send(std::span<const uint8_t> frame) {
  if (!uart_.Write(frame).ok()) ++status_.packets_dropped;
}

bool MainLoop::SendLowPriority(const Result<size_t>& encoded) {
  if (!encoded.ok()) {
    ++status_.pipeline_errors;
    return false;
  }
  const std::span<const uint8_t> frame(packet_, *encoded);
  if (uart_.WriteSpace() < frame.size() + kTxReserveBytes || !uart_.Write(frame).ok()) {
    ++status_.feature_packets_dropped;
    return false;
  }
  ++feature_packets_sent_;
  return true;
}

// After the ball state, one packet at a time through packet_ (no extra buffer); most useful
// first, so under backpressure the large line-point packet is the one that goes. Without an
// omni image the pipeline keeps the previous features: they are not sent again as new.
void MainLoop::SendFieldPackets(uint64_t exposure_us, bool omni_seen) {
  if (!pipeline_ready_ || !config_.pipeline.field_features) return;
  SendLowPriority(protocol::EncodePose(pipeline_.localisation(), exposure_us, seq_++, packet_));
  if (!omni_seen) return;
  const FieldFeatures& f = pipeline_.features();
  SendLowPriority(protocol::EncodeObstacles(f, exposure_us, seq_++, packet_));
  SendLowPriority(protocol::EncodeGoals(f, exposure_us, seq_++, packet_));
  size_t sent = 0;
  if (SendLowPriority(protocol::EncodeLinePoints(f, exposure_us, seq_++, packet_, sent))) {
    const size_t found = static_cast<size_t>(f.line_count > 0 ? f.line_count : 0) + f.lines_dropped;
    status_.line_points_unsent += static_cast<uint32_t>(found - sent);
  }
}

void MainLoop::SendStatus() {
  status_.uptime_us = clock_.NowUs();
  status_.rx_errors = rx_.stats().errors();
  status_.command_errors = commands_.errors();
  const hal::UartRxStats link = uart_.RxStats();
  status_.rx_overruns = link.overruns;
  status_.rx_ring_full = link.ring_full;
  status_.rx_line_errors = link.line_errors;
  last_status_clock_us_ = status_.uptime_us;
  // Pairs per second of exposure time since the previous status packet.
  status_.frame_rate_mhz = 0;
  if (interval_pairs_ >= 2 && interval_last_exposure_us_ > interval_first_exposure_us_) {
    status_.frame_rate_mhz =
        static_cast<uint32_t>(uint64_t{interval_pairs_ - 1} * 1000000000ull /
                              (interval_last_exposure_us_ - interval_first_exposure_us_));
  }
  interval_pairs_ = 0;
  if (camera_.BadInputCount() != 0) status_.fault_flags |= kFaultCameraBadInput;
  const Result<size_t> n = protocol::EncodeStatus(status_, seq_++, packet_);
  if (!n.ok()) {
    ++status_.pipeline_errors;  // cannot happen with a correctly sized buffer; counted anyway
    return;
  }
  const uint32_t dropped_before = status_.packets_dropped;
  Send(std::span<const uint8_t>(packet_, *n));
  if (status_.packets_dropped == dropped_before) ++status_packets_sent_;
}

void MainLoop::CountPairFlags(const hal::FramePair& pair) {
  status_.frames_dropped += pair.dropped;
  if (pair.flags & hal::kPairOmniMissing) ++status_.pairs_omni_missing;
  if (pair.flags & hal::kPairPerspMissing) ++status_.pairs_persp_missing;
  if (pair.flags & hal::kPairOutOfSync) ++status_.pairs_out_of_sync;
  if (pair.flags & hal::kPairOutOfOrder) ++status_.pairs_out_of_order;
  if (pair.flags & hal::kPairTorn) ++status_.pairs_torn;
}

void MainLoop::MaybeSendStatus(uint64_t exposure_us) {
  if (interval_pairs_ == 0) interval_first_exposure_us_ = exposure_us;
  ++interval_pairs_;
  interval_last_exposure_us_ = exposure_us;
  if (!have_status_exposure_) {
    have_status_exposure_ = true;
    last_status_exposure_us_ = exposure_us;
  }
  // Exactly one status per status_interval_us of exposure time (an out-of-order pair with an
  // older timestamp never triggers one; the clock heartbeat in Poll() covers stalls).
  if (exposure_us >= last_status_exposure_us_ + config_.status_interval_us) {
    last_status_exposure_us_ += config_.status_interval_us;
    if (exposure_us >= last_status_exposure_us_ + config_.status_interval_us) {
      last_status_exposure_us_ = exposure_us;  // a gap in the stream: restart the cadence
    }
    SendStatus();
  }
}

bool MainLoop::Poll() {
  if (watchdog_ != nullptr) watchdog_->Feed();
  PollCommands();
  SendPendingSync();
  PumpCapture();
  hal::FramePair pair;
  if (!camera_.AcquirePair(pair).ok()) {
    // Idle: keep the status heartbeat going on clock time (live camera stalled or absent).
    const uint64_t now_us = clock_.NowUs();
    if (now_us - last_status_clock_us_ >= config_.status_interval_us) SendStatus();
    return false;
  }
  bv_pair_begin();
  const uint64_t start_us = clock_.NowUs();
  CountPairFlags(pair);

  FrameInput in;
  in.omni = ToImage(pair.omni);
  in.persp = ToImage(pair.persp);
  in.t_us = pair.exposure_us;
  if (pair.omni.present) in.omni_t_us = pair.omni.exposure_us;
  if (pair.persp.present) in.persp_t_us = pair.persp.exposure_us;

  if (teach_.active) RunTeach(in);
  BallState state;
  if (pipeline_ready_) {
    bv_perf_begin();
    const Status st = pipeline_.Process(in, state);
    bv_perf_end();
    if (!st.ok()) ++status_.pipeline_errors;
  } else {
    state = BallState{};
    state.t_us = pair.exposure_us;
  }
  status_.check_omni = state.omni_check.Byte();
  status_.check_persp = state.persp_check.Byte();
  status_.change_omni_cdeg = protocol::ChangeCentiDegrees(state.omni_check.change_deg);
  status_.change_persp_cdeg = protocol::ChangeCentiDegrees(state.persp_check.change_deg);
  status_.confidence_omni_pct = Percent(state.omni_check.confidence);
  status_.confidence_persp_pct = Percent(state.persp_check.confidence);
  if (state.omni_check.state == CameraState::kUnusable) ++status_.pairs_omni_unusable;
  if (state.persp_check.state == CameraState::kUnusable) ++status_.pairs_persp_unusable;
  const uint64_t proc_us = clock_.NowUs() - start_us;
  state.proc_us = static_cast<uint32_t>(proc_us > UINT32_MAX ? UINT32_MAX : proc_us);

  const Result<size_t> n = protocol::EncodeBallState(state, seq_++, packet_);
  if (n.ok()) {
    const uint32_t dropped_before = status_.packets_dropped;
    Send(std::span<const uint8_t>(packet_, *n));
    if (status_.packets_dropped == dropped_before) ++ball_packets_sent_;
  } else {
    ++status_.pipeline_errors;  // e.g. a NaN the encoder refuses; the stream stays valid
  }
  if (!TakeForCapture(pair)) camera_.Release(pair);
  SendFieldPackets(pair.exposure_us, in.omni.valid());

  const uint64_t total_us = clock_.NowUs() - start_us;
  status_.last_proc_us = static_cast<uint32_t>(total_us > UINT32_MAX ? UINT32_MAX : total_us);
  if (status_.last_proc_us > status_.max_proc_us) status_.max_proc_us = status_.last_proc_us;
  if (total_us > config_.frame_period_us) ++status_.deadline_overruns;
  ++status_.frames_processed;
  if (have_status_exposure_ &&
      pair.exposure_us >
          interval_last_exposure_us_ + uint64_t{kTimestampJumpPeriods} * config_.frame_period_us) {
    status_.fault_flags |= kFaultTimestampJump;  // interval_last_: the previous pair's exposure
  }
  MaybeSendStatus(pair.exposure_us);
  bv_pair_end();
  return true;
}

void MainLoop::RunUntilFinished() {
  while (!camera_.Finished() || capture_.active) Poll();
  if (teach_.active) {  // the frames ended before a pair could be taught from
    teach_.active = false;
    const Result<size_t> n =
        protocol::EncodeCommandReply(protocol::MsgType::kTeachBall, teach_.cmd_seq,
                                     protocol::CommandError::kNoBall, 0xFFu, seq_, packet_);
    if (n.ok()) {
      ++seq_;
      Send(std::span<const uint8_t>(packet_, *n));
    }
  }
  SendStatus();
}

}  // namespace bv::fw
