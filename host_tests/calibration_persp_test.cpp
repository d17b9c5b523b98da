// Perspective device model (core/calibration) against OpenCV's projectPoints/undistortPoints.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include "core/calibration/calibration.h"

namespace bv {
namespace {

// The reference rig's perspective camera (render/README.md): strong barrel distortion.
PerspCalibration WideAngle() {
  PerspCalibration c;
  c.valid = true;
  c.fx = 378.0f;
  c.fy = 378.0f;
  c.cx = 318.2f;
  c.cy = 242.6f;
  c.k1 = -0.28f;
  c.k2 = 0.09f;
  const float pitch = 8.0f * 3.14159265f / 180.0f;
  // camera x right, y down, z forward; pitched up about robot +x.
  c.R_robot_cam << 1, 0, 0, 0, std::sin(pitch), std::cos(pitch), 0, -std::cos(pitch),
      std::sin(pitch);
  c.t_robot_cam = Eigen::Vector3f(0.0f, 0.15f, 0.45f);
  return c;
}

PerspCalibration OpenCvLeft() {  // OpenCV's left chessboard camera, k1 k2 only
  PerspCalibration c;
  c.valid = true;
  c.fx = 533.0664f;
  c.fy = 533.4227f;
  c.cx = 342.4127f;
  c.cy = 233.2484f;
  c.k1 = -0.291336f;
  c.k2 = 0.108291f;
  return c;
}

cv::Mat K(const PerspCalibration& c) {
  return (cv::Mat_<double>(3, 3) << c.fx, c.skew, c.cx, 0, c.fy, c.cy, 0, 0, 1);
}
cv::Mat Dist(const PerspCalibration& c) { return (cv::Mat_<double>(1, 5) << c.k1, c.k2, 0, 0, 0); }

std::vector<cv::Point2f> Grid(const PerspCalibration& c) {
  std::vector<cv::Point2f> g;
  for (int v = 0; v <= c.height_px - 1; v += 8)
    for (int u = 0; u <= c.width_px - 1; u += 8) g.emplace_back(float(u), float(v));
  for (float u : {0.0f, 639.0f})
    for (float v : {0.0f, 479.0f}) g.emplace_back(u, v);  // the corners
  return g;
}

void CheckAgainstOpenCv(const PerspCalibration& c) {
  const std::vector<cv::Point2f> grid = Grid(c);
  // OpenCV, iterated to convergence (its default of 5 iterations is not enough here).
  std::vector<cv::Point2f> und;
  cv::undistortPoints(
      grid, und, K(c), Dist(c), cv::noArray(), cv::noArray(),
      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 200, 1e-12));
  double max_und_px = 0, max_round_px = 0, max_proj_px = 0;
  std::vector<cv::Point3f> cam_pts;
  for (size_t i = 0; i < grid.size(); ++i) {
    const Result<Ray> ray = PerspPixelToRay(c, grid[i].x, grid[i].y);
    ASSERT_TRUE(ray.ok()) << grid[i] << ": " << ray.status().message();
    EXPECT_NEAR(ray->dir.norm(), 1.0f, 1e-5f);
    EXPECT_LT((ray->origin - c.t_robot_cam).norm(), 1e-6f);
    const Eigen::Vector3f d_cam = c.R_robot_cam.transpose() * ray->dir;
    const double x = d_cam.x() / d_cam.z(), y = d_cam.y() / d_cam.z();
    // Undistorted position in pixels of the ideal pinhole, ours vs OpenCV.
    max_und_px = std::max(max_und_px, std::hypot((x - und[i].x) * c.fx, (y - und[i].y) * c.fy));
    // Round trip through our projection.
    const Eigen::Vector3f p = ray->origin + 2.0f * ray->dir;
    float u = 0, v = 0;
    ASSERT_TRUE(PerspProject(c, p, u, v).ok());
    max_round_px = std::max(max_round_px, double(std::hypot(u - grid[i].x, v - grid[i].y)));
    cam_pts.emplace_back(float(x * 2.5), float(y * 2.5), 2.5f);
  }
  // Our projection vs cv::projectPoints of the same camera-frame points.
  std::vector<cv::Point2f> proj;
  cv::projectPoints(cam_pts, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K(c), Dist(c), proj);
  for (size_t i = 0; i < cam_pts.size(); ++i) {
    const Eigen::Vector3f pc(cam_pts[i].x, cam_pts[i].y, cam_pts[i].z);
    const Eigen::Vector3f pr = c.R_robot_cam * pc + c.t_robot_cam;
    float u = 0, v = 0;
    ASSERT_TRUE(PerspProject(c, pr, u, v).ok());
    max_proj_px = std::max(max_proj_px, double(std::hypot(u - proj[i].x, v - proj[i].y)));
  }
  std::printf(
      "grid %zu points: undistort vs OpenCV max %.5f px, project vs OpenCV max %.5f px, "
      "round trip max %.5f px\n",
      grid.size(), max_und_px, max_proj_px, max_round_px);
  EXPECT_LE(max_und_px, 0.01);
  EXPECT_LE(max_proj_px, 0.01);
  EXPECT_LE(max_round_px, 0.01);
}

TEST(PerspModel, WideAngleMatchesOpenCv) { CheckAgainstOpenCv(WideAngle()); }
TEST(PerspModel, OpenCvLeftCameraMatchesOpenCv) { CheckAgainstOpenCv(OpenCvLeft()); }

TEST(PerspModel, SkewRoundTrip) {
  PerspCalibration c = OpenCvLeft();
  c.skew = 0.2045f;
  for (float u = 0; u < 640; u += 37) {
    for (float v = 0; v < 480; v += 29) {
      const Result<Ray> ray = PerspPixelToRay(c, u, v);
      ASSERT_TRUE(ray.ok());
      float pu = 0, pv = 0;
      ASSERT_TRUE(PerspProject(c, ray->origin + ray->dir, pu, pv).ok());
      EXPECT_NEAR(pu, u, 0.01f);
      EXPECT_NEAR(pv, v, 0.01f);
    }
  }
}

TEST(PerspModel, Errors) {
  PerspCalibration c = WideAngle();
  EXPECT_EQ(PerspPixelToRay(c, NAN, 1).status().code(), StatusCode::kInvalidArgument);
  float u = 0, v = 0;
  // Behind the camera (it looks along +y).
  EXPECT_EQ(PerspProject(c, Eigen::Vector3f(0, -1, 0.45f), u, v).code(), StatusCode::kOutOfRange);
  EXPECT_EQ(PerspProject(c, Eigen::Vector3f(NAN, 1, 0), u, v).code(), StatusCode::kInvalidArgument);
  // Far outside the image the radial model folds over: refused, not a wrong ray.
  EXPECT_EQ(PerspPixelToRay(c, 5000, 5000).status().code(), StatusCode::kOutOfRange);
  c.valid = false;
  EXPECT_EQ(PerspPixelToRay(c, 10, 10).status().code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(PerspProject(c, Eigen::Vector3f(0, 2, 0.45f), u, v).code(),
            StatusCode::kFailedPrecondition);
}

TEST(PerspModel, PrincipalPointLooksAlongTheOpticalAxis) {
  const PerspCalibration c = WideAngle();
  const Result<Ray> ray = PerspPixelToRay(c, c.cx, c.cy);
  ASSERT_TRUE(ray.ok());
  EXPECT_LT((ray->dir - c.R_robot_cam.col(2)).norm(), 1e-6f);
}

}  // namespace
}  // namespace bv
