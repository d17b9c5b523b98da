#include "core/health/camera_watch.h"

#include <cstring>

#include "core/scanline/scanline.h"

namespace bv {

Status CameraWatch::Build(const ScanlineTableBase& table, const CameraWatchConfig& config) {
  config_ = config;
  count_ = 0;
  stride_ = 0;
  width_ = table.width();
  height_ = table.height();
  Reset();
  if (!table.built()) return Status(StatusCode::kFailedPrecondition, "camera watch: no scan table");
  const uint32_t n = table.pixel_count();
  const uint32_t step = n > kMaxPoints ? n / kMaxPoints : 1;
  ScanlineTableBase::Cursor cursor;
  uint32_t index = 0;
  // Every step-th sample, from the middle of the first step on (the table's first rows are its
  // edge, where a vignetted image is darkest).
  uint32_t next = step / 2;
  while (count_ < kMaxPoints) {
    const size_t got = table.ReadSamples(cursor, 1, [&](int u, int v) {
      if (index == next) {
        points_[count_++] = static_cast<uint32_t>(u) | static_cast<uint32_t>(v) << 16;
        next += step;
      }
    });
    if (got == 0) break;
    ++index;
  }
  return Status();
}

void CameraWatch::Reset() {
  have_last_ = false;
  last_signature_ = 0;
  last_t_us_ = 0;
  repeats_ = blind_ = missing_ = good_ = 0;
  check_ = CameraCheck{};
}

void CameraWatch::SetStride(int stride_bytes) {
  stride_ = stride_bytes;
  for (int i = 0; i < count_; ++i) {
    const uint32_t u = points_[i] & 0xFFFFu, v = points_[i] >> 16;
    offsets_[i] = (v * static_cast<uint32_t>(stride_bytes) + (u & ~1u) * 2) << 1 | (u & 1u);
  }
}

uint8_t CameraWatch::Faults(const YuyvImage& img, uint64_t camera_t_us) {
  if (!img.valid()) return kCameraMissing;
  // Another size is the front end's to refuse (PipelineStats::frame_errors); nothing to compare.
  if (img.width != width_ || img.height != height_ || img.stride_bytes < 2 * img.width ||
      static_cast<uint64_t>(img.stride_bytes) * static_cast<uint64_t>(img.height) >= (1u << 30)) {
    return 0;  // offsets << 1 must fit 32 bits
  }
  if (img.stride_bytes != stride_) SetStride(img.stride_bytes);
  // All points requested before the first is read: a fresh frame is cold, and its misses then
  // overlap instead of queuing behind the signature's chain.
  for (int i = 0; i < count_; ++i) __builtin_prefetch(img.data + (offsets_[i] >> 1));
  uint32_t signature = 2166136261u;
  int dark = 0, saturated = 0;
  uint32_t sum = 0, sum_sq = 0;  // 64 * 255^2 fits
  for (int i = 0; i < count_; ++i) {
    uint32_t word;  // Y0 U Y1 V of the point's pixel pair, one load
    std::memcpy(&word, img.data + (offsets_[i] >> 1), sizeof word);
    signature = (signature ^ word) * 16777619u;
    const uint32_t y = word >> ((offsets_[i] & 1u) << 4) & 0xFFu;
    dark += y <= config_.dark_y;
    saturated += y >= config_.saturated_y;
    sum += y;
    sum_sq += y * y;
  }
  uint8_t faults = 0;
  if (have_last_ && signature == last_signature_) faults |= kCameraRepeated;
  if (camera_t_us != 0 && last_t_us_ != 0 && camera_t_us == last_t_us_) faults |= kCameraStaleTime;
  have_last_ = true;
  last_signature_ = signature;
  if (camera_t_us != 0) last_t_us_ = camera_t_us;
  const float n = static_cast<float>(count_);
  const float need = config_.blind_fraction * n;
  if (static_cast<float>(dark) >= need) faults |= kCameraDark;
  if (static_cast<float>(saturated) >= need) faults |= kCameraSaturated;
  if (!(faults & (kCameraDark | kCameraSaturated)) &&
      static_cast<float>(dark + saturated) >= need) {
    faults |= kCameraDark | kCameraSaturated;  // black and burnt out together: a lamp in view
  }
  const float mean = static_cast<float>(sum) / n;
  const float var = static_cast<float>(sum_sq) / n - mean * mean;
  if (var <= config_.flat_sigma_dn * config_.flat_sigma_dn) faults |= kCameraFlat;
  return faults;
}

bool CameraWatch::Observe(const YuyvImage& img, uint64_t camera_t_us) {
  if (!config_.enabled || count_ == 0) {
    check_ = CameraCheck{};
    return img.valid();
  }
  const uint8_t faults = Faults(img, camera_t_us);
  check_.faults = faults;
  repeats_ = (faults & (kCameraRepeated | kCameraStaleTime)) ? repeats_ + 1 : 0;
  blind_ = (faults & (kCameraDark | kCameraSaturated | kCameraFlat)) ? blind_ + 1 : 0;
  missing_ = (faults & kCameraMissing) ? missing_ + 1 : 0;
  good_ = faults == 0 ? good_ + 1 : 0;
  if (repeats_ >= config_.repeats_to_flag || blind_ >= config_.blind_to_flag ||
      missing_ >= config_.missing_to_flag) {
    check_.state = CameraState::kUnusable;
  } else if (check_.state == CameraState::kUnusable && good_ >= config_.good_to_clear) {
    check_.state = CameraState::kAsCalibrated;
  }
  return faults == 0 && check_.state != CameraState::kUnusable;
}

}  // namespace bv
