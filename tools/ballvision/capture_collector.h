#pragma once
// Host side of a capture over the link: reassembles captured pairs from capture frame / chunk /
// end packets (core/protocol/link.h). A pair is complete only when every byte of its images
// arrived in order; a gap (lost or corrupt packets) or a stream that stops inside a pair
// breaks that pair only, and says so.
#include <cstdint>
#include <string>
#include <vector>

#include "core/calibration/calibration.h"
#include "core/color_lut/color_lut.h"
#include "core/pipeline.h"
#include "core/protocol/link.h"
#include "core/protocol/protocol.h"
#include "core/scanline/scanline.h"

namespace bv::tools {

struct CapturedPair {
  protocol::CaptureFrame frame;
  std::vector<uint8_t> image[2];  // omni, persp as sent (decimated in half / quarter mode;
                                  // scanlines: the stream of core/protocol/scan_capture.h)
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
  static constexpr uint32_t kUnknownSize = UINT32_MAX;
  bool Break(const std::string& why, std::string& message);
  bool SizeScanStream(const protocol::CaptureChunk& c, std::string& message);

  CapturedPair pair_;
  bool in_pair_ = false;
  uint32_t received_[2] = {0, 0};
  uint32_t expected_[2] = {0, 0};  // bytes of each camera's image (kUnknownSize: not yet known)
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

/// The fill of the pixels a scanline capture did not send: mid grey with no chroma, which
/// the colour tables classify as nothing (kUnknown: not ball, field, line or obstacle).
inline constexpr uint8_t kScanFillY = 128;
inline constexpr uint8_t kScanFillChroma = 128;

/// A 640x480 YUYV image from one camera's scanline stream: each sample's Y at its pixel and its
/// U, V in its pixel pair, every other byte fill. False (`error` says why, naming both counts)
/// when the stream's sample count or positions differ from `table`'s, the table the host built
/// from the calibration file.
/// The scan tables the device builds for a calibration: its Pipeline::Init with the default
/// PipelineConfig (what firmware/main_loop runs; the colour table does not enter the tables),
/// on the host. Keeps the calibration and the table the pipeline points to.
struct ScanTables {
  RigCalibration calibration;
  ColorLut lut;
  OwnedPipeline pipeline;
  /// False (`error` says why) when the pipeline cannot be built from `cal`.
  bool Build(const RigCalibration& cal, std::string& error);
  const ScanlineTableBase& table(int camera) const {
    return camera == 0 ? pipeline.omni_scan() : pipeline.persp_scan();
  }
};

bool ScanStreamToImage(const std::vector<uint8_t>& stream, const ScanlineTableBase& table,
                       const char* camera, std::vector<uint8_t>& image, std::string& error);

}  // namespace bv::tools
