#include "tools/ballvision/run_common.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/color_lut/color_model.h"
#include "hal/host/sequence.h"
#include "tools/ballvision/calib_io.h"
#include "tools/ballvision/safe_write.h"

namespace bv::cli {

void FillBuiltInLut(ColorLut& lut) {
  // The default model is valid by construction (host_tests check it).
  BuildLut(BallColorModel{}, lut).IgnoreError();
}

bool LoadLutOrDefault(const std::string& path, const std::string& calib_path, ColorLut& lut,
                      std::string& used, std::string& error) {
  namespace fs = std::filesystem;
  std::string file = path;
  if (file.empty()) {
    if (const char* env = std::getenv("BV_LUT"); env && *env) file = env;
  }
  if (file.empty() && !calib_path.empty()) {
    const fs::path dir = fs::path(calib_path).parent_path() / "luts";
    std::error_code ec;
    if (fs::is_directory(dir, ec)) {
      std::vector<fs::path> found;
      for (const auto& e : fs::directory_iterator(dir, ec)) {
        const std::string ext = e.path().extension().string();
        if (ext == ".lut" || ext == ".bin") found.push_back(e.path());
      }
      std::sort(found.begin(), found.end());
      // Prefer a LUT named for the rendered (sim) data.
      for (const auto& f : found) {
        if (f.filename().string().find("sim") != std::string::npos) {
          file = f.string();
          break;
        }
      }
      if (file.empty() && !found.empty()) file = found.front().string();
    }
  }
  if (file == "builtin") {
    FillBuiltInLut(lut);
    used = "built-in colour model (--lut builtin)";
    return true;
  }
  if (file.empty()) {
    FillBuiltInLut(lut);
    used = "built-in colour model (no --lut, no $BV_LUT, no <calib dir>/luts/*.lut)";
    return true;
  }
  std::vector<uint8_t> bytes;
  if (!ReadFileBytes(file, bytes, error)) return false;
  const Status st = ParseLut(bytes, lut);
  if (!st.ok()) {
    error = file + ": " + st.message();
    return false;
  }
  used = file;
  return true;
}

namespace {

double NiceStep(double range, int target) {
  const double raw = range / std::max(target, 1);
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 2.5, 5.0, 10.0}) {
    if (m * mag >= raw) return m * mag;
  }
  return 10 * mag;
}

std::string Fmt(double v, double step) {
  char buf[32];
  const int dec = step >= 1 ? 0 : static_cast<int>(std::ceil(-std::log10(step) - 1e-9));
  std::snprintf(buf, sizeof buf, "%.*f", dec, v);
  return buf;
}

}  // namespace

