#pragma once
// The OpenCV full-frame reference the benches compare with: the same job on the whole frame
// (YUYV->BGR->HSV, inRange, findContours, moments, the roundest large contour).
#include <cmath>
#include <cstdint>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "core/common/image.h"

namespace bv::bench {

struct CvResult {
  bool found = false;
  double u = 0, v = 0;
};

// Buffers kept by the caller: allocated once, as a tuned OpenCV loop would.
inline CvResult OpenCvFind(const std::vector<uint8_t>& yuyv, cv::Mat& bgr, cv::Mat& hsv,
                           cv::Mat& mask, int width = kFrameWidth, int height = kFrameHeight) {
  cv::Mat src(height, width, CV_8UC2, const_cast<uint8_t*>(yuyv.data()));
  cv::cvtColor(src, bgr, cv::COLOR_YUV2BGR_YUYV);
  cv::cvtColor(bgr, hsv, cv::COLOR_BGR2HSV);
  // Orange-red ball: hue wraps around 0 (OpenCV hue 0..180).
  cv::Mat m2;
  cv::inRange(hsv, cv::Scalar(0, 120, 60), cv::Scalar(14, 255, 255), mask);
  cv::inRange(hsv, cv::Scalar(172, 120, 60), cv::Scalar(180, 255, 255), m2);
  mask |= m2;
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(mask, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  CvResult best;
  double best_key = 0;
  for (const auto& c : contours) {
    const cv::Moments m = cv::moments(c);
    if (m.m00 < 10) continue;
    const double p = cv::arcLength(c, true);
    const double round = 4 * M_PI * m.m00 / (p * p);
    if (round < 0.35) continue;
    const double key = m.m00 * round;
    if (key > best_key) {
      best_key = key;
      best = {true, m.m10 / m.m00, m.m01 / m.m00};
    }
  }
  return best;
}

}  // namespace bv::bench
