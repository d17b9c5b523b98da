#include "tools/ballvision/capture_collector.h"

#include <algorithm>
#include <cstring>

#include "core/common/image.h"

namespace bv::tools {

bool CaptureCollector::Break(const std::string& why, std::string& message) {
  message = "pair " + std::to_string(pair_.frame.pair_index) + " of capture " +
            std::to_string(pair_.frame.capture_id) + " incomplete: " + why;
  in_pair_ = false;
  ++pairs_broken_;
  return true;
}

CaptureCollector::Event CaptureCollector::Feed(const protocol::FrameView& frame,
                                               std::string& message) {
  message.clear();
  switch (frame.type) {
    case protocol::MsgType::kCaptureFrame: {
      protocol::CaptureFrame f;
      const Status s = protocol::ParseCaptureFrame(frame.payload, f);
      if (!s.ok()) {
        message = s.message();
        return Event::kBadPacket;
      }
      Event e = Event::kNone;
      if (in_pair_) {
        Break(
            "the next pair started after " + std::to_string(received_[0] + received_[1]) + " bytes",
            message);
        e = Event::kBadPacket;
      }
      if (!seen_any_) first_ = f;
      seen_any_ = true;
      ended_ = false;
      pair_.frame = f;
      for (int c = 0; c < 2; ++c) {
        received_[c] = 0;
        const bool has = (f.cameras & (1u << c)) != 0;
        pair_.image[c].assign(has ? f.image_bytes : 0, 0);
      }
      in_pair_ = true;
      return e;
    }
    case protocol::MsgType::kCaptureChunk: {
      protocol::CaptureChunk c;
      const Status s = protocol::ParseCaptureChunk(frame.payload, c);
      if (!s.ok()) {
        message = s.message();
        if (in_pair_) Break(std::string("a chunk was refused: ") + s.message(), message);
        return Event::kBadPacket;
      }
      if (!in_pair_) {
        message = "chunk outside a pair (its capture frame packet was lost)";
        return Event::kBadPacket;
      }
      const protocol::CaptureFrame& f = pair_.frame;
      if (c.capture_id != f.capture_id || c.pair_index != f.pair_index ||
          (f.cameras & (1u << c.camera)) == 0) {
        Break("a chunk of another pair or camera arrived", message);
        return Event::kBadPacket;
      }
      if (c.offset != received_[c.camera] || c.data.size() > f.image_bytes - c.offset) {
        Break("chunk at byte " + std::to_string(c.offset) + " of camera " +
                  std::to_string(c.camera) + ", expected " + std::to_string(received_[c.camera]) +
                  " (packets lost)",
              message);
        return Event::kBadPacket;
      }
      std::memcpy(pair_.image[c.camera].data() + c.offset, c.data.data(), c.data.size());
      received_[c.camera] += static_cast<uint32_t>(c.data.size());
      for (int k = 0; k < 2; ++k) {
        if (received_[k] != pair_.image[k].size()) return Event::kNone;
      }
      in_pair_ = false;
      ++pairs_complete_;
      return Event::kPairComplete;
    }
    case protocol::MsgType::kCaptureEnd: {
      protocol::CaptureEnd e;
      const Status s = protocol::ParseCaptureEnd(frame.payload, e);
      if (!s.ok()) {
        message = s.message();
        return Event::kBadPacket;
      }
      if (in_pair_) Break("the capture ended inside it", message);
      ended_ = true;
      end_ = e;
      return Event::kEnd;
    }
    default:
      return Event::kNone;
  }
}

bool CaptureCollector::Finish(std::string& message) {
  if (!in_pair_) return false;
  return Break("the stream ended after " + std::to_string(received_[0] + received_[1]) + " of " +
                   std::to_string(pair_.image[0].size() + pair_.image[1].size()) + " bytes",
               message);
}

std::vector<uint8_t> UpsampleCapture(const std::vector<uint8_t>& image,
                                     protocol::CaptureMode mode) {
  uint16_t w = 0, h = 0;
  if (mode == protocol::CaptureMode::kFull || !protocol::CaptureSize(mode, w, h)) return image;
  const int k = kFrameWidth / w;
  std::vector<uint8_t> out(kFrameBytes);
  for (int y = 0; y < kFrameHeight; ++y) {
    const uint8_t* src = image.data() + static_cast<size_t>(y / k) * w * 2;
    uint8_t* dst = out.data() + static_cast<size_t>(y) * kFrameWidth * 2;
    for (int m = 0; m < kFrameWidth / 2; ++m) {
      // Both pixels of an output macropixel come from decimated pixel 2m/k (k is even).
      const int dx = 2 * m / k;
      dst[4 * m] = dst[4 * m + 2] = src[2 * dx];
      dst[4 * m + 1] = src[4 * (dx / 2) + 1];
      dst[4 * m + 3] = src[4 * (dx / 2) + 3];
    }
  }
  return out;
}

}  // namespace bv::tools
