#include "core/common/ball_state.h"

namespace bv {

const char* BallModeName(BallMode mode) {
  switch (mode) {
    case BallMode::kNone:
      return "none";
    case BallMode::kRolling:
      return "rolling";
    case BallMode::kFlying:
      return "flying";
    case BallMode::kBouncing:
      return "bouncing";
  }
  return "none";
}

const char* CameraStateName(CameraState state) {
  switch (state) {
    case CameraState::kAsCalibrated:
      return "as calibrated";
    case CameraState::kCorrected:
      return "changed, corrected";
    case CameraState::kChanged:
      return "changed, not corrected";
    case CameraState::kUnusable:
      return "unusable";
  }
  return "?";
}

}  // namespace bv
