#include "tools/ballvision/calib_io.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "core/common/blob.h"
#include "core/common/crc32.h"

namespace bv::cli {
namespace {

using nlohmann::json;

bool GetNumber(const json& j, const char* key, double& v, std::string& error,
               const std::string& where) {
  if (!j.contains(key)) {
    error = where + "." + key + " missing";
    return false;
  }
  if (!j[key].is_number()) {
    error = where + "." + key + " is not a number";
    return false;
  }
  v = j[key].get<double>();
  if (!std::isfinite(v)) {
    error = where + "." + key + " is not finite";
    return false;
  }
  return true;
}

bool GetFloat(const json& j, const char* key, float& v, std::string& error,
              const std::string& where) {
  double d = 0;
  if (!GetNumber(j, key, d, error, where)) return false;
  v = static_cast<float>(d);
  return true;
}

bool GetFloatArray(const json& j, const char* key, float* dst, size_t n, std::string& error,
                   const std::string& where) {
  if (!j.contains(key) || !j[key].is_array() || j[key].size() != n) {
    error = where + "." + key + " must be an array of " + std::to_string(n) + " numbers";
    return false;
  }
  for (size_t i = 0; i < n; ++i) {
    if (!j[key][i].is_number()) {
      error = where + "." + key + "[" + std::to_string(i) + "] is not a number";
      return false;
    }
    dst[i] = static_cast<float>(j[key][i].get<double>());
  }
  return true;
}

bool PerspFromJson(const json& j, PerspCalibration& p, std::string& error) {
  const std::string w = "persp";
  p = PerspCalibration{};
  if (!j.is_object()) {
    error = "persp is not an object";
    return false;
  }
  p.valid = j.value("valid", true);
  double d = 0;
  if (!GetNumber(j, "width_px", d, error, w)) return false;
  p.width_px = static_cast<int>(d);
  if (!GetNumber(j, "height_px", d, error, w)) return false;
  p.height_px = static_cast<int>(d);
  if (!GetFloat(j, "fx", p.fx, error, w) || !GetFloat(j, "fy", p.fy, error, w) ||
      !GetFloat(j, "cx", p.cx, error, w) || !GetFloat(j, "cy", p.cy, error, w) ||
      !GetFloat(j, "skew", p.skew, error, w) || !GetFloat(j, "k1", p.k1, error, w) ||
      !GetFloat(j, "k2", p.k2, error, w)) {
    return false;
  }
  if (j.contains("rms_px") && !GetFloat(j, "rms_px", p.rms_px, error, w)) return false;
  if (j.contains("R_robot_cam")) {
    const json& r = j["R_robot_cam"];
    if (!r.is_array() || r.size() != 3) {
      error = "persp.R_robot_cam must be 3x3";
      return false;
    }
    for (int i = 0; i < 3; ++i) {
      float row[3];
      if (!GetFloatArray(json{{"row", r[i]}}, "row", row, 3, error, "persp.R_robot_cam")) {
        return false;
      }
      for (int c = 0; c < 3; ++c) p.R_robot_cam(i, c) = row[c];
    }
  }
  if (j.contains("t_robot_cam")) {
    float t[3];
    if (!GetFloatArray(j, "t_robot_cam", t, 3, error, w)) return false;
    p.t_robot_cam = Eigen::Vector3f(t[0], t[1], t[2]);
  }
  return true;
}

bool OmniFromJson(const json& j, OmniCalibration& o, std::string& error) {
  const std::string w = "omni";
  o = OmniCalibration{};
  if (!j.is_object()) {
    error = "omni is not an object";
    return false;
  }
  o.valid = j.value("valid", true);
  if (!GetFloat(j, "center_u", o.center_u, error, w) ||
      !GetFloat(j, "center_v", o.center_v, error, w) ||
      !GetFloat(j, "viewpoint_z_m", o.viewpoint_z_m, error, w)) {
    return false;
  }
  double sign = 1;
  if (j.contains("image_angle_sign") && !GetNumber(j, "image_angle_sign", sign, error, w)) {
    return false;
  }
  o.image_angle_sign = static_cast<int8_t>(sign < 0 ? -1 : 1);
  if (j.contains("image_angle_offset_rad") &&
      !GetFloat(j, "image_angle_offset_rad", o.image_angle_offset_rad, error, w)) {
    return false;
  }
  if (!GetFloatArray(j, "edge_ground_m", o.edge_ground_m, OmniCalibration::kEdges, error, w)) {
    return false;
  }
  if (!j.contains("support_px") || !j["support_px"].is_array() ||
      j["support_px"].size() != OmniCalibration::kDirections) {
    error = "omni.support_px must be 45 rows of 12";
    return false;
  }
  for (int s = 0; s < OmniCalibration::kDirections; ++s) {
    if (!GetFloatArray(json{{"row", j["support_px"][s]}}, "row", o.support_px[s],
                       OmniCalibration::kEdges, error,
                       "omni.support_px[" + std::to_string(s) + "]")) {
      return false;
    }
  }
  if (j.contains("sector_flags")) {
    const json& f = j["sector_flags"];
    if (!f.is_array() || f.size() != OmniCalibration::kDirections) {
      error = "omni.sector_flags must have 45 entries";
      return false;
    }
    for (int s = 0; s < OmniCalibration::kDirections; ++s) {
      if (!f[s].is_number_integer() || f[s].get<int>() < 0 || f[s].get<int>() > 255) {
        error = "omni.sector_flags[" + std::to_string(s) + "] is not a byte";
        return false;
      }
      o.sector_flags[s] = static_cast<uint8_t>(f[s].get<int>());
    }
  }
  return true;
}

}  // namespace

json PerspToJson(const PerspCalibration& p) {
  json j;
  j["valid"] = p.valid;
  j["width_px"] = p.width_px;
  j["height_px"] = p.height_px;
  j["fx"] = p.fx;
  j["fy"] = p.fy;
  j["cx"] = p.cx;
  j["cy"] = p.cy;
  j["skew"] = p.skew;
  j["k1"] = p.k1;
  j["k2"] = p.k2;
  j["rms_px"] = p.rms_px;
  json r = json::array();
  for (int i = 0; i < 3; ++i) {
    r.push_back({p.R_robot_cam(i, 0), p.R_robot_cam(i, 1), p.R_robot_cam(i, 2)});
  }
  j["R_robot_cam"] = r;
  j["t_robot_cam"] = {p.t_robot_cam.x(), p.t_robot_cam.y(), p.t_robot_cam.z()};
  return j;
}

json OmniToJson(const OmniCalibration& o) {
  json j;
  j["valid"] = o.valid;
  j["center_u"] = o.center_u;
  j["center_v"] = o.center_v;
  j["viewpoint_z_m"] = o.viewpoint_z_m;
  j["image_angle_sign"] = static_cast<int>(o.image_angle_sign);
  j["image_angle_offset_rad"] = o.image_angle_offset_rad;
  j["sector_deg"] = 360.0 / OmniCalibration::kDirections;
  j["edge_ground_m"] =
      std::vector<float>(o.edge_ground_m, o.edge_ground_m + OmniCalibration::kEdges);
  json sv = json::array();
  for (const auto& row : o.support_px) {
    sv.push_back(std::vector<float>(row, row + OmniCalibration::kEdges));
  }
  j["support_px"] = sv;
  j["sector_flags"] =
      std::vector<int>(o.sector_flags, o.sector_flags + OmniCalibration::kDirections);
  return j;
}

json CalibrationToJson(const RigCalibration& cal) {
  json j;
  j["format"] = "ballvision-calibration";
  j["version"] = kCalibrationBlobVersion;
  j["calibration_id"] = cal.calibration_id;
  j["lut_id"] = cal.lut_id;
  j["ball_radius_m"] = cal.ball_radius_m;
  j["persp"] = PerspToJson(cal.persp);
  j["omni"] = OmniToJson(cal.omni);
  return j;
}

bool CalibrationToBlob(const RigCalibration& cal, std::vector<uint8_t>& blob, std::string& error) {
  blob.assign(kCalibrationBlobMaxBytes, 0);
  const Result<size_t> n = SerializeCalibration(cal, blob);
  if (!n.ok()) {
    error = std::string("calibration rejected: ") + n.status().message();
    return false;
  }
  blob.resize(*n);
  return true;
}

bool CalibrationFromJson(const json& j, RigCalibration& out, std::string& error) {
  RigCalibration cal;
  if (!j.is_object()) {
    error = "calibration JSON is not an object";
    return false;
  }
  if (j.contains("version") && j["version"].is_number() &&
      j["version"].get<int>() > kCalibrationBlobVersion) {
    error = "calibration JSON version newer than this tool understands";
    return false;
  }
  double d = 0;
  if (j.contains("calibration_id")) {
    if (!GetNumber(j, "calibration_id", d, error, "calibration")) return false;
    cal.calibration_id = static_cast<uint32_t>(d);
  }
  if (j.contains("lut_id")) {
    if (!GetNumber(j, "lut_id", d, error, "calibration")) return false;
    cal.lut_id = static_cast<uint32_t>(d);
  }
  if (j.contains("ball_radius_m") &&
      !GetFloat(j, "ball_radius_m", cal.ball_radius_m, error, "calibration")) {
    return false;
  }
  if (j.contains("persp") && !PerspFromJson(j["persp"], cal.persp, error)) return false;
  if (j.contains("omni") && !OmniFromJson(j["omni"], cal.omni, error)) return false;
  // Same checks as the device.
  std::vector<uint8_t> blob;
  if (!CalibrationToBlob(cal, blob, error)) return false;
  out = cal;
  return true;
}

bool ReadFileBytes(const std::string& path, std::vector<uint8_t>& bytes, std::string& error) {
  std::ifstream f(path, std::ios::binary);
  if (!f) {
    error = "cannot open " + path;
    return false;
  }
  bytes.assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
  return true;
}

bool ReadJsonFile(const std::string& path, json& out, std::string& error) {
  std::vector<uint8_t> bytes;
  if (!ReadFileBytes(path, bytes, error)) return false;
  out = json::parse(bytes.begin(), bytes.end(), nullptr, /*allow_exceptions=*/false);
  if (out.is_discarded()) {
    error = path + ": not valid JSON";
    return false;
  }
  return true;
}

bool WriteFileBytes(const std::string& path, const std::vector<uint8_t>& bytes,
                    std::string& error) {
  // Write to a temporary name and rename, so a failed write never leaves half a file.
  const std::string tmp = path + ".tmp";
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    if (!f) {
      error = "cannot write " + tmp;
      return false;
    }
    f.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
    if (!f) {
      error = "write failed: " + tmp;
      return false;
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    error = "cannot rename " + tmp + " to " + path;
    return false;
  }
  return true;
}

bool LoadCalibrationFile(const std::string& path, RigCalibration& out, std::string& error) {
  std::vector<uint8_t> bytes;
  if (!ReadFileBytes(path, bytes, error)) return false;
  if (bytes.size() >= 4 && bytes[0] == 'B' && bytes[1] == 'V' && bytes[2] == 'B' &&
      bytes[3] == '1') {
    const Status s = ParseCalibration(bytes, out);
    if (!s.ok()) {
      error = path + ": " + s.message();
      return false;
    }
    return true;
  }
  json j = json::parse(bytes.begin(), bytes.end(), nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) {
    error = path + ": neither a calibration blob nor valid JSON";
    return false;
  }
  std::string e;
  if (!CalibrationFromJson(j, out, e)) {
    error = path + ": " + e;
    return false;
  }
  return true;
}

uint32_t ComputeCalibrationId(const RigCalibration& cal) {
  RigCalibration c = cal;
  c.calibration_id = 0;
  std::vector<uint8_t> blob(kCalibrationBlobMaxBytes);
  const Result<size_t> n = SerializeCalibration(c, blob);
  if (!n.ok()) return 0;
  return Crc32(std::span<const uint8_t>(blob.data() + kBlobHeaderBytes, *n - kBlobHeaderBytes));
}

bool SaveCalibrationJson(const std::string& path, const RigCalibration& cal, std::string& error) {
  std::vector<uint8_t> blob;
  if (!CalibrationToBlob(cal, blob, error)) return false;
  const std::string text = CalibrationToJson(cal).dump(1) + "\n";
  return WriteFileBytes(path, std::vector<uint8_t>(text.begin(), text.end()), error);
}

bool UpdateCalibrationSection(const std::string& path, const std::string& section,
                              const json& value, std::string& error) {
  json doc = json::object();
  std::ifstream f(path);
  if (f) {
    std::stringstream ss;
    ss << f.rdbuf();
    doc = json::parse(ss.str(), nullptr, false);
    if (doc.is_discarded() || !doc.is_object()) {
      error = path + " exists but is not a JSON calibration; not overwritten";
      return false;
    }
  }
  doc["format"] = "ballvision-calibration";
  doc["version"] = kCalibrationBlobVersion;
  if (!doc.contains("ball_radius_m")) doc["ball_radius_m"] = 0.11;
  if (!doc.contains("lut_id")) doc["lut_id"] = 0;
  doc[section] = value;
  RigCalibration cal;
  std::string e;
  if (!CalibrationFromJson(doc, cal, e)) {
    error = "calibration not written: " + e;
    return false;
  }
  doc["calibration_id"] = ComputeCalibrationId(cal);
  const std::string text = doc.dump(1) + "\n";
  return WriteFileBytes(path, std::vector<uint8_t>(text.begin(), text.end()), error);
}

}  // namespace bv::cli
