#include "tools/ballvision/calib_io.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "core/common/blob.h"
#include "core/common/crc32.h"
#include "tools/ballvision/safe_write.h"
#include "tools/ballvision/strict_json.h"

namespace bv::cli {
namespace {

using nlohmann::json;

constexpr double kBig = 1e30;

// Appends instead of operator+ (GCC 12 reports a false -Wrestrict on "[" + to_string(i)).
std::string IndexKey(int i) {
  std::string k("[");
  k.append(std::to_string(i));
  k.push_back(']');
  return k;
}

// Ranges follow the device's blob checks (core/calibration) so a refusal names the field here.
bool PerspIntrinsicsFromJson(StrictObject& r, PerspCalibration& p) {
  const bool v = p.valid;
  int64_t w = 0, h = 0;
  if (!r.Int("width_px", w, 16, 4096) || !r.Int("height_px", h, 16, 4096)) return false;
  p.width_px = static_cast<int>(w);
  p.height_px = static_cast<int>(h);
  return r.Float("fx", p.fx, v ? 1 : -kBig, v ? 1e5 : kBig) &&
         r.Float("fy", p.fy, v ? 1 : -kBig, v ? 1e5 : kBig) &&
         r.Float("cx", p.cx, v ? -w : -kBig, v ? 2.0 * w : kBig) &&
         r.Float("cy", p.cy, v ? -h : -kBig, v ? 2.0 * h : kBig) &&
         r.Float("skew", p.skew, v ? -1e4 : -kBig, v ? 1e4 : kBig) &&
         r.Float("k1", p.k1, v ? -100 : -kBig, v ? 100 : kBig) &&
         r.Float("k2", p.k2, v ? -1000 : -kBig, v ? 1000 : kBig) &&
         r.Float("rms_px", p.rms_px, v ? 0 : -kBig, v ? 1e3 : kBig, /*required=*/false);
}

bool PerspFromJson(const json& j, const std::string& file, PerspCalibration& p,
                   std::vector<std::string>* unknown, std::string& error) {
  p = PerspCalibration{};
  StrictObject r(j, file, "persp");
  std::string model;
  bool ok = r.IsObject() && r.Bool("valid", p.valid) && PerspIntrinsicsFromJson(r, p) &&
            r.String("model", model, {"zhang_k1k2", "zhang_k1k2_skew"}, /*required=*/false);
  if (ok && model == "zhang_k1k2" && p.skew != 0) {
    ok = r.Fail("skew", j["skew"], "0 for model \"zhang_k1k2\" (no skew)");
  }
  if (ok && r.Has("R_robot_cam")) {
    const json& rows = *r.Child("R_robot_cam");
    if (!rows.is_array() || rows.size() != 3) {
      ok = r.Fail("R_robot_cam", rows, "3 rows of 3 numbers");
    }
    for (int i = 0; ok && i < 3; ++i) {
      float row[3];
      const std::string key = IndexKey(i);
      const json wrap{{key, rows[i]}};
      StrictObject rr(wrap, file, "persp.R_robot_cam");
      ok = rr.FloatArray(key.c_str(), row, 3, -1.001, 1.001) || r.Adopt(rr);
      for (int c = 0; ok && c < 3; ++c) p.R_robot_cam(i, c) = row[c];
    }
  }
  float t[3];
  if (ok && r.FloatArray("t_robot_cam", t, 3, -100, 100, /*required=*/false) &&
      r.Has("t_robot_cam")) {
    p.t_robot_cam = Eigen::Vector3f(t[0], t[1], t[2]);
  }
  ok = ok && r.error().empty();
  r.Allow({"views", "per_image_rms_px", "pose_rms_px", "pose_views"});
  if (!ok) error = r.error();
  if (ok && unknown) {
    for (auto& k : r.UnknownKeys()) unknown->push_back(k);
  }
  return ok;
}

bool OmniScalarsFromJson(StrictObject& r, OmniCalibration& o) {
  const bool v = o.valid;
  int64_t sign = 0;
  if (!r.Int("image_angle_sign", sign, -1, 1)) return false;
  if (sign == 0) return r.Fail("image_angle_sign", 0, "1 or -1");
  o.image_angle_sign = static_cast<int8_t>(sign);
  double sector = 0;
  if (r.Has("sector_deg") && !r.Number("sector_deg", sector, -kBig, kBig)) return false;
  if (r.Has("sector_deg") && sector != 360.0 / OmniCalibration::kDirections) {
    return r.Fail("sector_deg", sector, "8 (45 sectors of 8 degrees)");
  }
  return r.Float("center_u", o.center_u, v ? 0 : -kBig, v ? 4096 : kBig) &&
         r.Float("center_v", o.center_v, v ? 0 : -kBig, v ? 4096 : kBig) &&
         r.Float("viewpoint_z_m", o.viewpoint_z_m, v ? 0.01 : -kBig, v ? 10 : kBig) &&
         r.Float("image_angle_offset_rad", o.image_angle_offset_rad, -4 * M_PI, 4 * M_PI) &&
         r.FloatArray("edge_ground_m", o.edge_ground_m, OmniCalibration::kEdges, v ? 0 : -kBig,
                      v ? 100 : kBig) &&
         r.FloatArray("azimuth_harmonics_rad", o.azimuth_harmonics_rad, 4, -0.1, 0.1,
                      /*required=*/false);
}

bool OmniTablesFromJson(StrictObject& r, const std::string& file, OmniCalibration& o) {
  const bool v = o.valid;
  const json* rows = r.Child("support_px");
  if (!rows) return false;
  if (!rows->is_array() || rows->size() != OmniCalibration::kDirections) {
    return r.Fail("support_px", *rows, "45 rows of 12 numbers");
  }
  for (int s = 0; s < OmniCalibration::kDirections; ++s) {
    const std::string key = IndexKey(s);
    const json wrap{{key, (*rows)[s]}};
    StrictObject rr(wrap, file, "omni.support_px");
    if (!rr.FloatArray(key.c_str(), o.support_px[s], OmniCalibration::kEdges, v ? 0 : -kBig,
                       v ? 4096 : kBig)) {
      return r.Adopt(rr);
    }
  }
  const json* flags = r.Child("sector_flags", /*required=*/false);
  if (!flags) return true;
  if (!flags->is_array() || flags->size() != OmniCalibration::kDirections) {
    return r.Fail("sector_flags", *flags, "an array of 45 integers 0 or 1");
  }
  for (int s = 0; s < OmniCalibration::kDirections; ++s) {
    int64_t f = 0;
    const std::string key = IndexKey(s);
    const json wrap{{key, (*flags)[s]}};
    StrictObject fr(wrap, file, "omni.sector_flags");
    if (!fr.Int(key.c_str(), f, 0, 1)) return r.Adopt(fr);
    o.sector_flags[s] = static_cast<uint8_t>(f);
  }
  return true;
}

// `self_mask` (optional; absent: none learned): radii, sectors as [angle, half width] pairs, the
// body outline.
bool SelfMaskFromJson(StrictObject& r, const std::string& file, OmniSelfMask& m) {
  const json* jm = r.Child("self_mask", /*required=*/false);
  if (!jm) return true;
  StrictObject mr(*jm, file, "omni.self_mask");
  float body[OmniSelfMask::kOutlineDirections];
  m.known = true;
  if (!mr.IsObject() || !mr.Float("inner_radius_px", m.inner_radius_px, 1, 2048) ||
      !mr.Float("outer_radius_px", m.outer_radius_px, 1, 2048) ||
      !mr.FloatArray("body_px", body, OmniSelfMask::kOutlineDirections, 0, 255)) {
    return r.Adopt(mr);
  }
  for (int i = 0; i < OmniSelfMask::kOutlineDirections; ++i) {
    m.body_px[i] = static_cast<uint8_t>(std::lround(body[i]));
  }
  const json* sectors = mr.Child("sectors");
  if (!sectors) return r.Adopt(mr);
  if (!sectors->is_array() || sectors->size() > OmniSelfMask::kMaxSectors) {
    return r.Fail("self_mask.sectors", *sectors, "at most 8 [angle_deg, half_width_deg] pairs");
  }
  m.sector_count = static_cast<int>(sectors->size());
  for (int i = 0; i < m.sector_count; ++i) {
    const std::string key = IndexKey(i);
    const json wrap{{key, (*sectors)[i]}};
    StrictObject sr(wrap, file, "omni.self_mask.sectors");
    float pair[2];
    if (!sr.FloatArray(key.c_str(), pair, 2, -360, 360)) return r.Adopt(sr);
    m.sectors[i] = {pair[0], pair[1]};
  }
  mr.Allow({"unchanged_fraction", "frames"});
  const Status valid = ValidateSelfMask(m);
  if (!valid.ok()) return r.Fail("self_mask", *jm, valid.message());
  return true;
}

bool OmniFromJson(const json& j, const std::string& file, OmniCalibration& o,
                  std::vector<std::string>* unknown, std::string& error) {
  o = OmniCalibration{};
  StrictObject r(j, file, "omni");
  const bool ok = r.IsObject() && r.Bool("valid", o.valid) && OmniScalarsFromJson(r, o) &&
                  OmniTablesFromJson(r, file, o) && SelfMaskFromJson(r, file, o.self_mask);
  r.Allow({"samples", "rim_radius_px", "symmetric_support_px", "rms_ground_rel",
           "symmetric_rms_ground_rel"});
  if (!ok) error = r.error();
  if (ok) PrepareOmniAngles(o);
  if (ok && unknown) {
    for (auto& k : r.UnknownKeys()) unknown->push_back(k);
  }
  return ok;
}

// The calibration's `field` section: rig.json's names (metres), each optional (MSL default).
struct FieldKey {
  const char* key;
  float FieldConfig::*member;
  double lo, hi;
};
constexpr FieldKey kFieldKeys[] = {
    {"length", &FieldConfig::length_m, 0.5, 40},
    {"width", &FieldConfig::width_m, 0.5, 30},
    {"line_width", &FieldConfig::line_width_m, 0.01, 0.5},
    {"center_circle_radius", &FieldConfig::center_circle_radius_m, 0, 15},
    {"penalty_area_depth", &FieldConfig::penalty_area_depth_m, 0.01, 20},
    {"penalty_area_width", &FieldConfig::penalty_area_width_m, 0.01, 30},
    {"goal_area_depth", &FieldConfig::goal_area_depth_m, 0.01, 20},
    {"goal_area_width", &FieldConfig::goal_area_width_m, 0.01, 30},
    {"penalty_mark_distance", &FieldConfig::penalty_mark_distance_m, 0, 20},
    {"corner_arc_radius", &FieldConfig::corner_arc_radius_m, 0, 15},
    {"goal_width", &FieldConfig::goal_width_m, 0.1, 30},
    {"goal_height", &FieldConfig::goal_height_m, 0.1, 3},
    {"goal_depth", &FieldConfig::goal_depth_m, 0.05, 3},
    {"border", &FieldConfig::border_m, 0, 5},
    {"margin", &FieldConfig::margin_m, 0, 2},
};

bool FieldFromJson(const json& j, const std::string& file, FieldConfig& f,
                   std::vector<std::string>* unknown, std::string& error) {
  f = FieldConfig{};
  StrictObject r(j, file, "field");
  bool ok = r.IsObject();
  for (const FieldKey& k : kFieldKeys) {
    ok = ok && r.Float(k.key, f.*k.member, k.lo, k.hi, /*required=*/false);
  }
  if (!ok) {
    error = r.error();
    return false;
  }
  // Cross-field checks (areas inside the field, ...): the device's own, named by its field.
  if (const Status s = ValidateFieldConfig(f); !s.ok()) {
    std::string msg = s.message();  // "field.goal_width_m: ..." -> the JSON key "field.goal_width"
    if (const size_t at = msg.find("_m:"); at != std::string::npos) msg.erase(at, 2);
    error = (file.empty() ? "" : file + ": ") + msg;
    return false;
  }
  if (unknown) {
    for (auto& k : r.UnknownKeys()) unknown->push_back(k);
  }
  return true;
}

}  // namespace

json FieldToJson(const FieldConfig& f) {
  json j;
  for (const FieldKey& k : kFieldKeys) j[k.key] = f.*k.member;
  return j;
}

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

std::string SelfMaskSummary(const OmniSelfMask& m) {
  if (!m.known) return "none learned (the reference rig's body, rim and struts stand in)";
  const auto [lo, hi] =
      std::minmax_element(m.body_px, m.body_px + OmniSelfMask::kOutlineDirections);
  char buf[96];
  std::snprintf(buf, sizeof buf,
                "usable radii %.1f-%.1f px, body outline %d-%d px, %d sectors:", m.inner_radius_px,
                m.outer_radius_px, *lo, *hi, m.sector_count);
  std::string text = buf;
  for (int i = 0; i < m.sector_count; ++i) {
    std::snprintf(buf, sizeof buf, " %.1f+-%.1f", m.sectors[i].angle_deg,
                  m.sectors[i].half_width_deg);
    text += buf;
  }
  return text + " deg";
}

json OmniToJson(const OmniCalibration& o) {
  json j;
  j["valid"] = o.valid;
  j["center_u"] = o.center_u;
  j["center_v"] = o.center_v;
  j["viewpoint_z_m"] = o.viewpoint_z_m;
  j["image_angle_sign"] = static_cast<int>(o.image_angle_sign);
  j["image_angle_offset_rad"] = o.image_angle_offset_rad;
  j["azimuth_harmonics_rad"] =
      std::vector<float>(o.azimuth_harmonics_rad, o.azimuth_harmonics_rad + 4);
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
  const OmniSelfMask& m = o.self_mask;
  if (m.known) {
    json sectors = json::array();
    for (int i = 0; i < m.sector_count; ++i) {
      sectors.push_back({m.sectors[i].angle_deg, m.sectors[i].half_width_deg});
    }
    j["self_mask"] = {
        {"inner_radius_px", m.inner_radius_px},
        {"outer_radius_px", m.outer_radius_px},
        {"sectors", sectors},
        {"body_px", std::vector<int>(m.body_px, m.body_px + OmniSelfMask::kOutlineDirections)}};
  }
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
  j["field"] = FieldToJson(cal.field);
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

bool CalibrationFromJson(const json& j, RigCalibration& out, std::string& error,
                         const std::string& file, std::vector<std::string>* unknown) {
  RigCalibration cal;
  StrictObject r(j, file, "");
  std::string format;
  int64_t version = 0;
  bool ok = r.IsObject() && r.String("format", format, {"ballvision-calibration"}) &&
            r.Int("version", version, 1, kCalibrationBlobVersion) &&
            r.U32("calibration_id", cal.calibration_id, /*required=*/false) &&
            r.U32("lut_id", cal.lut_id) && r.Float("ball_radius_m", cal.ball_radius_m, 0.01, 1.0);
  if (!ok) {
    error = r.error();
    return false;
  }
  std::vector<std::string> unknown_here;
  const json* persp = r.Child("persp", /*required=*/false);
  const json* omni = r.Child("omni", /*required=*/false);
  const json* field = r.Child("field", /*required=*/false);  // none: the MSL field
  if ((persp && !PerspFromJson(*persp, file, cal.persp, &unknown_here, error)) ||
      (omni && !OmniFromJson(*omni, file, cal.omni, &unknown_here, error)) ||
      (field && !FieldFromJson(*field, file, cal.field, &unknown_here, error))) {
    return false;
  }
  // Same checks as the device (cross-field: rotation, increasing edges and support vectors).
  std::vector<uint8_t> blob;
  if (!CalibrationToBlob(cal, blob, error)) {
    if (!file.empty()) error = file + ": " + error;
    return false;
  }
  if (unknown) {
    *unknown = r.UnknownKeys();
    unknown->insert(unknown->end(), unknown_here.begin(), unknown_here.end());
  }
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

namespace {

// The parser's own message says where the text stops being JSON (line, column, token).
bool ParseJsonBytes(const std::vector<uint8_t>& bytes, const std::string& path, json& out,
                    std::string& error) {
  try {
    out = json::parse(bytes.begin(), bytes.end());
    return true;
  } catch (const json::exception& e) {
    error = path + ": not valid JSON (" + e.what() + ")";
    return false;
  }
}

}  // namespace

bool ReadJsonFile(const std::string& path, json& out, std::string& error) {
  std::vector<uint8_t> bytes;
  return ReadFileBytes(path, bytes, error) && ParseJsonBytes(bytes, path, out, error);
}

bool WriteFileBytes(const std::string& path, const std::vector<uint8_t>& bytes,
                    std::string& error) {
  return WriteFileAtomic(path, bytes, error);
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
  json j;
  if (!ParseJsonBytes(bytes, path, j, error)) {
    error += "; not a calibration blob either (no BVB1 magic)";
    return false;
  }
  std::vector<std::string> unknown;
  if (!CalibrationFromJson(j, out, error, path, &unknown)) return false;
  for (const std::string& k : unknown) {
    std::fprintf(stderr, "warning: %s: unknown key, ignored\n", k.c_str());
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
