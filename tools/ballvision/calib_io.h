#pragma once
// The robot's calibration file: JSON for people, the BVB1 blob (core/common/blob.h) for the
// device. JSON layout (unknown keys are kept when a section is updated):
//   {"format": "ballvision-calibration", "version": 1, "calibration_id", "lut_id",
//    "ball_radius_m",
//    "persp": {"valid", "width_px", "height_px", "fx", "fy", "cx", "cy", "skew", "k1", "k2",
//              "rms_px", "R_robot_cam" (3x3 rows), "t_robot_cam" [x,y,z], ...report keys},
//    "omni":  {"valid", "center_u", "center_v", "viewpoint_z_m", "image_angle_sign",
//              "image_angle_offset_rad", "azimuth_harmonics_rad" [4] (optional, zeros),
//              "sector_deg", "edge_ground_m" [12],
//              "support_px" [45][12], "sector_flags" [45], ...report keys}}
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/calibration/calibration.h"

namespace bv::cli {

/// Loads a calibration from a JSON file or a device blob (detected by its "BVB1" magic).
/// Everything is validated as the device would (via SerializeCalibration/ParseCalibration).
bool LoadCalibrationFile(const std::string& path, bv::RigCalibration& out, std::string& error);

/// Writes `cal` as a JSON calibration file (whole file).
bool SaveCalibrationJson(const std::string& path, const bv::RigCalibration& cal,
                         std::string& error);

/// JSON <-> struct. FromJson validates types, ranges, format and version (messages name
/// `file`, the field, the value and what was expected); missing sections become
/// valid = false. Keys it does not know are returned in `unknown` (not an error).
nlohmann::json CalibrationToJson(const bv::RigCalibration& cal);
bool CalibrationFromJson(const nlohmann::json& j, bv::RigCalibration& out, std::string& error,
                         const std::string& file = "", std::vector<std::string>* unknown = nullptr);
nlohmann::json PerspToJson(const bv::PerspCalibration& p);
nlohmann::json OmniToJson(const bv::OmniCalibration& o);
/// One line on the self-mask for people (`calib show`, `calibrate omni`): radii, body outline,
/// sectors, or that none was learned.
std::string SelfMaskSummary(const bv::OmniSelfMask& m);
nlohmann::json FieldToJson(const bv::FieldConfig& f);

/// Serialises to a device blob (validated).
bool CalibrationToBlob(const bv::RigCalibration& cal, std::vector<uint8_t>& blob,
                       std::string& error);

/// Content-derived id: CRC-32 of the blob payload with the id field zeroed. Changes whenever
/// any calibrated value changes; identical content gives the same id.
uint32_t ComputeCalibrationId(const bv::RigCalibration& cal);

/// Creates `path` or replaces only `section` ("persp" or "omni") of an existing JSON file,
/// keeping the other section and unknown keys; recomputes calibration_id. The new section is
/// validated before anything is written.
bool UpdateCalibrationSection(const std::string& path, const std::string& section,
                              const nlohmann::json& value, std::string& error);

bool ReadFileBytes(const std::string& path, std::vector<uint8_t>& bytes, std::string& error);
/// Reads and parses a JSON file; the error names the file (cannot open / not valid JSON).
bool ReadJsonFile(const std::string& path, nlohmann::json& out, std::string& error);
bool WriteFileBytes(const std::string& path, const std::vector<uint8_t>& bytes, std::string& error);

}  // namespace bv::cli
