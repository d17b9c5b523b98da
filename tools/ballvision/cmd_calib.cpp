// `ballvision calib to-blob IN OUT | to-json IN OUT | show IN`: converts the robot's calibration
// between JSON (people) and the device blob, both ways, and prints it.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "tools/ballvision/calib_io.h"
#include "tools/ballvision/cli_args.h"
#include "tools/ballvision/commands.h"

namespace bv::cli {
namespace {

constexpr char kUsage[] =
    "usage: ballvision calib to-blob CALIB(.json|.bin) OUT.bin\n"
    "       ballvision calib to-json CALIB(.json|.bin) OUT.json\n"
    "       ballvision calib show CALIB(.json|.bin)\n"
    "       ballvision calib set CALIB.json [--lut-id N] [--ball-radius M]\n"
    "       ballvision calib rays CALIB(.json|.bin) --camera omni|persp < PIXELS\n"
    "  rays: reads 'u v' pixel lines on stdin, writes one CSV line per pixel:\n"
    "  u,v,ok,ox,oy,oz,dx,dy,dz (robot frame; the omni ray as the pipeline uses it,\n"
    "  beyond the distance map included; ok 0 = no ray, the rest empty)\n";

void Show(const RigCalibration& c) {
  std::printf("calibration_id 0x%08x  lut_id 0x%08x  ball_radius_m %.4f\n", c.calibration_id,
              c.lut_id, c.ball_radius_m);
  const PerspCalibration& p = c.persp;
  if (p.valid) {
    std::printf(
        "persp: %dx%d fx %.3f fy %.3f cx %.3f cy %.3f skew %.4f k1 %.5f k2 %.5f "
        "rms %.4f px\n",
        p.width_px, p.height_px, p.fx, p.fy, p.cx, p.cy, p.skew, p.k1, p.k2, p.rms_px);
    const Eigen::Vector3f axis = p.R_robot_cam.col(2);
    std::printf("  camera at (%.4f, %.4f, %.4f) m, optical axis (%.4f, %.4f, %.4f)\n",
                p.t_robot_cam.x(), p.t_robot_cam.y(), p.t_robot_cam.z(), axis.x(), axis.y(),
                axis.z());
  } else {
    std::printf("persp: not calibrated\n");
  }
  const OmniCalibration& o = c.omni;
  if (o.valid) {
    int interpolated = 0;
    for (uint8_t f : o.sector_flags) interpolated += (f & kOmniSectorInterpolated) ? 1 : 0;
    std::printf(
        "omni: centre (%.2f, %.2f) px, viewpoint z %.4f m, angle sign %+d offset %.2f "
        "deg, %d/%d sectors interpolated\n",
        o.center_u, o.center_v, o.viewpoint_z_m, o.image_angle_sign,
        o.image_angle_offset_rad * 180.0 / M_PI, interpolated, OmniCalibration::kDirections);
    std::printf("  edges_m:");
    for (float e : o.edge_ground_m) std::printf(" %.2f", e);
    std::printf("\n  support_px min/max over sectors per edge:");
    for (int k = 0; k < OmniCalibration::kEdges; ++k) {
      float lo = 1e9f, hi = -1e9f;
      for (const auto& row : o.support_px) {
        lo = std::min(lo, row[k]);
        hi = std::max(hi, row[k]);
      }
      std::printf(" %.1f-%.1f", lo, hi);
    }
    std::printf("\n");
    std::printf("  self-mask: %s\n", SelfMaskSummary(o.self_mask).c_str());
  } else {
    std::printf("omni: not calibrated\n");
  }
  const FieldConfig& f = c.field;
  std::printf(
      "field: %.3f x %.3f m, lines %.3f m, goals %.3f wide %.3f high %.3f deep, border %.3f m\n",
      f.length_m, f.width_m, f.line_width_m, f.goal_width_m, f.goal_height_m, f.goal_depth_m,
      f.border_m);
}

int ShowFile(int argc, char** argv) {
  std::string in;
  ArgParser p("ballvision calib show", kUsage);
  p.Positional("CALIB", in);
  if (const int rc = p.Parse(argc, argv); rc >= 0) return rc;
  RigCalibration cal;
  std::string error;
  if (!LoadCalibrationFile(in, cal, error)) {
    std::fprintf(stderr, "calib show: %s\n", error.c_str());
    return 1;
  }
  Show(cal);
  return 0;
}

// to-blob and to-json.
int Convert(int argc, char** argv) {
  const std::string sub = argv[0];
  std::string in, out;
  ArgParser p("ballvision calib " + sub, kUsage);
  p.Positional("CALIB", in).Positional("OUT", out);
  if (const int rc = p.Parse(argc, argv); rc >= 0) return rc;
  RigCalibration cal;
  std::string error;
  if (!LoadCalibrationFile(in, cal, error)) {
    std::fprintf(stderr, "calib %s: %s\n", sub.c_str(), error.c_str());
    return 1;
  }
  if (sub == "to-blob") {
    std::vector<uint8_t> blob;
    if (!CalibrationToBlob(cal, blob, error) || !WriteFileBytes(out, blob, error)) {
      std::fprintf(stderr, "calib to-blob: %s\n", error.c_str());
      return 1;
    }
    std::printf("wrote %s (%zu bytes, calibration_id 0x%08x)\n", out.c_str(), blob.size(),
                cal.calibration_id);
  } else {
    if (!SaveCalibrationJson(out, cal, error)) {
      std::fprintf(stderr, "calib to-json: %s\n", error.c_str());
      return 1;
    }
    std::printf("wrote %s\n", out.c_str());
  }
  return 0;
}

// "N" or "0xHEX", 32 bits.
bool LutId(const std::string& text, int64_t& v, std::string& error) {
  const bool hex = text.rfind("0x", 0) == 0 || text.rfind("0X", 0) == 0;
  char* end = nullptr;
  if (hex) v = static_cast<int64_t>(std::strtoull(text.c_str() + 2, &end, 16));
  std::string e;
  if (hex ? (text.size() < 3 || text.size() > 10 || *end != '\0')
          : !ArgInt("--lut-id", text, 0, 0xFFFFFFFFll, v, e)) {
    error = "--lut-id: got '" + text + "', expected a 32-bit id (decimal or 0x hex)";
    return false;
  }
  return true;
}

// Rig constants outside the camera sections; the file is validated before it is written.
int Set(int argc, char** argv) {
  std::string path;
  int64_t lut_id = -1;
  double ball_radius_m = -1;
  ArgParser p("ballvision calib set", kUsage);
  p.Positional("CALIB", path)
      .Custom("--lut-id", [&lut_id](const std::string& v,
                                    std::string& error) { return LutId(v, lut_id, error); })
      .Custom("--ball-radius", [&ball_radius_m](const std::string& v, std::string& error) {
        if (ArgNumber("--ball-radius", v, 0.01, 1.0, ball_radius_m, error)) return true;
        error += " (metres)";
        return false;
      });
  if (const int rc = p.Parse(argc, argv); rc >= 0) return rc;
  if (lut_id < 0 && ball_radius_m < 0) return p.UsageError("nothing to set");
  nlohmann::json j;
  std::string error;
  if (!ReadJsonFile(path, j, error)) {
    std::fprintf(stderr, "calib set: %s\n", error.c_str());
    return 1;
  }
  if (!j.is_object()) {
    std::fprintf(stderr, "calib set: %s is not a JSON calibration\n", path.c_str());
    return 1;
  }
  if (lut_id >= 0) j["lut_id"] = static_cast<uint32_t>(lut_id);
  if (ball_radius_m >= 0) j["ball_radius_m"] = ball_radius_m;
  RigCalibration cal;
  if (!CalibrationFromJson(j, cal, error, path)) {
    std::fprintf(stderr, "calib set: not written: %s\n", error.c_str());
    return 1;
  }
  cal.calibration_id = ComputeCalibrationId(cal);
  j["calibration_id"] = cal.calibration_id;
  const std::string text = j.dump(1) + "\n";
  if (!WriteFileBytes(path, std::vector<uint8_t>(text.begin(), text.end()), error)) {
    std::fprintf(stderr, "calib set: %s\n", error.c_str());
    return 1;
  }
  Show(cal);
  return 0;
}

// The rays the pipeline would use, for checks against a rig model (tools/python/validate_rays.py).
int Rays(int argc, char** argv) {
  std::string in, camera;
  ArgParser p("ballvision calib rays", kUsage);
  p.Positional("CALIB", in).Text("--camera", camera).Required("--camera");
  if (const int rc = p.Parse(argc, argv); rc >= 0) return rc;
  if (camera != "omni" && camera != "persp") {
    return p.UsageError("--camera: got '" + camera + "', expected omni or persp");
  }
  RigCalibration cal;
  std::string error;
  if (!LoadCalibrationFile(in, cal, error)) {
    std::fprintf(stderr, "calib rays: %s\n", error.c_str());
    return 1;
  }
  if (camera == "omni" ? !cal.omni.valid : !cal.persp.valid) {
    std::fprintf(stderr, "calib rays: %s has no %s calibration\n", in.c_str(), camera.c_str());
    return 1;
  }
  std::printf("u,v,ok,ox,oy,oz,dx,dy,dz\n");
  char line[256];
  long line_no = 0;
  while (std::fgets(line, sizeof line, stdin) != nullptr) {
    ++line_no;
    double u = 0, v = 0;
    char extra = 0;
    const int got = std::sscanf(line, "%lf %lf %c", &u, &v, &extra);
    if (got == EOF) continue;  // blank line
    if (got != 2 || !std::isfinite(u) || !std::isfinite(v)) {
      std::fprintf(stderr, "calib rays: stdin line %ld: expected 'u v', got '%s'\n", line_no, line);
      return 1;
    }
    const Result<Ray> r =
        camera == "omni"
            ? OmniPixelToRayExtended(cal.omni, static_cast<float>(u), static_cast<float>(v))
            : PerspPixelToRay(cal.persp, static_cast<float>(u), static_cast<float>(v));
    if (!r.ok()) {
      std::printf("%.3f,%.3f,0,,,,,,\n", u, v);
      continue;
    }
    std::printf("%.3f,%.3f,1,%.6f,%.6f,%.6f,%.7f,%.7f,%.7f\n", u, v, r->origin.x(), r->origin.y(),
                r->origin.z(), r->dir.x(), r->dir.y(), r->dir.z());
  }
  return 0;
}

}  // namespace

int CmdCalib(int argc, char** argv) {
  return RunSubCommand("ballvision calib", kUsage, argc, argv,
                       {{"show", ShowFile},
                        {"to-blob", Convert},
                        {"to-json", Convert},
                        {"set", Set},
                        {"rays", Rays}});
}

}  // namespace bv::cli
