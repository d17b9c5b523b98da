#include "tools/ballvision/states_csv.h"

#include <cstdio>
#include <initializer_list>

#include "core/protocol/protocol.h"

namespace bv::cli {
namespace {

void Append(std::string& out, const char* fmt, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, fmt, v);
  out += buf;
}

std::string Pad3(int v) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "%03d", v);
  return buf;
}

}  // namespace

std::string StatesCsvHeader(bool predict) {
  std::string h =
      "index,t_us,found,x,y,z,vx,vy,vz,mode,omni_u,omni_v,persp_u,persp_v,ray_gap,t_bounce_us,"
      "proc_us";
  if (predict) h += ",px,py,pz";
  h += ",sigma_x,sigma_y,sigma_z";
  if (predict) h += ",psigma_x,psigma_y,psigma_z";
  // CameraState (0 as calibrated ... 3 unusable), the estimated change in degrees.
  h += ",check_omni,check_persp,check_omni_deg,check_persp_deg";
  return h + "\n";
}

std::string StatesCsvRow(int64_t index, const BallState& s, bool predict, bool with_proc) {
  std::string r =
      std::to_string(index) + "," + std::to_string(s.t_us) + "," + (s.found ? "1" : "0");
  for (float v : {s.x_m, s.y_m, s.z_m, s.vx_mps, s.vy_mps, s.vz_mps}) {
    r += ",";
    if (s.found) Append(r, "%.5f", v);
  }
  r += ",";
  r += BallModeName(s.mode);
  for (const BallDetection* d : {&s.omni, &s.persp}) {
    for (float v : {d->u_px, d->v_px}) {
      r += ",";
      if (d->found) Append(r, "%.3f", v);
    }
  }
  r += ",";
  if (s.ray_gap_m >= 0) Append(r, "%.5f", s.ray_gap_m);
  r += ",";
  if (s.flags & kFlagHasBounce) r += std::to_string(s.t_bounce_us);
  r += ",";
  if (with_proc) r += std::to_string(s.proc_us);
  if (predict) {
    for (float v : {s.px_m, s.py_m, s.pz_m}) {
      r += ",";
      if (s.flags & kFlagHasPrediction) Append(r, "%.5f", v);
    }
  }
  // As the ball-state packet carries them (mm), so run and listen write the same.
  auto sigmas = [&r](std::initializer_list<float> values, bool valid) {
    for (float v : values) {
      r += ",";
      const int mm = protocol::BallSigmaMm(v);
      if (valid) r += std::to_string(mm / 1000) + "." + Pad3(mm % 1000);
    }
  };
  sigmas({s.sigma_x_m, s.sigma_y_m, s.sigma_z_m}, s.found);
  if (predict) {
    sigmas({s.psigma_x_m, s.psigma_y_m, s.psigma_z_m}, (s.flags & kFlagHasPrediction) != 0);
  }
  for (const CameraCheck* c : {&s.omni_check, &s.persp_check}) {
    r += ",";
    r += std::to_string(static_cast<int>(c->state));
  }
  // As the packet carries it (centidegrees), so run and listen write the same.
  for (const CameraCheck* c : {&s.omni_check, &s.persp_check}) {
    const int cdeg = protocol::ChangeCentiDegrees(c->change_deg);
    char buf[16];
    std::snprintf(buf, sizeof buf, ",%d.%02d", cdeg / 100, cdeg % 100);
    r += buf;
  }
  return r + "\n";
}

std::string StatesCsvPose(bool known, float x_m, float y_m, float heading_rad) {
  if (!known) return ",,,";
  std::string r = ",";
  Append(r, "%.4f", x_m);
  r += ",";
  Append(r, "%.4f", y_m);
  r += ",";
  Append(r, "%.3f", heading_rad * 57.29577951308232);
  return r;
}

std::string CameraCheckText(const CameraCheck& check) {
  static constexpr const char* kFaults[kCameraFaultBits] = {"repeated",  "stale time", "dark",
                                                            "saturated", "flat",       "missing"};
  std::string t = CameraStateName(check.state);
  std::string why;
  for (int b = 0; b < kCameraFaultBits; ++b) {
    if (check.faults & (1u << b)) why += (why.empty() ? "" : ", ") + std::string(kFaults[b]);
  }
  return why.empty() ? t : t + " (" + why + ")";
}

std::string CameraCheckText(uint8_t byte) {
  CameraCheck c;
  c.state = static_cast<CameraState>(byte & 3u);
  c.faults = static_cast<uint8_t>(byte >> 2);
  return CameraCheckText(c);
}

}  // namespace bv::cli
