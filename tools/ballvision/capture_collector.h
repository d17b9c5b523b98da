#pragma once
// Host side of a capture over the link: reassembles captured pairs from capture frame / chunk /
// end packets (core/protocol/link.h). A pair is complete only when every byte of its images
// arrived in order; a gap (lost or corrupt packets) or a stream that stops inside a pair
// breaks that pair only, and says so.
#include <cstdint>
#include <string>
#include <vector>

#include "core/protocol/link.h"
#include "core/protocol/protocol.h"

namespace bv::tools {

struct CapturedPair {
  protocol::CaptureFrame frame;
  std::vector<uint8_t> image[2];  // omni, persp as sent (decimated in half / quarter mode)
};

class CaptureCollector {
 public:
  enum class Event { kNone, kPairComplete, kEnd, kBadPacket };

  /// Feeds one verified frame of any type (others are ignored). kBadPacket: a capture packet
  /// whose payload was refused, or that does not fit the pair in progress (`message` says
  /// why; the pair in progress is then broken).
  Event Feed(const protocol::FrameView& frame, std::string& message);
  /// The stream ended: a pair in progress is broken (true, with `message`).
  bool Finish(std::string& message);

  const CapturedPair& pair() const { return pair_; }
  bool ended() const { return ended_; }
  const protocol::CaptureEnd& end() const { return end_; }
  bool seen_any() const { return seen_any_; }
  /// The first capture frame seen (mode, count) once seen_any().
  const protocol::CaptureFrame& first() const { return first_; }
  uint32_t pairs_complete() const { return pairs_complete_; }
  uint32_t pairs_broken() const { return pairs_broken_; }

 private:
  bool Break(const std::string& why, std::string& message);

  CapturedPair pair_;
  bool in_pair_ = false;
  uint32_t received_[2] = {0, 0};
  bool seen_any_ = false;
  protocol::CaptureFrame first_;
  bool ended_ = false;
  protocol::CaptureEnd end_;
  uint32_t pairs_complete_ = 0;
  uint32_t pairs_broken_ = 0;
};

/// A 640x480 YUYV image from a decimated one (nearest neighbour), so `ballvision run` can
/// replay half / quarter captures; a full-size image is returned as it is.
std::vector<uint8_t> UpsampleCapture(const std::vector<uint8_t>& image, protocol::CaptureMode mode);

}  // namespace bv::tools
