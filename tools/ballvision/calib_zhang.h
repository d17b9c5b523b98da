#pragma once
// Zhang's planar calibration (Z. Zhang, "A flexible new technique for camera calibration",
// 1998/2000): per-view homographies (normalised DLT) -> closed-form intrinsics from the
// absolute-conic constraints -> extrinsics -> linear radial distortion (k1, k2) -> joint
// Levenberg-Marquardt refinement of everything (Eigen, double). Host only.
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace bv::cli {

struct ZhangView {
  std::string name;
  std::vector<Eigen::Vector2d> board;  // board-plane points (Z = 0)
  std::vector<Eigen::Vector2d> image;  // distorted pixels, same order
};

struct ZhangOptions {
  bool skew = false;  // estimate Zhang's skew term gamma (else fixed 0)
  int max_iterations = 200;
};

struct ZhangResult {
  double fx = 0, fy = 0, cx = 0, cy = 0, skew = 0, k1 = 0, k2 = 0;
  std::vector<Eigen::Matrix3d> R;  // p_cam = R p_board + t, per view
  std::vector<Eigen::Vector3d> t;
  std::vector<double> rms_per_view_px;
  double rms_px = 0;  // sqrt(mean over points of du² + dv²), as OpenCV reports it
  int iterations = 0;
  // Closed-form initial estimate (before LM), for the report.
  double init_fx = 0, init_fy = 0, init_cx = 0, init_cy = 0, init_skew = 0;
};

/// Projects a board point with the given model. Returns false if behind the camera.
bool ZhangProject(const ZhangResult& m, const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
                  const Eigen::Vector3d& p, Eigen::Vector2d& uv);

/// Errors (false + message): fewer than 3 views, fewer than 6 points in a view, non-finite
/// input, degenerate poses (e.g. all boards parallel), no convergence.
bool ZhangCalibrate(const std::vector<ZhangView>& views, const ZhangOptions& options,
                    ZhangResult& result, std::string& error);

/// The steps of ZhangCalibrate, in order (each tested on its own in calib_zhang_steps_test.cpp).
namespace zhang {
/// At least 3 views of at least 6 finite corners each; `total` counts the corners.
bool CheckViews(const std::vector<ZhangView>& views, size_t& total, std::string& error);
/// 1. Board -> image homography per view (normalised DLT), scaled to H(2,2) = 1.
bool Homographies(const std::vector<ZhangView>& views, std::vector<Eigen::Matrix3d>& Hs,
                  std::string& error);
/// 2. Closed-form intrinsics from the absolute-conic constraints (skew 0 unless `skew`).
struct Intrinsics {
  double fx = 0, fy = 0, cx = 0, cy = 0, skew = 0;
};
bool ClosedFormIntrinsics(const std::vector<Eigen::Matrix3d>& Hs, bool skew, Intrinsics& out,
                          std::string& error);
/// 3. Per view p_cam = R p_board + t (board in front of the camera, R the nearest rotation).
void Extrinsics(const std::vector<Eigen::Matrix3d>& Hs, const Intrinsics& in,
                std::vector<Eigen::Matrix3d>& R, std::vector<Eigen::Vector3d>& t);
/// 4. k1, k2 by linear least squares with the poses and intrinsics fixed.
Eigen::Vector2d LinearDistortion(const std::vector<ZhangView>& views, const Intrinsics& in,
                                 const std::vector<Eigen::Matrix3d>& R,
                                 const std::vector<Eigen::Vector3d>& t);
/// 5. Levenberg-Marquardt over everything from `m` (intrinsics, k1, k2, R, t); fills the rms.
bool Refine(const std::vector<ZhangView>& views, const ZhangOptions& options, ZhangResult& m,
            std::string& error);
}  // namespace zhang

/// The rig pose of the camera (p_robot = R_rc p_cam + t_rc) from views whose board pose in the
/// robot frame is known (p_robot = Rb p_board + tb): closed-form average, then LM on the
/// reprojection error of those views with the intrinsics fixed.
struct BoardPose {
  int view = -1;
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
};
bool EstimateRigPose(const std::vector<ZhangView>& views, const ZhangResult& model,
                     const std::vector<BoardPose>& poses, Eigen::Matrix3d& R_rc,
                     Eigen::Vector3d& t_rc, double& rms_px, std::string& error);

}  // namespace bv::cli
