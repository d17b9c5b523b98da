#pragma once
// Pairs the two cameras' frames by exposure timestamp. Board-independent logic shared by every
// camera implementation: the capture ISR / file reader reports completed frames, the main loop
// asks for the newest pair. Pure and allocation-free so it is host-tested.
#include <cstdint>

#include "hal/camera.h"

namespace bv::hal {

struct PairerConfig {
  uint32_t sync_tolerance_us = 2000;   // |t_omni - t_persp| above this flags kPairOutOfSync
  uint32_t missing_timeout_us = 25000; // serve a lone frame once its partner is this late
};

struct PairDecision {
  bool has[kCameraCount] = {};
  uint32_t slot[kCameraCount] = {};
  uint64_t exposure_us[kCameraCount] = {};
  uint32_t sequence[kCameraCount] = {};
  uint64_t exposure_us_pair = 0;
  int64_t skew_us = 0;
  uint32_t flags = 0;
  uint32_t dropped = 0;
};

class FramePairer {
 public:
  explicit FramePairer(const PairerConfig& config = PairerConfig()) : config_(config) {}

  /// A frame of camera `id` is complete in DMA slot `slot`. A newer frame replaces an unserved
  /// older one of the same camera; the replaced one is counted as dropped.
  void OnFrameComplete(CameraId id, uint64_t exposure_us, uint32_t sequence, uint32_t slot);
  /// Decides whether a pair is ready at `now_us`; fills `out` and forgets the served frames.
  bool TakePair(uint64_t now_us, PairDecision& out);
  /// The slot a camera's DMA must not write next (the one held by an unserved frame), or -1.
  int pending_slot(CameraId id) const;

 private:
  struct Pending {
    bool present = false;
    uint64_t exposure_us = 0;
    uint32_t sequence = 0;
    uint32_t slot = 0;
  };
  PairerConfig config_;
  Pending pending_[kCameraCount];
  uint32_t dropped_ = 0;
  bool served_any_ = false;
  uint64_t last_exposure_us_ = 0;
};

}  // namespace bv::hal
