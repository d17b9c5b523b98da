#include "tools/ballvision/annotate_frontend.h"

#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "hal/host/sequence.h"
#include "tools/ballvision/safe_write.h"

namespace bv {
namespace {

cv::Vec3b ClassColor(ColorClass c) {  // BGR
  switch (c) {
    case ColorClass::kBall:
      return {0, 90, 255};
    case ColorClass::kField:
      return {0, 160, 0};
    case ColorClass::kLine:
      return {255, 255, 255};
    case ColorClass::kObstacle:
      return {160, 40, 40};
    default:
      return {120, 120, 120};
  }
}

void DrawSelfMask(cv::Mat& out, const FieldOverlay& field, int scale) {
  const OmniSelfMask& m = *field.self_mask;
  const cv::Scalar orange(0, 140, 255);
  const auto at = [&](double deg, double r) {
    const double a = deg * M_PI / 180.0;
    return cv::Point(static_cast<int>((field.center_u + 0.5 + r * std::cos(a)) * scale),
                     static_cast<int>((field.center_v + 0.5 + r * std::sin(a)) * scale));
  };
  const cv::Point c = at(0, 0);
  cv::circle(out, c, static_cast<int>(m.inner_radius_px * scale), orange, 1);
  cv::circle(out, c, static_cast<int>(m.outer_radius_px * scale), orange, 1);
  for (int i = 0; i < m.sector_count; ++i) {
    for (float side : {-1.0f, 1.0f}) {
      const double deg = m.sectors[i].angle_deg + side * m.sectors[i].half_width_deg;
      cv::line(out, at(deg, m.inner_radius_px), at(deg, m.outer_radius_px), orange, 1);
    }
  }
  std::vector<cv::Point> body;
  for (int i = 0; i < OmniSelfMask::kOutlineDirections; ++i) {
    body.push_back(at((i + 0.5) * 360.0 / OmniSelfMask::kOutlineDirections, m.body_px[i]));
  }
  cv::polylines(out, body, true, orange, 1);
}

}  // namespace

bool AnnotateFrontEnd(const YuyvImage& image, const ColorLut& lut, const ScanlineTableBase& scan,
                      const BallFinder& finder, const Prediction* prediction,
                      const BallDetection& detection, const std::string& png_path,
                      std::string* error, int scale, const FieldOverlay* field) {
  if (!image.valid() || scale < 1) {
    if (error) *error = "AnnotateFrontEnd: invalid image or scale";
    return false;
  }
  // Dimmed grey background from Y.
  cv::Mat out(image.height, image.width, CV_8UC3);
  for (int v = 0; v < image.height; ++v) {
    for (int u = 0; u < image.width; ++u) {
      const uint8_t g = static_cast<uint8_t>(image.at(u, v).y / 3);
      out.at<cv::Vec3b>(v, u) = {g, g, g};
    }
  }
  ForEachScanPixel(scan, [&](int u, int v) {
    if (!image.contains(u, v)) return;
    const Yuv p = image.at(u, v);
    out.at<cv::Vec3b>(v, u) = ClassColor(lut.Classify(p.y, p.u, p.v));
  });
  if (scale > 1) cv::resize(out, out, cv::Size(), scale, scale, cv::INTER_NEAREST);
  const auto pt = [scale](float u, float v) {
    return cv::Point(static_cast<int>((u + 0.5f) * scale), static_cast<int>((v + 0.5f) * scale));
  };
  const RegionSetBase& rs = finder.regions();
  for (const Region& r : rs.regions()) {
    int u = r.start_u, v = r.start_v;
    const cv::Vec3b col = r.hole ? cv::Vec3b(255, 255, 0) : cv::Vec3b(0, 255, 255);
    const auto put = [&](int pu, int pv) {
      for (int dy = 0; dy < scale; ++dy)
        for (int dx = 0; dx < scale; ++dx) {
          const int x = pu * scale + dx, y = pv * scale + dy;
          if (x >= 0 && y >= 0 && x < out.cols && y < out.rows) out.at<cv::Vec3b>(y, x) = col;
        }
    };
    put(u, v);
    for (uint8_t c : rs.chain(r)) {
      u += kChainDu[c];
      v += kChainDv[c];
      put(u, v);
    }
  }
  for (int i = 0; i < finder.attention_count(); ++i) {
    cv::circle(out, pt(finder.attention_u(i), finder.attention_v(i)), std::max(1, scale / 2),
               cv::Scalar(255, 80, 0), cv::FILLED);
  }
  if (prediction != nullptr) {
    cv::circle(out, pt(prediction->u_px, prediction->v_px),
               static_cast<int>(prediction->sigma_px * scale), cv::Scalar(255, 0, 0), 1);
    cv::drawMarker(out, pt(prediction->u_px, prediction->v_px), cv::Scalar(255, 0, 0),
                   cv::MARKER_TILTED_CROSS, 6 * scale, 1);
  }
  if (field != nullptr && field->self_mask != nullptr && field->self_mask->known) {
    DrawSelfMask(out, *field, scale);
  }
  if (field != nullptr) {
    for (const auto& p : field->model) cv::circle(out, pt(p.u, p.v), 0, cv::Scalar(0, 200, 0), 1);
    for (const auto& p : field->line_points) {
      cv::circle(out, pt(p.u, p.v), std::max(1, scale), cv::Scalar(0, 255, 255), cv::FILLED);
    }
    for (const auto& o : field->obstacles) {
      cv::circle(out, pt(o.first.u, o.first.v), std::max(2, static_cast<int>(o.second * scale)),
                 cv::Scalar(0, 0, 255), 1);
      cv::drawMarker(out, pt(o.first.u, o.first.v), cv::Scalar(0, 0, 255), cv::MARKER_CROSS,
                     6 * scale, 1);
    }
    cv::putText(out, field->caption, cv::Point(6, out.rows - 8), cv::FONT_HERSHEY_SIMPLEX, 0.45,
                cv::Scalar(0, 255, 0), 1);
  }
  if (detection.found) {
    cv::circle(out, pt(detection.u_px, detection.v_px),
               static_cast<int>((detection.radius_px + 3) * scale), cv::Scalar(255, 0, 255), 2);
    cv::drawMarker(out, pt(detection.u_px, detection.v_px), cv::Scalar(255, 0, 255),
                   cv::MARKER_CROSS, 8 * scale, 1);
    char text[96];
    std::snprintf(text, sizeof(text), "ball (%.1f, %.1f) r %.1f round %.2f conf %.2f",
                  detection.u_px, detection.v_px, detection.radius_px, detection.roundness,
                  detection.confidence);
    cv::putText(out, text, cv::Point(6, 16), cv::FONT_HERSHEY_SIMPLEX, 0.45,
                cv::Scalar(255, 0, 255), 1);
  }
  std::vector<uint8_t> png;
  std::string e;
  if (!out.isContinuous() || out.type() != CV_8UC3) {
    if (error) *error = png_path + ": annotation is not a packed 8-bit BGR picture";
    return false;
  }
  if (!host::EncodePng(out.data, out.cols, out.rows, true, png, e)) {
    if (error) *error = png_path + ": " + e;
    return false;
  }
  if (!cli::WriteFileAtomic(png_path, png, e)) {
    if (error) *error = e;
    return false;
  }
  return true;
}

}  // namespace bv
