#include "tools/ballvision/demo_scene.h"

#include <algorithm>
#include <cmath>

#include "hal/host/sequence.h"

namespace bv::cli {
namespace {

constexpr double kG = 9.81;
constexpr float kBallR = 0.11f;
constexpr int kW = 640, kH = 480;

// Ideal single-viewpoint mirror (unified model): image radius of a ray at angle alpha from the
// downward axis. Scaled like the reference rig: 5 m -> ~175 px, horizon+5 deg -> ~229 px.
float MirrorRadiusPx(float alpha) { return 187.f * std::sin(alpha) / (0.9f + std::cos(alpha)); }

uint32_t Hash(uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352dU;
  x ^= x >> 15;
  x *= 0x846ca68bU;
  x ^= x >> 16;
  return x;
}

void FieldColor(float x, float y, uint8_t* rgb) {
  // Mowing stripes every 1 m plus a white line at y = 3 m and x = -1.5 m.
  const bool stripe = static_cast<int>(std::floor(y)) % 2 == 0;
  uint8_t r = 40, g = stripe ? 130 : 115, b = 45;
  if (std::fabs(y - 3.f) < 0.0625f || std::fabs(x + 1.5f) < 0.0625f) r = g = b = 225;
  rgb[0] = r;
  rgb[1] = g;
  rgb[2] = b;
}

}  // namespace

RigCalibration MakeDemoCalibration() {
  RigCalibration cal;
  cal.calibration_id = 0xDE30u;
  cal.ball_radius_m = kBallR;
  PerspCalibration& p = cal.persp;
  p.valid = true;
  p.fx = p.fy = 378.f;
  p.cx = 318.2f;
  p.cy = 242.6f;
  p.k1 = -0.28f;
  p.k2 = 0.09f;
  const float pitch = 8.f * 3.14159265f / 180.f;
  const float c = std::cos(pitch), s = std::sin(pitch);
  // Columns: camera x (right), y (down), z (forward) in the robot frame.
  p.R_robot_cam << 1, 0, 0, 0, s, c, 0, -c, s;
  p.t_robot_cam = Eigen::Vector3f(0.f, 0.15f, 0.45f);
  OmniCalibration& o = cal.omni;
  o.valid = true;
  o.center_u = 320.f;
  o.center_v = 240.f;
  o.viewpoint_z_m = 0.776f;
  o.image_angle_sign = 1;  // robot +y is image up, robot +x image left
  o.image_angle_offset_rad = 3.14159265f;
  const float edges[OmniCalibration::kEdges] = {0.4f, 0.6f, 0.8f, 1.0f, 1.5f, 2.0f,
                                                3.0f, 4.0f, 5.0f, 7.0f, 10.f, 20.f};
  for (int k = 0; k < OmniCalibration::kEdges; ++k) {
    o.edge_ground_m[k] = edges[k];
    const float r = MirrorRadiusPx(std::atan(edges[k] / o.viewpoint_z_m));
    for (int d = 0; d < OmniCalibration::kDirections; ++d) o.support_px[d][k] = r;
  }
  PrepareOmniAngles(o);
  return cal;
}

DemoRenderer::DemoRenderer(const RigCalibration& cal) : cal_(cal) {
  omni_bg_.assign(kW * kH * 3, 0);
  persp_bg_.assign(kW * kH * 3, 0);
  for (int v = 0; v < kH; ++v) {
    for (int u = 0; u < kW; ++u) {
      uint8_t* o = &omni_bg_[(v * kW + u) * 3];
      const float rr = std::hypot(u - cal.omni.center_u, v - cal.omni.center_v);
      float x, y;
      if (rr < 52.f) {
        o[0] = o[1] = o[2] = 30;  // own robot / mirror holder
      } else if (OmniPixelToGround(cal.omni, static_cast<float>(u), static_cast<float>(v), x, y)
                     .ok()) {
        FieldColor(x, y, o);
      } else if (rr < 229.f) {
        o[0] = 120;
        o[1] = 120;
        o[2] = 130;  // hall beyond the calibrated range
      }
      uint8_t* q = &persp_bg_[(v * kW + u) * 3];
      auto ray = PerspPixelToRay(cal.persp, static_cast<float>(u), static_cast<float>(v));
      if (ray.ok() && ray->dir.z() < -1e-3f) {
        const float t = -ray->origin.z() / ray->dir.z();
        const Eigen::Vector3f g = ray->origin + t * ray->dir;
        if (g.head<2>().norm() < 12.f) {
          FieldColor(g.x(), g.y(), q);
          continue;
        }
      }
      q[0] = 150;
      q[1] = 150;
      q[2] = 160;  // hall wall
    }
  }
}

void DemoRenderer::DrawBall(int cam, const Eigen::Vector3f& ball, std::vector<uint8_t>& rgb) const {
  float cu, cv;
  const bool seen = cam == 0 ? OmniProject(cal_.omni, ball, cu, cv).ok()
                             : PerspProject(cal_.persp, ball, cu, cv).ok();
  if (!seen) return;
  // Bounding radius: project points one ball radius away along each axis.
  float rad = 2.f;
  for (int a = 0; a < 3; ++a) {
    for (float sgn : {-1.f, 1.f}) {
      Eigen::Vector3f q = ball;
      q[a] += sgn * kBallR;
      float qu, qv;
      const bool ok = cam == 0 ? OmniProject(cal_.omni, q, qu, qv).ok()
                               : PerspProject(cal_.persp, q, qu, qv).ok();
      if (ok) rad = std::max(rad, std::hypot(qu - cu, qv - cv));
    }
  }
  rad = rad * 1.5f + 3.f;
  const int u0 = std::max(0, static_cast<int>(cu - rad)),
            u1 = std::min(kW - 1, static_cast<int>(cu + rad));
  const int v0 = std::max(0, static_cast<int>(cv - rad)),
            v1 = std::min(kH - 1, static_cast<int>(cv + rad));
  for (int v = v0; v <= v1; ++v) {
    for (int u = u0; u <= u1; ++u) {
      if (cam == 0 && std::hypot(u - cal_.omni.center_u, v - cal_.omni.center_v) < 52.f) continue;
      // 2x2 supersampling for a soft edge; shading from the surface normal.
      float cover = 0, shade = 0;
      for (int sy = 0; sy < 2; ++sy) {
        for (int sx = 0; sx < 2; ++sx) {
          const float fu = u - 0.25f + 0.5f * sx, fv = v - 0.25f + 0.5f * sy;
          auto ray =
              cam == 0 ? OmniPixelToRay(cal_.omni, fu, fv) : PerspPixelToRay(cal_.persp, fu, fv);
          if (!ray.ok()) continue;
          const Eigen::Vector3f d = ray->dir.normalized();
          const Eigen::Vector3f oc = ball - ray->origin;
          const float tc = oc.dot(d);
          const float d2 = oc.squaredNorm() - tc * tc;
          if (tc <= 0 || d2 > kBallR * kBallR) continue;
          const float th = std::sqrt(kBallR * kBallR - d2);
          const Eigen::Vector3f n = (ray->origin + (tc - th) * d - ball) / kBallR;
          cover += 0.25f;
          shade += 0.25f * (0.7f + 0.3f * std::max(0.f, n.z()));
        }
      }
      if (cover <= 0) continue;
      uint8_t* px = &rgb[(v * kW + u) * 3];
      const float k = shade / cover;
      const float ball_rgb[3] = {250.f * k, 105.f * k, 25.f * k};
      for (int ch = 0; ch < 3; ++ch) {
        px[ch] = static_cast<uint8_t>(std::lround(cover * ball_rgb[ch] + (1 - cover) * px[ch]));
      }
    }
  }
}

void DemoRenderer::Render(const Eigen::Vector3f& ball, uint32_t noise_seed,
                          std::vector<uint8_t>& omni_yuyv, std::vector<uint8_t>& persp_yuyv) const {
  Render(std::span<const Eigen::Vector3f>(&ball, 1), noise_seed, omni_yuyv, persp_yuyv);
}

void DemoRenderer::Render(std::span<const Eigen::Vector3f> balls, uint32_t noise_seed,
                          std::vector<uint8_t>& omni_yuyv, std::vector<uint8_t>& persp_yuyv) const {
  std::vector<uint8_t> rgb[2] = {omni_bg_, persp_bg_};
  for (int cam = 0; cam < 2; ++cam) {
    for (const Eigen::Vector3f& ball : balls) DrawBall(cam, ball, rgb[cam]);
  }
  if (noise_seed) {
    for (int cam = 0; cam < 2; ++cam) {
      for (size_t i = 0; i < rgb[cam].size(); ++i) {
        const int n = static_cast<int>(
                          Hash(noise_seed * 2654435761u + static_cast<uint32_t>(i) * 2 + cam) % 5) -
                      2;
        rgb[cam][i] = static_cast<uint8_t>(std::clamp(rgb[cam][i] + n, 0, 255));
      }
    }
  }
  omni_yuyv.resize(kW * kH * 2);
  persp_yuyv.resize(kW * kH * 2);
  host::RgbToYuyv(rgb[0].data(), kW, kH, omni_yuyv.data());
  host::RgbToYuyv(rgb[1].data(), kW, kH, persp_yuyv.data());
}

DemoTruth DemoLob(double t, double b, std::vector<double>* bounces) {
  // Kick: from (0.2, 5.5, r) with (-0.05, -1.9, 3.6) m/s.
  double x = 0.2, y = 5.5, z = kBallR, vx = -0.05, vy = -1.9, vz = 3.6;
  double ts = 0;
  if (bounces) bounces->clear();
  while (vz > 0.3) {
    const double s = 2 * vz / kG;  // arc from the floor back to the floor
    if (t < ts + s) {
      const double u = t - ts;
      return {Eigen::Vector3f(static_cast<float>(x + vx * u), static_cast<float>(y + vy * u),
                              static_cast<float>(z + vz * u - 0.5 * kG * u * u)),
              Eigen::Vector3f(static_cast<float>(vx), static_cast<float>(vy),
                              static_cast<float>(vz - kG * u))};
    }
    ts += s;
    x += vx * s;
    y += vy * s;
    vz *= b;
    if (bounces) bounces->push_back(ts);
  }
  const double u = t - ts;
  return {Eigen::Vector3f(static_cast<float>(x + vx * u), static_cast<float>(y + vy * u), kBallR),
          Eigen::Vector3f(static_cast<float>(vx), static_cast<float>(vy), 0.f)};
}

}  // namespace bv::cli
