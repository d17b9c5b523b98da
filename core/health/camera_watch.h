#pragma once
// Frozen, blind and missing cameras (issue 40 B6): a fixed handful of the scan table's own
// pixels, read once per frame, tell a repeated frame (a signature of their bytes), a camera
// whose own exposure time stands still, and one that is mostly black, saturated or one flat
// grey. A repeated or blind frame is never used; one that lasts is flagged kUnusable.
#include <cstdint>

#include "core/common/ball_state.h"
#include "core/common/image.h"
#include "core/common/status.h"

namespace bv {

class ScanlineTableBase;

struct CameraWatchConfig {
  bool enabled = true;
  // Consecutive frames before the state is kUnusable, and good frames before it is cleared. A
  // live sensor never repeats a frame (its noise alone differs), so three repeats are a stall.
  int repeats_to_flag = 3;
  int blind_to_flag = 5;
  int missing_to_flag = 10;
  int good_to_clear = 3;
  uint8_t dark_y = 24;        // Y at or below: black
  uint8_t saturated_y = 245;  // Y at or above: saturated
  float blind_fraction = 0.9f;
  float flat_sigma_dn = 3.0f;  // Y's spread over the points at or below: one flat grey
};

class CameraWatch {
 public:
  // 64 points: 90 % blind is 58 of them, and 256 bytes tell any two live frames apart.
  static constexpr int kMaxPoints = 64;

  /// Spreads the points evenly over `table`'s samples (their order is the table's). Errors:
  /// kFailedPrecondition (the table is not built).
  Status Build(const ScanlineTableBase& table, const CameraWatchConfig& config);
  /// One frame of this camera: an invalid image counts as missing. `camera_t_us` is the
  /// camera's own exposure time (0: unknown). Returns true when the frame may be used.
  bool Observe(const YuyvImage& img, uint64_t camera_t_us);
  const CameraCheck& check() const { return check_; }
  /// Forgets the frame history (unrelated stills, a restarted stream); the points stay.
  void Reset();
  /// No points: Observe() passes every present frame (a camera without calibration).
  void Clear() {
    count_ = 0;
    Reset();
  }

 private:
  uint8_t Faults(const YuyvImage& img, uint64_t camera_t_us);
  void SetStride(int stride_bytes);

  CameraWatchConfig config_;
  uint32_t points_[kMaxPoints] = {};   // u | v << 16
  uint32_t offsets_[kMaxPoints] = {};  // the points' YUYV pair in a frame of stride_: byte offset
                                       // << 1 | 1 for the pair's second pixel
  int stride_ = 0;
  int count_ = 0;
  int width_ = 0, height_ = 0;
  bool have_last_ = false;
  uint32_t last_signature_ = 0;
  uint64_t last_t_us_ = 0;
  int repeats_ = 0, blind_ = 0, missing_ = 0, good_ = 0;
  CameraCheck check_;
};

}  // namespace bv
