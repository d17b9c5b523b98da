#pragma once
// Captured sequences on disk (DESIGN.md §4): frames.csv (index,t_us,omni_file,persp_file) plus
// PNG (converted to YUYV with BT.601 full range) or raw .yuyv images. Host only: may allocate.
#include <cstdint>
#include <string>
#include <vector>

#include "core/common/status.h"
#include "hal/camera.h"
#include "hal/common/frames_csv.h"

namespace bv::host {

struct SequenceEntry {
  int64_t index = 0;
  uint64_t t_us = 0;
  std::string omni_path;  // absolute or relative to the cwd; empty when that camera has no frame
  std::string persp_path;
};

struct Sequence {
  std::string dir;
  std::vector<SequenceEntry> entries;
};

/// Splits one CSV line at commas (no quoting: none of our files need it); a trailing '\r' is
/// dropped, empty fields are kept ("a,,b," gives 4 fields).
std::vector<std::string> SplitCsvLine(const std::string& line);

/// Reads and validates DIR/frames.csv. On error returns false and sets `error` to a message
/// naming the file, the line and what was wrong (bad header, missing column, non-numeric or
/// decreasing t_us, duplicate index, missing image file).
bool LoadSequence(const std::string& dir, Sequence& out, std::string& error);

/// The parser behind LoadSequence, for text already in memory (and the fuzzer). With
/// `check_files` false, image names are not checked against the file system.
bool ParseSequenceIndex(const std::string& text, const std::string& dir, bool check_files,
                        Sequence& out, std::string& error);

/// Decodes PNG bytes (any bit depth / colour type libpng reads) to YUYV; `name` is used in
/// error messages. Refuses images larger than 8192 x 8192.
bool DecodePngToYuyv(const std::string& name, const uint8_t* data, size_t size,
                     std::vector<uint8_t>& out, int& width, int& height, std::string& error);

/// Decodes PNG bytes to 8-bit RGB (3 bytes per pixel, any size up to 8192 x 8192).
bool DecodePngToRgb(const std::string& name, const uint8_t* data, size_t size,
                    std::vector<uint8_t>& rgb, int& width, int& height, std::string& error);

/// Loads one image as YUYV (2 bytes per pixel). PNG (8-bit gray/RGB/RGBA, any size) is
/// converted with BT.601 full range, chroma averaged over horizontal pairs; .yuyv must be
/// expected_width x expected_height x 2 bytes exactly. Errors name the file and the problem.
bool LoadYuyv(const std::string& path, std::vector<uint8_t>& out, int& width, int& height,
              std::string& error, int expected_width = 640, int expected_height = 480);

/// Encodes 8-bit RGB (or BGR) pixels, 3 bytes each, rows packed, as PNG bytes (libpng).
bool EncodePng(const uint8_t* pixels, int width, int height, bool bgr, std::vector<uint8_t>& png,
               std::string& error);

/// Writes a YUYV image as a raw .yuyv file, or as an RGB PNG when the path ends in .png.
bool SaveYuyv(const std::string& path, const uint8_t* yuyv, int width, int height,
              std::string& error);

/// BT.601 full-range conversions used by the loader (and by tests that draw frames).
void RgbToYuyv(const uint8_t* rgb, int width, int height, uint8_t* yuyv);
void YuyvToRgb(const uint8_t* yuyv, int width, int height, uint8_t* rgb);

/// A Camera that replays a sequence: one pair per frames.csv row, in file order. A row with
/// one file empty is served with that camera flagged missing; an unreadable image is served
/// as missing too and counted in load_errors() (with the message in last_error()).
class SequenceCamera : public hal::Camera {
 public:
  explicit SequenceCamera(Sequence sequence) : seq_(std::move(sequence)) {}
  size_t position() const { return next_; }
  size_t size() const { return seq_.entries.size(); }
  const SequenceEntry* current() const { return cur_; }
  uint32_t load_errors() const { return load_errors_; }
  const std::string& last_error() const { return last_error_; }

 private:
  Status DoStart() override;
  Status DoAcquirePair(hal::FramePair& out) override;
  void DoRelease(const hal::FramePair& pair) override;
  bool DoFinished() const override { return next_ >= seq_.entries.size(); }

  Sequence seq_;
  size_t next_ = 0;
  const SequenceEntry* cur_ = nullptr;
  std::vector<uint8_t> buf_[hal::kCameraCount];
  uint64_t last_t_us_ = 0;
  uint32_t load_errors_ = 0;
  std::string last_error_;
};

}  // namespace bv::host
