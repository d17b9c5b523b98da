#include "tools/ballvision/carpet_json.h"

#include <cmath>
#include <cstdio>

#include "tools/ballvision/calib_io.h"
#include "tools/ballvision/strict_json.h"

namespace bv::cli {

using nlohmann::json;

CarpetColorCode CarpetColor(const std::string& name) {
  if (name == "white") return kCarpetWhite;
  if (name == "blue") return kCarpetBlue;
  if (name == "red") return kCarpetRed;
  return kCarpetOther;
}

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr size_t kMinEdges = 12;  // support vectors per direction (OmniCalibration::kEdges)

double Wrap2Pi(double a) {
  a = std::fmod(a, 2 * kPi);
  return a < 0 ? a + 2 * kPi : a;
}
double WrapPi(double a) { return Wrap2Pi(a + kPi) - kPi; }

bool ParseCarpetFrames(StrictObject& r, const std::string& path, Carpet& c) {
  const json* frames = r.Child("frames");
  if (!frames) return false;
  if (!frames->is_array() || frames->empty()) {
    return r.Fail("frames", *frames, "a non-empty array of per-frame objects");
  }
  for (size_t i = 0; i < frames->size(); ++i) {
    StrictObject f((*frames)[i], path, "frames[" + std::to_string(i) + "]");
    int64_t index = 0;
    double az = 0, bearing = 0;
    if (!f.IsObject() || !f.Int("index", index, 0, INT32_MAX)) return r.Adopt(f);
    // Either direction convention; both present must agree (bearing: clockwise from +y).
    const bool has_az = f.Has("carpet_azimuth_robot_deg"), has_b = f.Has("carpet_bearing_deg");
    if (!f.Number("carpet_azimuth_robot_deg", az, -720, 720, has_az || !has_b) ||
        !f.Number("carpet_bearing_deg", bearing, -720, 720, false)) {
      return r.Adopt(f);
    }
    if (!has_az) az = 90.0 - bearing;
    if (has_az && has_b && std::fabs(WrapPi((az - (90.0 - bearing)) * kPi / 180)) > 1e-3) {
      return r.Fail("frames[" + std::to_string(i) + "].carpet_bearing_deg", bearing,
                    "90 - carpet_azimuth_robot_deg (the two directions disagree)");
    }
    f.Allow({"t_us", "robot_heading_field_deg"});
    for (const std::string& k : f.UnknownKeys()) {
      std::fprintf(stderr, "warning: %s: unknown key, ignored\n", k.c_str());
    }
    if (!c.azimuth_rad.emplace(index, Wrap2Pi(az * kPi / 180)).second) {
      return r.Fail("frames[" + std::to_string(i) + "].index", index, "a unique frame index");
    }
  }
  return true;
}

}  // namespace

bool LoadCarpet(const std::string& path, Carpet& c, std::string& error) {
  json j;
  return ReadJsonFile(path, j, error) && ParseCarpet(j, path, c, error);
}

// Types, units (metres, degrees), ranges, and the cross-field rules the calibration relies on.
bool ParseCarpet(const json& j, const std::string& path, Carpet& c, std::string& error) {
  c = Carpet{};
  StrictObject r(j, path, "");
  bool ok = r.IsObject() && r.NumberArray("edges_m", c.edges_m, 0, 100) &&
            r.Number("width_m", c.width_m, 0.05, 10, false) &&
            r.Number("thickness_m", c.thickness_m, 0, 0.2, false);
  const json* cj = ok ? r.Child("colors") : nullptr;
  ok = ok && cj;
  if (ok && (!cj->is_array() || cj->size() + 1 != c.edges_m.size())) {
    ok = r.Fail("colors", *cj,
                "an array with one entry less than edges_m (" + std::to_string(c.edges_m.size()) +
                    " edges)");
  }
  for (size_t i = 0; ok && i < cj->size(); ++i) {
    const json& e = (*cj)[i];
    if (!e.is_string() || CarpetColor(e.get<std::string>()) == kCarpetOther) {
      ok = r.Fail("colors[" + std::to_string(i) + "]", e, "\"white\", \"blue\" or \"red\"");
    } else {
      c.colors.push_back(CarpetColor(e.get<std::string>()));
    }
  }
  for (size_t i = 1; ok && i < c.edges_m.size(); ++i) {
    if (!(c.edges_m[i] > c.edges_m[i - 1])) {
      ok = r.Fail("edges_m[" + std::to_string(i) + "]", c.edges_m[i], "increasing edges");
    }
  }
  if (ok && c.edges_m.size() < kMinEdges) {
    ok = r.Fail("edges_m", j["edges_m"], "at least 12 edges (12 support vectors per direction)");
  }
  ok = ok && ParseCarpetFrames(r, path, c);
  r.Allow({"field_direction_deg", "origin_field"});
  if (!ok) {
    error = r.error();
    return false;
  }
  for (const std::string& k : r.UnknownKeys()) {
    std::fprintf(stderr, "warning: %s: unknown key, ignored\n", k.c_str());
  }
  return true;
}

}  // namespace bv::cli
