#pragma once
// Camera models of the rig, in the robot frame (+x right, +y forward, +z up, metres, origin on
// the floor under the robot centre). Device side: allocation-free, fixed size.
// Owner: calibration stage (issue 4). Other stages rely on the names below; extend, don't rename.
#include <cstddef>
#include <cstdint>
#include <span>

#include <Eigen/Core>

#include "core/common/status.h"
#include "core/field/field_config.h"

namespace bv {

/// A viewing ray in the robot frame; dir is unit length.
struct Ray {
  Eigen::Vector3f origin = Eigen::Vector3f::Zero();
  Eigen::Vector3f dir = Eigen::Vector3f::UnitY();
};

/// Pinhole + 2 radial terms (+ optional skew), Zhang's model; pixel (0,0) = top-left pixel centre.
struct PerspCalibration {
  bool valid = false;
  int width_px = 640, height_px = 480;
  float fx = 0, fy = 0, cx = 0, cy = 0, skew = 0, k1 = 0, k2 = 0;
  float rms_px = 0;
  // Camera pose: p_robot = R_robot_cam * p_cam + t_robot_cam (camera: x right, y down, z forward).
  Eigen::Matrix3f R_robot_cam = Eigen::Matrix3f::Identity();
  Eigen::Vector3f t_robot_cam = Eigen::Vector3f::Zero();
};

/// What of the omni image is the robot itself (body, mirror holder, struts, rim): learned by
/// `calibrate omni` from the turning run, where it is what does not move with the world.
/// Angles are image angles atan2(v - center_v, u - center_u) in degrees, v down, [0, 360).
struct OmniSelfMask {
  static constexpr int kMaxSectors = 8;
  static constexpr int kOutlineDirections = 64;
  /// Masked sectors together may cover at most this much of the circle.
  static constexpr float kMaxMaskedDeg = 120.0f;
  struct Sector {
    float angle_deg = 0;       // centre
    float half_width_deg = 0;  // (0, 45]
  };
  bool known = false;         // false: none learned (the reference rig's geometry stands in)
  float inner_radius_px = 0;  // the body ends here in every direction: no scan inside
  float outer_radius_px = 0;  // the mirror's usable circle
  int sector_count = 0;
  Sector sectors[kMaxSectors];
  uint8_t body_px[kOutlineDirections] = {};  // body outline: radius in direction i * 360 / 64 deg
};

/// kInvalidArgument naming what is wrong: radii out of order, a sector out of range, more than
/// kMaxSectors, sectors covering more than kMaxMaskedDeg; an unknown mask must be all zero.
Status ValidateSelfMask(const OmniSelfMask& m);

/// The paper's model-free omni calibration: image centre + per-direction piecewise-linear map
/// from image distance (px) to ground distance (m), 45 sectors x 12 support vectors.
struct OmniCalibration {
  static constexpr int kDirections = 45;
  static constexpr int kEdges = 12;
  bool valid = false;
  float center_u = 0, center_v = 0;
  float viewpoint_z_m = 0;  // f_O, mirror viewpoint height (rig constant)
  // Image direction of sector s covers angle [s*8°, (s+1)*8°) measured in the image; the
  // convention between image angle and robot bearing is documented in calibration.cpp.
  float edge_ground_m[kEdges] = {};  // ground distances of the support vectors
  // Derived, never serialised: atan(edge_ground_m[k] / viewpoint_z_m), so that the maps take no
  // arc tangent per pixel (~2 % of a frame pair on the M7). PrepareOmniAngles sets them (the blob
  // and JSON readers call it); while 0 the maps compute them. Prepare again after changing the
  // edges or the viewpoint.
  float edge_psi_rad[kEdges] = {};
  float support_px[kDirections][kEdges] = {};  // image radius of each support vector
  uint8_t sector_flags[kDirections] = {};      // bit 0: interpolated (occluded sector)
  // Image angle phi = atan2(v - center_v, u - center_u) (v down) relates to the robot azimuth
  // theta (CCW from +x) by phi = image_angle_sign * theta + image_angle_offset_rad (found by the
  // calibration from the known carpet bearing; the reference rig's image is mirror-reversed).
  int8_t image_angle_sign = 1;  // +1 or -1
  float image_angle_offset_rad = 0;
  // A tilted mirror turns the image angle of a direction by a small periodic amount (about 7 mrad
  // on the reference rig's 1 degree tilt), which one offset cannot hold: the image angle is
  // phi = sign * theta + offset + h(phi), h(phi) = a1 cos phi + b1 sin phi + a2 cos 2phi +
  // b2 sin 2phi, fitted by the calibration from the carpet's centre line in every direction.
  // All zero in blobs before version 3.
  float azimuth_harmonics_rad[4] = {};  // a1, b1, a2, b2; each within +-0.1 rad
  OmniSelfMask self_mask;               // unknown in blobs before version 4
};

/// Fills OmniCalibration::edge_psi_rad from the edges and the viewpoint height.
void PrepareOmniAngles(OmniCalibration& cal);
/// h(phi) of OmniCalibration::azimuth_harmonics_rad.
float OmniAzimuthCorrection(const OmniCalibration& cal, float phi);

/// Sector flag bits.
inline constexpr uint8_t kOmniSectorInterpolated = 1u << 0;

struct RigCalibration {
  uint32_t calibration_id = 0;  // changes with every calibration written; reported in status
  uint32_t lut_id = 0;          // CRC of the colour LUT this calibration was made with
  float ball_radius_m = 0.11f;
  PerspCalibration persp;
  OmniCalibration omni;
  FieldConfig field;  // the venue (MSL defaults; blob version 1 has none)
};

// --- perspective camera ---
/// Pixel -> unit viewing ray in the robot frame (fixed-iteration inverse distortion).
/// Errors: kFailedPrecondition (not valid), kInvalidArgument (NaN), kOutOfRange (no convergence).
Result<Ray> PerspPixelToRay(const PerspCalibration& cal, float u_px, float v_px);
/// Robot-frame point -> pixel. kOutOfRange if the point is behind the camera.
Status PerspProject(const PerspCalibration& cal, const Eigen::Vector3f& p_robot, float& u_px,
                    float& v_px);

// --- omni camera ---
/// Image point -> ground point (z = 0) in the robot frame. kOutOfRange beyond the calibrated map.
Status OmniPixelToGround(const OmniCalibration& cal, float u_px, float v_px, float& x_m,
                         float& y_m);
/// The terms of OmniPixelToGround that depend only on the direction from the image centre, for a
/// direction walked radius by radius (the feature rays): no arc tangent, sine or cosine per pixel.
struct OmniGroundDirection {
  int16_t sector = -1;           // support vectors of sector and sector + 1 (-1: not prepared)
  float blend = 0;               // weight of the second
  float last_px = 0;             // the blended last support vector
  float quad_a = 0, quad_b = 0;  // psi = a r + b r^2 inside the first vector, when quadratic
  bool quadratic = false;
  float cos_bearing = 1, sin_bearing = 0;  // the robot-frame bearing of the ground points
  float step_px = 1;                       // image radius per unit step
};
/// Prepares the pixels centre + t (du, dv), t >= 0. Errors: kFailedPrecondition (calibration not
/// valid), kInvalidArgument (direction not finite, or zero).
Status OmniPrepareGroundDirection(const OmniCalibration& cal, float du, float dv,
                                  OmniGroundDirection& out);
/// OmniPixelToGround of the pixel centre + t (du, dv) of a prepared direction: the same map, up
/// to float rounding of the pixel's position. Errors: kFailedPrecondition (not prepared),
/// kInvalidArgument (t not finite or negative), kOutOfRange (beyond the calibrated map).
Status OmniStepToGround(const OmniCalibration& cal, const OmniGroundDirection& dir, float t,
                        float& x_m, float& y_m);
/// Ground point -> image point (inverse of the above). kOutOfRange outside the calibrated range.
Status OmniGroundToPixel(const OmniCalibration& cal, float x_m, float y_m, float& u_px,
                         float& v_px);
/// Viewing ray from the mirror viewpoint (0, 0, f_O) through the ground point of the pixel.
Result<Ray> OmniPixelToRay(const OmniCalibration& cal, float u_px, float v_px);
/// The viewing ray of any pixel the mirror maps: OmniPixelToRay within the distance map; beyond it
/// (a raised ball far away, up to ~10 degrees above the horizon) the elevation continued by a
/// central-catadioptric fit r = k sin(a) / (xi + cos(a)) to the map's support vectors within 20
/// degrees of the horizon in that direction. kOutOfRange further out.
Result<Ray> OmniPixelToRayExtended(const OmniCalibration& cal, float u_px, float v_px);
/// Robot-frame 3D point -> image point: the ground point where the viewpoint ray through the
/// point meets the floor, projected. kOutOfRange if the point is at or above the viewpoint.
Status OmniProject(const OmniCalibration& cal, const Eigen::Vector3f& p_robot, float& u_px,
                   float& v_px);

// --- the device blob (BlobKind::kCalibration, see core/common/blob.h) ---
// Version 2 added the field section, version 3 the omni azimuth harmonics, version 4 the omni
// self-mask; older blobs still load (the MSL field, no harmonics, no self-mask).
inline constexpr uint16_t kCalibrationBlobVersion = 4;
/// Upper bound of a serialised calibration blob, header included.
inline constexpr size_t kCalibrationBlobMaxBytes = 4096;
Result<size_t> SerializeCalibration(const RigCalibration& cal, std::span<uint8_t> out);
/// Validates everything (CRC, version, finite values, sane ranges) before touching `out`.
Status ParseCalibration(std::span<const uint8_t> blob, RigCalibration& out);

}  // namespace bv
