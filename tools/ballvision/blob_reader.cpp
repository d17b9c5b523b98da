#include "tools/ballvision/blob_reader.h"

#include "core/ball_check/ball_check.h"
#include "core/calibration/calibration.h"
#include "core/color_lut/color_lut.h"
#include "core/common/crc32.h"

namespace bv::cli {

bool BlobReader::NextRequest(protocol::ReadBlobRequest& out, uint32_t& cmd_seq) {
  if (waiting_ || done_ || failed()) return false;
  out.target = static_cast<uint8_t>(target_);
  out.offset = static_cast<uint32_t>(blob_.size());
  out.length = static_cast<uint16_t>(protocol::kBlobDataBytes);
  cmd_seq = outstanding_seq_ = seq_++;
  waiting_ = true;
  return true;
}

void BlobReader::Restart(const char* why) {
  if (++restarts_ > kMaxRestarts) {
    error_ = std::string(why) + ", " + std::to_string(kMaxRestarts) + " times: giving up";
    return;
  }
  blob_.clear();
  total_ = crc_ = 0;
}

void BlobReader::Finish() {
  if (Crc32(blob_) != crc_) {
    Restart("the blob's CRC does not match its bytes");
    return;
  }
  // The device serialised what it uses: it must parse as such, or nothing is written.
  static ColorLut lut;  // 64 KB: not on the stack
  static RigCalibration cal;
  static BallClassifier classifier;
  const Status s = target_ == protocol::UploadTarget::kLut          ? ParseLut(blob_, lut)
                   : target_ == protocol::UploadTarget::kClassifier ? classifier.Parse(blob_)
                                                                    : ParseCalibration(blob_, cal);
  if (!s.ok()) {
    error_ = std::string("the blob read back does not parse: ") + s.message();
    return;
  }
  done_ = true;
}

void BlobReader::OnFrame(const protocol::FrameView& frame) {
  if (!waiting_ || done_ || failed()) return;
  protocol::CommandReply reply;
  if (protocol::ParseCommandReply(frame, reply).ok()) {
    if (reply.cmd_type != protocol::MsgType::kReadBlob || reply.cmd_seq != outstanding_seq_ ||
        reply.error == protocol::CommandError::kNone) {
      return;
    }
    const protocol::CommandError code = reply.error;
    waiting_ = false;
    if (code == protocol::CommandError::kBusy) {
      ++busy_;  // asked again by the next NextRequest()
    } else if (code == protocol::CommandError::kNoSnapshot) {
      Restart("the device's snapshot was replaced (an upload or a teach)");
    } else if (code == protocol::CommandError::kBadTarget) {
      error_ = target_ == protocol::UploadTarget::kLut ? "the device has no colour table in use"
               : target_ == protocol::UploadTarget::kClassifier
                   ? "the device has no ball classifier in use"
                   : "the device has no calibration in use";
    } else {
      error_ = "the device refused the read (error " + std::to_string(static_cast<int>(code)) + ")";
    }
    return;
  }
  if (frame.type != protocol::MsgType::kBlobData) return;
  protocol::BlobData d;
  if (!protocol::ParseBlobData(frame.payload, d).ok() || d.cmd_seq != outstanding_seq_) return;
  waiting_ = false;
  if (d.target != static_cast<uint8_t>(target_) || d.offset != blob_.size()) {
    error_ = "the device answered another read (target or offset differs)";
    return;
  }
  if (d.offset == 0) {
    total_ = d.total_len;
    crc_ = d.blob_crc32;
  } else if (d.total_len != total_ || d.blob_crc32 != crc_) {
    Restart("the device's snapshot changed during the read");
    return;
  }
  blob_.insert(blob_.end(), d.data.begin(), d.data.end());
  if (blob_.size() == total_) Finish();
}

}  // namespace bv::cli