bool PlotPng(const std::string& path, const std::string& title, const std::string& xlabel,
             const std::string& ylabel, const std::vector<PlotSeries>& series, std::string& error,
             double y_min, double y_max) {
  const int W = 900, H = 560, L = 90, R = 30, T = 50, B = 70;
  cv::Mat img(H, W, CV_8UC3, cv::Scalar(255, 255, 255));
  double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
  for (const auto& s : series) {
    for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      x0 = std::min(x0, s.x[i]);
      x1 = std::max(x1, s.x[i]);
      y0 = std::min(y0, s.y[i]);
      y1 = std::max(y1, s.y[i]);
    }
  }
  if (x0 > x1) {
    x0 = 0;
    x1 = 1;
    y0 = 0;
    y1 = 1;
  }
  if (y_max > y_min) {
    y0 = y_min;
    y1 = y_max;
  }
  if (x1 - x0 < 1e-9) x1 = x0 + 1;
  if (y1 - y0 < 1e-9) y1 = y0 + 1;
  const double xs = NiceStep(x1 - x0, 8), ys = NiceStep(y1 - y0, 6);
  x0 = std::floor(x0 / xs) * xs;
  x1 = std::ceil(x1 / xs) * xs;
  y0 = std::floor(y0 / ys) * ys;
  y1 = std::ceil(y1 / ys) * ys;
  auto px = [&](double x) { return L + (x - x0) / (x1 - x0) * (W - L - R); };
  auto py = [&](double y) { return H - B - (y - y0) / (y1 - y0) * (H - T - B); };
  const cv::Scalar grid(225, 225, 225), black(0, 0, 0);
  for (double x = x0; x <= x1 + 1e-9; x += xs) {
    const int u = static_cast<int>(std::lround(px(x)));
    cv::line(img, {u, T}, {u, H - B}, grid, 1);
    cv::putText(img, Fmt(x, xs), {u - 12, H - B + 20}, cv::FONT_HERSHEY_SIMPLEX, 0.45, black, 1,
                cv::LINE_AA);
  }
  for (double y = y0; y <= y1 + 1e-9; y += ys) {
    const int v = static_cast<int>(std::lround(py(y)));
    cv::line(img, {L, v}, {W - R, v}, grid, 1);
    cv::putText(img, Fmt(y, ys), {8, v + 5}, cv::FONT_HERSHEY_SIMPLEX, 0.45, black, 1, cv::LINE_AA);
  }
  cv::rectangle(img, {L, T}, {W - R, H - B}, black, 1);
  cv::putText(img, title, {L, 24}, cv::FONT_HERSHEY_SIMPLEX, 0.65, black, 1, cv::LINE_AA);
  cv::putText(img, xlabel, {W / 2 - 60, H - 22}, cv::FONT_HERSHEY_SIMPLEX, 0.55, black, 1,
              cv::LINE_AA);
  cv::putText(img, ylabel, {8, T - 4}, cv::FONT_HERSHEY_SIMPLEX, 0.5, black, 1, cv::LINE_AA);
  cv::Mat plot_area = img(cv::Rect(L, T, W - L - R, H - T - B));
  int legend_y = T + 20;
  for (const auto& s : series) {
    const cv::Scalar c(s.b, s.g, s.r);
    std::vector<cv::Point> pts;
    for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) {
        pts.push_back({-100000, -100000});  // break marker
        continue;
      }
      pts.push_back({static_cast<int>(std::lround(px(s.x[i]))) - L,
                     static_cast<int>(std::lround(py(s.y[i]))) - T});
    }
    for (size_t i = 0; i < pts.size(); ++i) {
      const bool ok = pts[i].x > -50000;
      if (ok && (s.style == PlotSeries::kPoints || s.style == PlotSeries::kLinePoints)) {
        cv::circle(plot_area, pts[i], 3, c, cv::FILLED, cv::LINE_AA);
      }
      if (i == 0 || !ok || pts[i - 1].x < -50000) continue;
      if (s.style == PlotSeries::kLine || s.style == PlotSeries::kLinePoints) {
        cv::line(plot_area, pts[i - 1], pts[i], c, 2, cv::LINE_AA);
      } else if (s.style == PlotSeries::kDashed) {
        // 8 px on, 6 px off along the segment.
        const cv::Point2d a(pts[i - 1]), b(pts[i]);
        const double len = std::hypot(b.x - a.x, b.y - a.y);
        for (double d = 0; d < len; d += 14) {
          const double e = std::min(d + 8, len);
          cv::line(plot_area, a + (b - a) * (d / len), a + (b - a) * (e / len), c, 2, cv::LINE_AA);
        }
      }
    }
    cv::line(img, {W - R - 230, legend_y - 5}, {W - R - 200, legend_y - 5}, c, 2, cv::LINE_AA);
    cv::putText(img, s.name, {W - R - 192, legend_y}, cv::FONT_HERSHEY_SIMPLEX, 0.45, black, 1,
                cv::LINE_AA);
    legend_y += 20;
  }
  try {
    std::vector<uchar> png;
    if (!cv::imencode(".png", img, png)) {
      error = path + ": PNG encoding failed";
      return false;
    }
    if (!WriteFileAtomic(path, png, error)) return false;
  } catch (const cv::Exception& e) {
    error = path + ": " + e.what();
    return false;
  }
  return true;
}

}  // namespace bv::cli
