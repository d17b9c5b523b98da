#pragma once
// The ball-state CSV of DESIGN.md §4, written by `run` and `listen` with one formatter so their
// outputs compare byte for byte. Column names are a contract: keep them stable.
#include <cstdint>
#include <string>

#include "core/common/ball_state.h"

namespace bv::cli {

/// index,t_us,found,x,y,z,vx,vy,vz,mode,omni_u,omni_v,persp_u,persp_v,ray_gap,t_bounce_us,proc_us
/// (+ px,py,pz with `predict`), sigma_x.. (+ psigma_x..), check_omni,check_persp (CameraState),
/// check_omni_deg,check_persp_deg (the estimated change, 2 decimals).
std::string StatesCsvHeader(bool predict);
/// One row. Positions in metres with 5 decimals, pixels with 3; image centres empty when that
/// camera did not see the ball; t_bounce_us empty when no bounce is predicted. `with_proc`
/// false leaves proc_us empty (it is a wall-clock figure that differs between platforms).
std::string StatesCsvRow(int64_t index, const BallState& s, bool predict, bool with_proc = true);

/// The robot's field pose columns (DESIGN.md §4) appended to a row or header by `run` and
/// `listen`: ",pose_x,pose_y,pose_heading_deg"; values empty while the pose is unknown.
inline constexpr const char* kStatesPoseHeader = ",pose_x,pose_y,pose_heading_deg";
std::string StatesCsvPose(bool known, float x_m, float y_m, float heading_rad);

/// A camera's check as people read it: "as calibrated", "unusable (repeated, dark)".
std::string CameraCheckText(const CameraCheck& check);
/// The same from the packet byte (CameraCheck::Byte()).
std::string CameraCheckText(uint8_t byte);

}  // namespace bv::cli
