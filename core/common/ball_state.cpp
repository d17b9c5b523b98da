#include "core/common/ball_state.h"

namespace bv {

const char* BallModeName(BallMode mode) {
  switch (mode) {
    case BallMode::kNone: return "none";
    case BallMode::kRolling: return "rolling";
    case BallMode::kFlying: return "flying";
    case BallMode::kBouncing: return "bouncing";
  }
  return "none";
}

}  // namespace bv
