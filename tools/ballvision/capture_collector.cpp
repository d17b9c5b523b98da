#include "tools/ballvision/capture_collector.h"

#include <algorithm>
#include <cstdio>
#include <cstring>

#include "core/common/image.h"
#include "core/protocol/scan_capture.h"
#include "tools/ballvision/run_common.h"

namespace bv::tools {

bool CaptureCollector::Break(const std::string& why, std::string& message) {
  message = "pair " + std::to_string(pair_.frame.pair_index) + " of capture " +
            std::to_string(pair_.frame.capture_id) + " incomplete: " + why;
  in_pair_ = false;
  ++pairs_broken_;
  return true;
}

// The first chunk of a scanline stream carries the stream's sample count: the image's size,
// which with the other camera's must make up the frame's image_bytes.
bool CaptureCollector::SizeScanStream(const protocol::CaptureChunk& c, std::string& message) {
  uint32_t samples = 0, crc = 0;
  if (c.offset != 0 || !protocol::ParseScanStreamHeader(c.data, samples, crc)) {
    Break("the scanline stream of camera " + std::to_string(c.camera) +
              " does not start with its header (packets lost)",
          message);
    return false;
  }
  const uint32_t bytes = protocol::ScanStreamBytes(samples);
  const uint32_t other = expected_[1 - c.camera] == kUnknownSize ? 0 : expected_[1 - c.camera];
  const bool other_open = expected_[1 - c.camera] == kUnknownSize;
  const uint32_t total = pair_.frame.image_bytes;
  if (uint64_t{bytes} + other > total || (!other_open && uint64_t{bytes} + other != total)) {
    Break("camera " + std::to_string(c.camera) + "'s scanline stream (" + std::to_string(samples) +
              " samples) does not fit the pair's " + std::to_string(total) + " bytes",
          message);
    return false;
  }
  expected_[c.camera] = bytes;
  pair_.image[c.camera].assign(bytes, 0);
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
      const bool scan = f.mode == protocol::CaptureMode::kScanlines;
      for (int c = 0; c < 2; ++c) {
        received_[c] = 0;
        const bool has = (f.cameras & (1u << c)) != 0;
        // A scanline stream's size is in its own header (its first chunk).
        expected_[c] = has ? (scan ? kUnknownSize : f.image_bytes) : 0;
        pair_.image[c].assign(has && !scan ? f.image_bytes : 0, 0);
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
      if (expected_[c.camera] == kUnknownSize && !SizeScanStream(c, message)) {
        return Event::kBadPacket;
      }
      if (c.offset != received_[c.camera] || c.data.size() > expected_[c.camera] - c.offset) {
        Break("chunk at byte " + std::to_string(c.offset) + " of camera " +
                  std::to_string(c.camera) + ", expected " + std::to_string(received_[c.camera]) +
                  " (packets lost)",
              message);
        return Event::kBadPacket;
      }
      std::memcpy(pair_.image[c.camera].data() + c.offset, c.data.data(), c.data.size());
      received_[c.camera] += static_cast<uint32_t>(c.data.size());
      for (int k = 0; k < 2; ++k) {
        if (expected_[k] == kUnknownSize || received_[k] != expected_[k]) return Event::kNone;
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
  const size_t total = pair_.frame.mode == protocol::CaptureMode::kScanlines
                           ? pair_.frame.image_bytes
                           : pair_.image[0].size() + pair_.image[1].size();
  return Break("the stream ended after " + std::to_string(received_[0] + received_[1]) + " of " +
                   std::to_string(total) + " bytes",
               message);
}

bool ScanTables::Build(const RigCalibration& cal, std::string& error) {
  calibration = cal;
  cli::FillBuiltInLut(lut);
  const Status st = pipeline.Init(calibration, lut, PipelineConfig());
  if (!st.ok()) error = std::string("cannot build the scan tables: ") + st.message();
  return st.ok();
}

bool ScanStreamToImage(const std::vector<uint8_t>& stream, const ScanlineTableBase& table,
                       const char* camera, std::vector<uint8_t>& image, std::string& error) {
  uint32_t samples = 0, crc = 0;
  if (!protocol::ParseScanStreamHeader(stream, samples, crc) ||
      stream.size() != protocol::ScanStreamBytes(samples)) {
    error = std::string(camera) + " scanline stream: header and length disagree";
    return false;
  }
  if (samples != table.pixel_count()) {
    error = std::string(camera) + ": the device sent " + std::to_string(samples) +
            " scanline samples, the table built from the calibration has " +
            std::to_string(table.pixel_count()) +
            " (not the calibration the device uses, or another firmware's scan pattern)";
    return false;
  }
  const uint32_t host_crc = protocol::ScanPositionsCrc(table);
  if (crc != host_crc) {
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "%s: the device's %u scanline samples lie elsewhere than the calibration's "
                  "table puts them (positions CRC 0x%08x, host 0x%08x): not the calibration "
                  "the device uses",
                  camera, samples, crc, host_crc);
    error = buf;
    return false;
  }
  image.assign(kFrameBytes, 0);
  for (size_t i = 0; i < kFrameBytes; i += 2) {
    image[i] = kScanFillY;
    image[i + 1] = kScanFillChroma;
  }
  const uint8_t* p = stream.data() + protocol::kScanStreamHeaderBytes;
  ForEachScanPixel(table, [&](int u, int v) {
    uint8_t* pair = image.data() + (static_cast<size_t>(v) * kFrameWidth + (u & ~1)) * 2;
    pair[(u & 1) * 2] = p[0];
    pair[1] = p[1];
    pair[3] = p[2];
    p += protocol::kScanSampleBytes;
  });
  return true;
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
