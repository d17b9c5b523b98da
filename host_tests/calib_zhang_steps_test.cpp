// The steps of Zhang's method (tools/ballvision/calib_zhang.h, namespace zhang) one by one, on
// a synthetic camera. The whole method against Zhang's and OpenCV's data:
// calibration_zhang_test.cpp.
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "tools/ballvision/calib_zhang.h"

namespace bv::cli::zhang {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector2d;
using Eigen::Vector3d;

ZhangResult TrueCamera(double k1 = 0, double k2 = 0) {
  ZhangResult m;
  m.fx = 520;
  m.fy = 515;
  m.cx = 322;
  m.cy = 241;
  m.k1 = k1;
  m.k2 = k2;
  return m;
}

// A 7x5 board (0.05 m squares) at pose (R, t), through the camera.
ZhangView Board(const std::string& name, const ZhangResult& cam, const Matrix3d& R,
                const Vector3d& t) {
  ZhangView view{name, {}, {}};
  for (int j = 0; j < 5; ++j) {
    for (int i = 0; i < 7; ++i) {
      Vector2d uv;
      EXPECT_TRUE(ZhangProject(cam, R, t, Vector3d(0.05 * i, 0.05 * j, 0), uv));
      view.board.emplace_back(0.05 * i, 0.05 * j);
      view.image.push_back(uv);
    }
  }
  return view;
}

// Five tilted poses about 0.6 m away.
std::vector<ZhangView> Views(const ZhangResult& cam, std::vector<Matrix3d>* R_out = nullptr,
                             std::vector<Vector3d>* t_out = nullptr) {
  const double tilts[5][2] = {{0.3, 0.1}, {-0.35, 0.2}, {0.1, -0.4}, {-0.2, -0.25}, {0.4, 0.35}};
  std::vector<ZhangView> views;
  for (int v = 0; v < 5; ++v) {
    const Matrix3d R = (Eigen::AngleAxisd(tilts[v][0], Vector3d::UnitX()) *
                        Eigen::AngleAxisd(tilts[v][1], Vector3d::UnitY()) *
                        Eigen::AngleAxisd(0.1 * v, Vector3d::UnitZ()))
                           .toRotationMatrix();
    const Vector3d t(-0.15 + 0.02 * v, -0.1, 0.6 + 0.05 * v);
    views.push_back(Board(std::string(1, 'v').append(std::to_string(v)), cam, R, t));
    if (R_out) R_out->push_back(R);
    if (t_out) t_out->push_back(t);
  }
  return views;
}

TEST(ZhangSteps, CheckViewsNamesWhatIsWrong) {
  std::vector<ZhangView> views = Views(TrueCamera());
  size_t total = 0;
  std::string error;
  ASSERT_TRUE(CheckViews(views, total, error)) << error;
  EXPECT_EQ(total, 5u * 35u);
  const std::vector<ZhangView> two(views.begin(), views.begin() + 2);
  EXPECT_FALSE(CheckViews(two, total, error));
  EXPECT_EQ(error, "need at least 3 views of the board, got 2");
  views[1].image.resize(5);
  views[1].board.resize(5);
  EXPECT_FALSE(CheckViews(views, total, error));
  EXPECT_EQ(error, "view v1: need at least 6 corners (got 5)");
  views = Views(TrueCamera());
  views[2].image[7].x() = NAN;
  EXPECT_FALSE(CheckViews(views, total, error));
  EXPECT_EQ(error, "view v2: non-finite corner 7");
}

TEST(ZhangSteps, HomographiesMapTheBoardOntoTheImage) {
  const std::vector<ZhangView> views = Views(TrueCamera());
  std::vector<Matrix3d> Hs;
  std::string error;
  ASSERT_TRUE(Homographies(views, Hs, error)) << error;
  ASSERT_EQ(Hs.size(), views.size());
  for (size_t v = 0; v < views.size(); ++v) {
    EXPECT_DOUBLE_EQ(Hs[v](2, 2), 1.0);
    for (size_t k = 0; k < views[v].board.size(); ++k) {
      const Vector3d p = Hs[v] * views[v].board[k].homogeneous();
      EXPECT_NEAR((p.hnormalized() - views[v].image[k]).norm(), 0, 1e-6);
    }
  }
}

TEST(ZhangSteps, ClosedFormIntrinsicsAndExtrinsicsWithoutDistortion) {
  const ZhangResult cam = TrueCamera();
  std::vector<Matrix3d> R_true;
  std::vector<Vector3d> t_true;
  const std::vector<ZhangView> views = Views(cam, &R_true, &t_true);
  std::vector<Matrix3d> Hs;
  std::string error;
  ASSERT_TRUE(Homographies(views, Hs, error));
  Intrinsics in;
  ASSERT_TRUE(ClosedFormIntrinsics(Hs, false, in, error)) << error;
  EXPECT_NEAR(in.fx, cam.fx, 1e-4);
  EXPECT_NEAR(in.fy, cam.fy, 1e-4);
  EXPECT_NEAR(in.cx, cam.cx, 1e-4);
  EXPECT_NEAR(in.cy, cam.cy, 1e-4);
  EXPECT_EQ(in.skew, 0);
  Intrinsics with_skew;
  ASSERT_TRUE(ClosedFormIntrinsics(Hs, true, with_skew, error)) << error;
  EXPECT_NEAR(with_skew.skew, 0, 1e-4);

  std::vector<Matrix3d> R;
  std::vector<Vector3d> t;
  Extrinsics(Hs, in, R, t);
  ASSERT_EQ(R.size(), views.size());
  for (size_t v = 0; v < views.size(); ++v) {
    EXPECT_NEAR((R[v] - R_true[v]).norm(), 0, 1e-6) << v;
    EXPECT_NEAR((t[v] - t_true[v]).norm(), 0, 1e-6) << v;
  }
  // Undistorted corners: the linear fit finds no distortion.
  const Eigen::Vector2d k = LinearDistortion(views, in, R, t);
  EXPECT_NEAR(k[0], 0, 1e-6);
  EXPECT_NEAR(k[1], 0, 1e-6);
}

TEST(ZhangSteps, ParallelBoardsAreDegenerate) {
  // One board orientation at three distances: every view gives the same two constraints.
  const ZhangResult cam = TrueCamera();
  const Matrix3d R = Eigen::AngleAxisd(0.3, Vector3d::UnitX()).toRotationMatrix();
  std::vector<ZhangView> views;
  for (int v = 0; v < 3; ++v) {
    views.push_back(Board(std::string(1, 'p').append(std::to_string(v)), cam, R,
                          Vector3d(-0.1 + 0.05 * v, -0.1, 0.6 + 0.2 * v)));
  }
  std::vector<Matrix3d> Hs;
  std::string error;
  ASSERT_TRUE(Homographies(views, Hs, error));
  Intrinsics in;
  EXPECT_FALSE(ClosedFormIntrinsics(Hs, false, in, error));
  EXPECT_NE(error.find("degenerate set of board poses"), std::string::npos) << error;
}

TEST(ZhangSteps, LinearDistortionRecoversK1K2AtTheTruePose) {
  const ZhangResult cam = TrueCamera(-0.25, 0.08);
  std::vector<Matrix3d> R;
  std::vector<Vector3d> t;
  const std::vector<ZhangView> views = Views(cam, &R, &t);
  const Intrinsics in{cam.fx, cam.fy, cam.cx, cam.cy, 0};
  const Eigen::Vector2d k = LinearDistortion(views, in, R, t);
  EXPECT_NEAR(k[0], -0.25, 1e-6);
  EXPECT_NEAR(k[1], 0.08, 1e-6);
}

TEST(ZhangSteps, RefineConvergesFromAPerturbedStart) {
  const ZhangResult cam = TrueCamera(-0.25, 0.08);
  std::vector<Matrix3d> R_true;
  std::vector<Vector3d> t_true;
  const std::vector<ZhangView> views = Views(cam, &R_true, &t_true);
  ZhangResult m = cam;
  m.fx += 12;
  m.cy -= 6;
  m.k1 = -0.1;
  m.k2 = 0;
  m.R = R_true;
  m.t = t_true;
  for (auto& t : m.t) t.z() += 0.02;
  std::string error;
  ASSERT_TRUE(Refine(views, ZhangOptions{}, m, error)) << error;
  EXPECT_NEAR(m.fx, cam.fx, 1e-3);
  EXPECT_NEAR(m.fy, cam.fy, 1e-3);
  EXPECT_NEAR(m.cy, cam.cy, 1e-3);
  EXPECT_NEAR(m.k1, cam.k1, 1e-5);
  EXPECT_NEAR(m.k2, cam.k2, 1e-4);
  EXPECT_LT(m.rms_px, 1e-6);
  ASSERT_EQ(m.rms_per_view_px.size(), views.size());
  EXPECT_GT(m.iterations, 0);
  EXPECT_NEAR((m.t[3] - t_true[3]).norm(), 0, 1e-6);
}

TEST(ZhangSteps, TheWholeMethodIsTheStepsInOrder) {
  const ZhangResult cam = TrueCamera(-0.2, 0.05);
  const std::vector<ZhangView> views = Views(cam);
  ZhangResult r;
  std::string error;
  ASSERT_TRUE(ZhangCalibrate(views, ZhangOptions{}, r, error)) << error;
  EXPECT_NEAR(r.fx, cam.fx, 1e-3);
  EXPECT_NEAR(r.cx, cam.cx, 1e-3);
  EXPECT_NEAR(r.k1, cam.k1, 1e-5);
  // The closed-form estimate (distortion ignored) is kept for the report.
  EXPECT_NE(r.init_fx, r.fx);
  EXPECT_NEAR(r.init_fx, cam.fx, 0.05 * cam.fx);
}

}  // namespace
}  // namespace bv::cli::zhang
