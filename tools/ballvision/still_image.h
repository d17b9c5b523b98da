#pragma once
// Still images for `ballvision detect` and the real-image figures: JPEG or PNG, decoded strictly
// (a truncated or corrupt file is an error, not a partly grey picture) into the YUYV the device
// sees, BT.601 full range as the sequence loader converts.
#include <string>
#include <vector>

#include "tools/ballvision/lut_train.h"

namespace bv::cli {

struct Still {
  lut::Image image;  // YUYV; an odd width is padded by repeating the last column
  int width = 0;     // the file's own size
  int height = 0;
};

/// False with `error` naming the file and what was wrong: not readable, empty, neither JPEG nor
/// PNG, truncated or corrupt (libjpeg warnings count as corruption), or larger than the largest
/// frame the front end takes (kMaxFrameWidth x kMaxFrameHeight).
bool LoadStill(const std::string& path, Still& out, std::string& error);

/// The decoder behind LoadStill: 8-bit RGB, 3 bytes per pixel, with the same refusals and the
/// given size limit (the calibration pictures).
bool LoadRgb(const std::string& path, int max_width, int max_height, std::vector<uint8_t>& rgb,
             int& width, int& height, std::string& error);

/// Image files of a directory (sorted by name). False with `error` when it cannot be read or
/// holds a regular file that is neither .jpg/.jpeg/.png nor one of `ignore_suffixes` (the
/// annotations beside the images, e.g. ".txt"); sub-directories are skipped.
bool ListStills(const std::string& dir, const std::vector<std::string>& ignore_suffixes,
                std::vector<std::string>& out, std::string& error);

}  // namespace bv::cli
