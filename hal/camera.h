#pragma once
// Two-camera capture: each camera DMAs into its own double buffer; the board pairs the newest
// complete frames by exposure timestamp. Called a few times per frame, never in pixel loops.
#include <cstddef>
#include <cstdint>

#include "core/common/status.h"

namespace bv::hal {

enum class CameraId : uint8_t { kOmni = 0, kPersp = 1 };
inline constexpr int kCameraCount = 2;

struct Frame {
  const uint8_t* data = nullptr;  // YUYV, kFrameBytes long when present
  size_t size_bytes = 0;
  uint64_t exposure_us = 0;  // start of exposure, board clock
  uint32_t sequence = 0;     // per-camera frame counter from the capture hardware / file index
  bool present = false;
  uint32_t stride_bytes = 0;  // bytes per row; 0 = packed (2 * width). See hal/stm32h7/README.md
};

/// Flags of a pair; a pair may be served with one camera missing so the pipeline can fall back.
enum PairFlags : uint32_t {
  kPairOmniMissing = 1u << 0,
  kPairPerspMissing = 1u << 1,
  kPairOutOfSync = 1u << 2,   // both present but exposure times differ by more than the tolerance
  kPairTorn = 1u << 3,        // the DMA overwrote a slot while it was being handed out
  kPairOutOfOrder = 1u << 4,  // exposure time not after the previous pair's
};

struct FramePair {
  Frame omni;
  Frame persp;
  uint64_t exposure_us = 0;  // the pair's timestamp: the mean of the present frames' exposures
  int64_t skew_us = 0;       // persp - omni exposure when both present
  uint32_t flags = 0;
  uint32_t dropped = 0;  // complete frames overwritten before they were acquired, since last pair
  uint32_t slot = 0;     // board-private, returned in Release()
};

class Camera {
 public:
  virtual ~Camera() = default;
  /// Starts capture. Errors: kUnavailable (no camera at all), kInvalidArgument (bad config).
  Status Start() { return DoStart(); }
  /// Hands out the newest complete pair not handed out before. kUnavailable when there is none
  /// yet (the caller polls; it never blocks). The frames stay valid until Release().
  Status AcquirePair(FramePair& out) { return DoAcquirePair(out); }
  void Release(const FramePair& pair) { DoRelease(pair); }
  /// True once the source has no more frames (captured sequences); live cameras never end.
  bool Finished() const { return DoFinished(); }
  /// Pairs that may be held (acquired, not yet released) at once. 2 lets the loop keep one
  /// pair for a capture over the link while it goes on with the next ones.
  int MaxHeldPairs() const { return DoMaxHeldPairs(); }
  /// Input the camera refused since start (malformed rows, unreadable frames, DMA errors); the
  /// main loop reports a non-zero count as a fault in its status packet.
  uint32_t BadInputCount() const { return DoBadInputCount(); }

 private:
  virtual Status DoStart() = 0;
  virtual Status DoAcquirePair(FramePair& out) = 0;
  virtual void DoRelease(const FramePair& pair) = 0;
  virtual bool DoFinished() const { return false; }
  virtual int DoMaxHeldPairs() const { return 1; }
  virtual uint32_t DoBadInputCount() const { return 0; }
};

}  // namespace bv::hal
