#pragma once
// The records that flow between pipeline stages and out over the serial link. Units in names:
// metres (_m), metres per second (_mps), microseconds (_us), pixels (_px).
#include <cstdint>

namespace bv {

/// One camera's ball candidate after ball choice (at most one per image).
struct BallDetection {
  bool found = false;
  float u_px = 0, v_px = 0;  // sub-pixel centroid, (0,0) = centre of the top-left pixel
  float area_px = 0;
  float radius_px = 0;   // equivalent-circle radius sqrt(area / pi)
  float roundness = 0;   // 4*pi*area / hull perimeter^2 (1 = disc), core/contour
  float confidence = 0;  // 0..1
  // 0: u, v and radius are the region's; else a circle fitted to its outline, on this many of 16
  // sectors (core/contour: a ball merged with something behind it, or partly hidden)
  uint8_t arc_sectors = 0;
  // > 0: the ball's angular radius from the camera's model (a cut ball's outline fitted as the
  // cone of rays tangent to a sphere, core/pipeline); 0: from radius_px.
  float angular_radius_rad = 0;
};

enum class BallMode : uint8_t { kNone = 0, kRolling = 1, kFlying = 2, kBouncing = 3 };

const char* BallModeName(BallMode mode);

/// Quality / provenance flags of a ball state (bit set; also sent in packets).
enum BallFlags : uint16_t {
  kFlagSeenOmni = 1u << 0,
  kFlagSeenPersp = 1u << 1,
  kFlagTriangulated = 1u << 2,        // both rays used
  kFlagOmniGroundFallback = 1u << 3,  // only the omni ray went to the filter (name kept)
  kFlagPerspSizeFallback = 1u << 4,   // only the persp ray (+ its size) went to the filter
  kFlagCoasting = 1u << 5,            // no measurement: prediction only
  kFlagLost = 1u << 6,                // coasted too long; position invalid
  kFlagRaysParallel = 1u << 7,        // rays nearly parallel, triangulation refused
  kFlagOutlierRejected = 1u << 8,     // measurement rejected by the filter
  kFlagOutOfField = 1u << 9,          // measurement far outside the field, rejected
  kFlagBadTimestamp = 1u << 10,       // frame time not after the previous one; measurement ignored
  kFlagHasBounce = 1u << 11,          // t_bounce_us / bounce_x_m / bounce_y_m valid
  kFlagHasPrediction = 1u << 12,      // px/py/pz valid
  kFlagUnobservable = 1u << 13,  // one camera and too little motion: range along the ray unknown
  // px/py/pz's own 1-sigma exceeds BallFilterConfig::unobservable_sigma_m (a kick's first frames:
  // the speed along the rays not yet determined); still the best estimate.
  kFlagPredictionUncertain = 1u << 14,
};

/// How far a camera's data can be trusted (issue 40's states.csv codes and packet byte).
enum class CameraState : uint8_t {
  kAsCalibrated = 0,
  kCorrected = 1,  // changed, and the pipeline uses a corrected model
  kChanged = 2,    // changed, not corrected: down-weighted
  kUnusable = 3,   // frozen, blind, missing or beyond correction: its data is not used
};
const char* CameraStateName(CameraState state);

/// Why a camera's frames were refused (bit set; core/health).
enum CameraFault : uint8_t {
  kCameraRepeated = 1u << 0,   // the same frame again
  kCameraStaleTime = 1u << 1,  // its own exposure time did not advance
  kCameraDark = 1u << 2,       // the scan table's pixels mostly black
  kCameraSaturated = 1u << 3,  // mostly saturated
  kCameraFlat = 1u << 4,       // one flat grey (a covered lens, a test pattern, a zeroed buffer)
  kCameraMissing = 1u << 5,    // no frame delivered
};
inline constexpr uint8_t kCameraFaultBits = 6;

struct CameraCheck {
  CameraState state = CameraState::kAsCalibrated;
  uint8_t faults = 0;    // CameraFault: this frame's, also before they last long enough to flag
  float change_deg = 0;  // estimated change of the camera's pose since calibration (degrees)
  float confidence = 0;  // 0..1: how much of the evidence agrees with change_deg
  // Packet byte: state in bits 0-1, faults in bits 2-7.
  uint8_t Byte() const { return static_cast<uint8_t>(static_cast<uint8_t>(state) | faults << 2); }
};

struct BallState {
  uint64_t t_us = 0;   // exposure time of the frame pair
  bool found = false;  // position valid (measured or coasting within bounds)
  float x_m = 0, y_m = 0, z_m = 0;
  float vx_mps = 0, vy_mps = 0, vz_mps = 0;
  float sigma_x_m = 0, sigma_y_m = 0, sigma_z_m = 0;  // 1-sigma position uncertainty (found)
  BallMode mode = BallMode::kNone;
  uint16_t flags = 0;
  float ray_gap_m = -1;  // closest-approach distance of the two rays; < 0 when not triangulated
  BallDetection omni;
  BallDetection persp;
  uint64_t t_bounce_us = 0;  // next predicted floor contact (kFlagHasBounce)
  float bounce_x_m = 0, bounce_y_m = 0;
  uint32_t predict_ahead_us = 0;  // horizon of px/py/pz (kFlagHasPrediction)
  float px_m = 0, py_m = 0, pz_m = 0;
  float psigma_x_m = 0, psigma_y_m = 0, psigma_z_m = 0;  // 1-sigma of px/py/pz
  uint32_t proc_us = 0;                                  // pipeline time for this pair
  CameraCheck omni_check, persp_check;  // kUnusable: that camera's frame was not used
};

}  // namespace bv
