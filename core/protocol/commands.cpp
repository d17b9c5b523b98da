#include "core/protocol/commands.h"

#include <cmath>

#include "core/common/bytes.h"

namespace bv::protocol {
namespace {

bool ValidTarget(uint8_t t) {
  return t == static_cast<uint8_t>(UploadTarget::kCalibration) ||
         t == static_cast<uint8_t>(UploadTarget::kLut) ||
         t == static_cast<uint8_t>(UploadTarget::kClassifier);
}

bool Within(float v, float limit) { return std::fabs(v) <= limit; }  // false for NaN

}  // namespace

CommandResult CommandHandler::Handle(const FrameView& frame, uint32_t reply_seq,
                                     std::span<uint8_t> reply, size_t& reply_len) {
  CommandResult result;
  uint32_t detail = 0;
  result.error = Dispatch(frame, result, detail);
  result.reply_is_error = result.error != CommandError::kNone;
  if (result.reply_is_error) ++errors_;
  reply_len = 0;
  if (frame.type == MsgType::kReadBlob && !result.reply_is_error) {
    auto n = EncodeBlobData(read_, reply_seq, reply);
    if (n.ok()) reply_len = *n;
    return result;
  }
  if ((frame.type == MsgType::kRequestStatus || frame.type == MsgType::kClockSync ||
       result.deferred) &&
      !result.reply_is_error) {
    return result;  // the caller answers with a status packet / sync reply / later
  }
  auto n = EncodeCommandReply(frame.type, frame.seq, result.error, detail, reply_seq, reply);
  if (n.ok()) reply_len = *n;
  return result;
}

Result<size_t> EncodeCommandReply(MsgType cmd_type, uint32_t cmd_seq, CommandError error,
                                  uint32_t detail, uint32_t reply_seq, std::span<uint8_t> out) {
  uint8_t payload[10];
  ByteWriter w(payload);
  w.U8(static_cast<uint8_t>(cmd_type));
  w.U32(cmd_seq);
  if (error != CommandError::kNone) {
    w.U8(static_cast<uint8_t>(error));
    w.U32(detail);
  }
  return EncodeFrame(error != CommandError::kNone ? MsgType::kError : MsgType::kAck, reply_seq,
                     w.written(), out);
}

Status ParseCommandReply(const FrameView& frame, CommandReply& out) {
  const bool ack = frame.type == MsgType::kAck && frame.payload.size() == 5;
  const bool error = frame.type == MsgType::kError && frame.payload.size() == 10;
  if (!ack && !error) return Status(StatusCode::kInvalidArgument, "not a command reply");
  ByteReader r(frame.payload);
  CommandReply reply;
  reply.cmd_type = static_cast<MsgType>(r.U8());
  reply.cmd_seq = r.U32();
  if (error) {
    reply.error = static_cast<CommandError>(r.U8());
    reply.detail = r.U32();
  }
  out = reply;
  return Status();
}

// Checked here: finite numbers, a floor point within 20 m, a pixel within 0..4095; not while an
// upload is open (the device teaches in the upload buffer).
CommandError CommandHandler::TeachCommand(std::span<const uint8_t> p, uint32_t cmd_seq,
                                          CommandResult& result) {
  if (p.size() != kTeachBallBytes) return CommandError::kBadLength;
  ByteReader r(p);
  TeachRequest t;
  const uint8_t where = r.U8();
  t.a = r.F32();
  t.b = r.F32();
  if (where > static_cast<uint8_t>(TeachWhere::kPerspPixel)) return CommandError::kBadTarget;
  t.where = static_cast<TeachWhere>(where);
  const float limit = t.where == TeachWhere::kFloorPoint ? kMaxPoseFieldM : 4095.0f;
  const float low = t.where == TeachWhere::kFloorPoint ? -kMaxPoseFieldM : 0.0f;
  if (!(t.a >= low && t.a <= limit && t.b >= low && t.b <= limit)) return CommandError::kBadValue;
  if (uploading_) return CommandError::kBusy;
  if (!teach_->RequestTeach(t, cmd_seq).ok()) return CommandError::kBusy;
  result.deferred = true;
  return CommandError::kNone;
}

// A snapshot at offset 0 would overwrite an open upload's staged bytes: refused while one is
// open. detail: the snapshot's length for an offset beyond it.
CommandError CommandHandler::ReadCommand(std::span<const uint8_t> p, uint32_t cmd_seq,
                                         uint32_t& detail) {
  ReadBlobRequest req;
  if (!ParseReadBlob(p, req).ok()) return CommandError::kBadLength;
  if (!ValidTarget(req.target)) return CommandError::kBadTarget;
  if (req.length == 0 || req.length > kBlobDataBytes) {
    detail = kBlobDataBytes;
    return CommandError::kBadValue;
  }
  if (uploading_) return CommandError::kBusy;
  BlobData d;
  const Status s =
      readback_->ReadBlob(static_cast<UploadTarget>(req.target), req.offset, req.length, d);
  switch (s.code()) {
    case StatusCode::kOk:
      break;
    case StatusCode::kFailedPrecondition:
      return CommandError::kNoSnapshot;
    case StatusCode::kUnavailable:
      return CommandError::kBusy;
    case StatusCode::kOutOfRange:
      detail = d.total_len;
      return CommandError::kBadOffset;
    case StatusCode::kUnimplemented:
      return CommandError::kUnsupported;  // the board has no buffer for a snapshot
    default:
      return CommandError::kBadTarget;  // nothing of that kind in use
  }
  read_ = d;
  read_.cmd_seq = cmd_seq;
  read_.target = req.target;
  read_.offset = req.offset;
  return CommandError::kNone;
}

CommandError CommandHandler::Dispatch(const FrameView& frame, CommandResult& result,
                                      uint32_t& detail) {
  const auto p = frame.payload;
  switch (frame.type) {
    case MsgType::kRequestStatus:
      if (!p.empty()) return CommandError::kBadLength;
      result.send_status = true;
      return CommandError::kNone;
    case MsgType::kClockSync:
      if (!ParseClockSyncRequest(p, result.sync).ok()) return CommandError::kBadLength;
      result.clock_sync = true;
      return CommandError::kNone;
    case MsgType::kCaptureStart:
    case MsgType::kCaptureStop:
      if (capture_ == nullptr) break;
      return CaptureCommand(frame.type, p, detail);
    case MsgType::kSetParam: {
      if (p.size() != 6) return CommandError::kBadLength;
      ByteReader r(p);
      const uint16_t id = r.U16();
      const float value = r.F32();
      detail = id;
      if (!std::isfinite(value)) return CommandError::kBadValue;
      const Status s = params_.SetParam(id, value);
      if (s.code() == StatusCode::kNotFound) return CommandError::kUnknownParam;
      if (s.code() == StatusCode::kUnavailable) return CommandError::kBusy;
      return s.ok() ? CommandError::kNone : CommandError::kBadValue;
    }
    case MsgType::kUploadBegin:
      return UploadBegin(p);
    case MsgType::kUploadChunk: {
      const CommandError e = UploadChunk(p);
      detail = static_cast<uint32_t>(received_);  // lets the sender resume at the right offset
      return e;
    }
    case MsgType::kUploadCommit:
      return UploadCommit(p);
    case MsgType::kTeachBall:
      if (teach_ == nullptr) break;
      return TeachCommand(p, frame.seq, result);
    case MsgType::kReadBlob:
      if (readback_ == nullptr) break;
      return ReadCommand(p, frame.seq, detail);
    case MsgType::kSetFieldHalf:
    case MsgType::kOdometry:
    case MsgType::kSetPose:
      if (pose_ == nullptr) break;
      return PoseCommand(frame.type, p);
    default:
      break;
  }
  detail = static_cast<uint32_t>(frame.type);
  return CommandError::kUnknownCommand;
}

// Every value is checked here before the sink sees it: a refused command changes nothing.
CommandError CommandHandler::PoseCommand(MsgType type, std::span<const uint8_t> p) {
  ByteReader r(p);
  Status s;
  if (type == MsgType::kSetFieldHalf) {
    if (p.size() != 1) return CommandError::kBadLength;
    const auto half = static_cast<int8_t>(r.U8());
    if (half < -1 || half > 1) return CommandError::kBadValue;
    s = pose_->SetFieldHalf(half);
  } else if (type == MsgType::kOdometry) {
    if (p.size() != 12) return CommandError::kBadLength;
    const float dx = r.F32(), dy = r.F32(), dh = r.F32();
    if (!Within(dx, kMaxOdometryStepM) || !Within(dy, kMaxOdometryStepM) ||
        !Within(dh, kMaxOdometryStepRad)) {
      return CommandError::kBadValue;
    }
    s = pose_->SetOdometry(dx, dy, dh);
  } else {
    if (p.size() != 13) return CommandError::kBadLength;
    const uint8_t known = r.U8();
    const float x = r.F32(), y = r.F32(), h = r.F32();
    if (known > 1 || !Within(x, kMaxPoseFieldM) || !Within(y, kMaxPoseFieldM) ||
        !Within(h, kMaxPoseHeadingRad)) {
      return CommandError::kBadValue;
    }
    s = pose_->SetRobotPose(known == 1, x, y, h);
  }
  return s.ok() ? CommandError::kNone : CommandError::kBadValue;
}

// detail: the limit a refused value broke (count: kMaxCapturePairs).
CommandError CommandHandler::CaptureCommand(MsgType type, std::span<const uint8_t> p,
                                            uint32_t& detail) {
  if (type == MsgType::kCaptureStop) {
    if (!p.empty()) return CommandError::kBadLength;
    return capture_->StopCapture().ok() ? CommandError::kNone : CommandError::kNotRunning;
  }
  CaptureRequest req;
  if (!ParseCaptureStart(p, req).ok()) return CommandError::kBadLength;
  uint16_t w = 0, h = 0;
  if (req.count == 0 || req.count > kMaxCapturePairs) {
    detail = kMaxCapturePairs;
    return CommandError::kBadValue;
  }
  if (!CaptureSize(req.mode, w, h) || req.cameras == 0 ||
      (req.cameras & ~(kCaptureOmni | kCapturePersp)) != 0) {
    return CommandError::kBadValue;
  }
  const Status s = capture_->StartCapture(req);
  if (s.code() == StatusCode::kFailedPrecondition) return CommandError::kBusy;
  if (s.code() == StatusCode::kUnimplemented) return CommandError::kUnsupported;
  return s.ok() ? CommandError::kNone : CommandError::kBadValue;
}

CommandError CommandHandler::UploadBegin(std::span<const uint8_t> p) {
  if (p.size() != 9) return CommandError::kBadLength;
  ByteReader r(p);
  const uint8_t target = r.U8();
  const uint32_t total = r.U32();
  const uint32_t crc = r.U32();
  if (!ValidTarget(target)) return CommandError::kBadTarget;
  const auto t = static_cast<UploadTarget>(target);
  if (total == 0 || total > uploads_.capacity(t)) return CommandError::kTooLarge;
  if (uploading_) uploads_.Abort(target_);  // a new begin replaces an unfinished upload
  uploading_ = false;
  const Status begun = uploads_.Begin(t, total);
  if (begun.code() == StatusCode::kUnavailable) return CommandError::kBusy;
  if (!begun.ok()) return CommandError::kStorageFailed;
  uploading_ = true;
  target_ = t;
  total_len_ = total;
  total_crc_ = crc;
  received_ = 0;
  return CommandError::kNone;
}

CommandError CommandHandler::UploadChunk(std::span<const uint8_t> p) {
  if (p.size() < 6 || p.size() > 5 + kMaxChunkBytes) return CommandError::kBadLength;
  ByteReader r(p);
  const uint8_t target = r.U8();
  const uint32_t offset = r.U32();
  const auto data = p.subspan(5);
  if (!ValidTarget(target)) return CommandError::kBadTarget;
  if (!uploading_ || static_cast<UploadTarget>(target) != target_) return CommandError::kNoUpload;
  if (offset != received_) return CommandError::kBadOffset;
  if (data.size() > total_len_ - received_) return CommandError::kTooLarge;
  if (!uploads_.Write(target_, offset, data).ok()) {
    uploads_.Abort(target_);
    uploading_ = false;
    return CommandError::kStorageFailed;
  }
  received_ += data.size();
  return CommandError::kNone;
}

CommandError CommandHandler::UploadCommit(std::span<const uint8_t> p) {
  if (p.size() != 1) return CommandError::kBadLength;
  if (!ValidTarget(p[0])) return CommandError::kBadTarget;
  if (!uploading_ || static_cast<UploadTarget>(p[0]) != target_) return CommandError::kNoUpload;
  if (received_ != total_len_) return CommandError::kIncomplete;
  uploading_ = false;
  const Status s = uploads_.Commit(target_, total_crc_);
  if (!s.ok()) {
    uploads_.Abort(target_);
    return s.code() == StatusCode::kDataLoss || s.code() == StatusCode::kInvalidArgument
               ? CommandError::kVerifyFailed
               : CommandError::kStorageFailed;
  }
  return CommandError::kNone;
}

}  // namespace bv::protocol
