#pragma once
// Read-only view of a YUV 4:2:2 (YUYV: Y0 U Y1 V) frame as the camera DMA delivers it.
#include <cstddef>
#include <cstdint>

namespace bv {

inline constexpr int kFrameWidth = 640;
inline constexpr int kFrameHeight = 480;
inline constexpr size_t kYuyvBytesPerPixel = 2;
inline constexpr size_t kFrameBytes = kFrameWidth * kFrameHeight * kYuyvBytesPerPixel;
// The largest frame the front end takes (scan tables, contours, checks): a sensor of up to
// 1280 x 1024 (720p, SXGA, the 608 x 800 portrait cameras of the MSL dataset). The boards' DMA
// slots hold the reference rig's kFrameWidth x kFrameHeight.
inline constexpr int kMaxFrameWidth = 1280;
inline constexpr int kMaxFrameHeight = 1024;

struct Yuv {
  uint8_t y, u, v;
};

struct YuyvImage {
  const uint8_t* data = nullptr;
  int width = 0;
  int height = 0;
  int stride_bytes = 0;  // bytes per row, >= 2 * width

  constexpr bool valid() const { return data != nullptr && width > 0 && height > 0; }
  constexpr bool contains(int u, int v) const { return u >= 0 && v >= 0 && u < width && v < height; }
  // Pixel (u, v): Y of that pixel plus the U, V shared with its horizontal neighbour.
  Yuv at(int u, int v) const {
    const uint8_t* row = data + static_cast<ptrdiff_t>(v) * stride_bytes;
    const uint8_t* pair = row + (u & ~1) * 2;
    return Yuv{pair[(u & 1) * 2], pair[1], pair[3]};
  }
};

inline constexpr YuyvImage MakeYuyvImage(const uint8_t* data, int width, int height) {
  return YuyvImage{data, width, height, width * 2};
}

}  // namespace bv
