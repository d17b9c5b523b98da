// `ballvision calibrate persp` (our Zhang implementation) on published data sets and the
// rendered reference rig; bad input.
#include <unistd.h>
#include <cmath>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "tools/ballvision/calib_zhang.h"
#include "tools/ballvision/commands.h"

namespace bv::cli {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

const std::string kData = BV_SHARED_DATA_DIR;

std::string TempPath(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("bv_calib_zhang_" + std::to_string(::getpid()));
  static const struct Cleanup {
    fs::path p;
    ~Cleanup() {
      std::error_code ec;
      fs::remove_all(p, ec);
    }
  } cleanup{dir};
  fs::create_directories(dir);
  return (dir / name).string();
}

int RunCli(std::vector<std::string> args) {
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  return CmdCalibrate(static_cast<int>(argv.size()), argv.data());
}

json ReadJson(const std::string& path) {
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  return json::parse(ss.str());
}

#define REQUIRE_DATA(path) \
  if (!fs::exists(path)) GTEST_SKIP() << "shared data missing: " << (path)

TEST(Zhang, ReproducesZhangsPublishedResultWithSkew) {
  REQUIRE_DATA(kData + "/zhang_msr/corners.csv");
  const std::string out = TempPath("zhang.json");
  fs::remove(out);
  ASSERT_EQ(RunCli({"calibrate", "persp", "--corners", kData + "/zhang_msr/corners.csv", "--skew",
                    "--size", "640x480", "--out", out}),
            0);
  const json p = ReadJson(out)["persp"];
  // Zhang's result file: alpha gamma beta u0 v0 / k1 k2.
  const struct {
    const char* key;
    double published;
  } kRef[] = {{"fx", 832.5},   {"fy", 832.53},    {"skew", 0.204494}, {"cx", 303.959},
              {"cy", 206.585}, {"k1", -0.228601}, {"k2", 0.190353}};
  for (const auto& r : kRef) {
    const double got = p[r.key].get<double>();
    std::printf("%-4s ours %.6f  Zhang %.6f  rel diff %.4f %%\n", r.key, got, r.published,
                100 * std::fabs(got / r.published - 1));
    EXPECT_LE(std::fabs(got / r.published - 1), 0.001) << r.key;
  }
}

TEST(Zhang, ReproducesOpenCvReferenceFromCorners) {
  REQUIRE_DATA(kData + "/opencv_chessboard/corners_left.csv");
  const std::string out = TempPath("ocv.json");
  fs::remove(out);
  ASSERT_EQ(RunCli({"calibrate", "persp", "--corners",
                    kData + "/opencv_chessboard/corners_left.csv", "--out", out}),
            0);
  const json p = ReadJson(out)["persp"];
  std::printf("corners: rms %.5f (ref 0.20513) fx %.4f (533.0664) fy %.4f (533.4227)\n",
              p["rms_px"].get<double>(), p["fx"].get<double>(), p["fy"].get<double>());
  EXPECT_NEAR(p["rms_px"].get<double>(), 0.205130, 0.01);
  EXPECT_NEAR(p["fx"].get<double>(), 533.0664, 0.5);
  EXPECT_NEAR(p["fy"].get<double>(), 533.4227, 0.5);
  EXPECT_NEAR(p["k1"].get<double>(), -0.291336, 0.002);
  EXPECT_NEAR(p["k2"].get<double>(), 0.108291, 0.005);
  EXPECT_DOUBLE_EQ(p["skew"].get<double>(), 0.0);
}

TEST(Zhang, ReproducesOpenCvReferenceFromImages) {
  REQUIRE_DATA(kData + "/opencv_chessboard/left01.jpg");
  const std::string out = TempPath("ocv_img.json");
  fs::remove(out);
  ASSERT_EQ(RunCli({"calibrate", "persp", "--images", kData + "/opencv_chessboard", "--prefix",
                    "left", "--board", "9x6", "--square", "1", "--out", out}),
            0);
  const json p = ReadJson(out)["persp"];
  EXPECT_EQ(p["views"].get<int>(), 13);
  std::printf("images: rms %.5f (ref 0.20513) fx %.4f fy %.4f\n", p["rms_px"].get<double>(),
              p["fx"].get<double>(), p["fy"].get<double>());
  EXPECT_NEAR(p["rms_px"].get<double>(), 0.205130, 0.01);
  EXPECT_NEAR(p["fx"].get<double>(), 533.07, 1.0);
  EXPECT_NEAR(p["fy"].get<double>(), 533.42, 1.0);
}

std::vector<ZhangView> LoadSimCorners() {
  std::vector<ZhangView> views;
  std::ifstream f(kData + "/sim/calib_persp/corners.csv");
  std::string line;
  std::getline(f, line);
  while (std::getline(f, line)) {
    std::stringstream ss(line);
    std::string name, idx, X, Y, u, v, in;
    std::getline(ss, name, ',');
    std::getline(ss, idx, ',');
    std::getline(ss, X, ',');
    std::getline(ss, Y, ',');
    std::getline(ss, u, ',');
    std::getline(ss, v, ',');
    std::getline(ss, in, ',');
    if (in.rfind("1", 0) != 0) continue;
    if (views.empty() || views.back().name != name) views.push_back({name, {}, {}});
    views.back().board.emplace_back(std::stod(X), std::stod(Y));
    views.back().image.emplace_back(std::stod(u), std::stod(v));
  }
  return views;
}

TEST(Zhang, AgreesWithCvCalibrateCameraOnNoisyCorners) {
  REQUIRE_DATA(kData + "/sim/calib_persp/corners.csv");
  std::vector<ZhangView> views = LoadSimCorners();
  ASSERT_GE(views.size(), 10u);
  cv::RNG rng(7);
  std::vector<std::vector<cv::Point3f>> obj;
  std::vector<std::vector<cv::Point2f>> img;
  for (auto& v : views) {
    obj.emplace_back();
    img.emplace_back();
    for (size_t i = 0; i < v.image.size(); ++i) {
      v.image[i] += Eigen::Vector2d(rng.gaussian(0.2), rng.gaussian(0.2));
      obj.back().emplace_back(float(v.board[i].x()), float(v.board[i].y()), 0.0f);
      img.back().emplace_back(float(v.image[i].x()), float(v.image[i].y()));
    }
  }
  ZhangResult r;
  std::string error;
  ASSERT_TRUE(ZhangCalibrate(views, ZhangOptions{}, r, error)) << error;
  cv::Mat K = cv::Mat::eye(3, 3, CV_64F), D;
  std::vector<cv::Mat> rv, tv;
  const double rms = cv::calibrateCamera(
      obj, img, cv::Size(640, 480), K, D, rv, tv, cv::CALIB_FIX_K3 | cv::CALIB_ZERO_TANGENT_DIST,
      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 200, 1e-12));
  std::printf("ours rms %.5f fx %.4f fy %.4f; OpenCV rms %.5f fx %.4f fy %.4f\n", r.rms_px, r.fx,
              r.fy, rms, K.at<double>(0, 0), K.at<double>(1, 1));
  EXPECT_NEAR(r.rms_px, rms, 1e-3);
  EXPECT_NEAR(r.fx, K.at<double>(0, 0), 0.02);
  EXPECT_NEAR(r.fy, K.at<double>(1, 1), 0.02);
  EXPECT_NEAR(r.cx, K.at<double>(0, 2), 0.02);
  EXPECT_NEAR(r.cy, K.at<double>(1, 2), 0.02);
  EXPECT_NEAR(r.k1, D.at<double>(0), 1e-4);
  EXPECT_NEAR(r.k2, D.at<double>(1), 1e-4);
}

TEST(Zhang, RenderedRigPoseAndNoiseFloor) {
  REQUIRE_DATA(kData + "/sim/calib_persp/boards.json");
  const std::string dir = kData + "/sim/calib_persp";
  const std::string out = TempPath("sim.json");
  fs::remove(out);
  ASSERT_EQ(RunCli({"calibrate", "persp", "--images", dir, "--board", "9x6", "--square", "0.07",
                    "--poses", dir + "/boards.json", "--out", out}),
            0);
  const json p = ReadJson(out)["persp"];
  // Scoring only: the true rig.
  const json truth = ReadJson(dir + "/rig_truth.json")["persp"];
  Eigen::Matrix3d Rt;
  Eigen::Vector3d tt;
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  for (int i = 0; i < 3; ++i) {
    tt[i] = truth["camera_center"][i].get<double>();
    t[i] = p["t_robot_cam"][i].get<double>();
    for (int j = 0; j < 3; ++j) {
      Rt(i, j) = truth["R_wc"][i][j].get<double>();
      R(i, j) = p["R_robot_cam"][i][j].get<double>();
    }
  }
  const double pos_mm = 1000 * (t - tt).norm();
  const double ang_deg = Eigen::AngleAxisd(R * Rt.transpose()).angle() * 180 / M_PI;
  // Noise floor of the renderer: detected corners vs the true corners (corners.csv).
  const std::vector<ZhangView> truth_views = LoadSimCorners();
  double se = 0;
  int n = 0;
  for (const auto& v : truth_views) {
    const cv::Mat gray = cv::imread((fs::path(dir) / v.name).string(), cv::IMREAD_GRAYSCALE);
    std::vector<cv::Point2f> c;
    if (!cv::findChessboardCorners(gray, cv::Size(9, 6), c,
                                   cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE)) {
      continue;
    }
    cv::cornerSubPix(gray, c, cv::Size(5, 5), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 30, 0.1));
    // match each true corner to the nearest detection (order-independent)
    for (const auto& q : v.image) {
      double best = 1e9;
      for (const auto& d : c) best = std::min(best, std::hypot(d.x - q.x(), d.y - q.y()));
      se += best * best;
      ++n;
    }
  }
  ASSERT_GT(n, 500);
  const double floor_px = std::sqrt(se / n);
  const double rms = p["rms_px"].get<double>();
  std::printf(
      "sim persp: fx %.3f fy %.3f cx %.3f cy %.3f k1 %.5f k2 %.5f (truth 378 378 318.2 "
      "242.6 -0.28 0.09)\n",
      p["fx"].get<double>(), p["fy"].get<double>(), p["cx"].get<double>(), p["cy"].get<double>(),
      p["k1"].get<double>(), p["k2"].get<double>());
  std::printf(
      "sim persp: rms %.4f px, corner-detection noise floor %.4f px; pose error %.2f mm "
      "%.4f deg\n",
      rms, floor_px, pos_mm, ang_deg);
  EXPECT_LE(std::fabs(rms - floor_px), 0.05);
  EXPECT_LE(pos_mm, 5.0);
  EXPECT_LE(ang_deg, 0.2);
  EXPECT_NEAR(p["fx"].get<double>(), 378.0, 378.0 * 0.005);
  EXPECT_NEAR(p["k1"].get<double>(), -0.28, 0.01);
}

TEST(Zhang, BadInputIsRefusedAndNothingWritten) {
  REQUIRE_DATA(kData + "/zhang_msr/corners.csv");
  // Two views only.
  const std::string csv = TempPath("two.csv");
  {
    std::ifstream in(kData + "/zhang_msr/corners.csv");
    std::ofstream o(csv);
    std::string line;
    while (std::getline(in, line)) {
      if (line.find("CalibIm3") == std::string::npos &&
          line.find("CalibIm4") == std::string::npos &&
          line.find("CalibIm5") == std::string::npos) {
        o << line << "\n";
      }
    }
  }
  const std::string out = TempPath("never.json");
  fs::remove(out);
  EXPECT_EQ(RunCli({"calibrate", "persp", "--corners", csv, "--out", out}), 1);
  EXPECT_FALSE(fs::exists(out));

  // A corner outside the image.
  const std::string csv2 = TempPath("outside.csv");
  {
    std::ifstream in(kData + "/zhang_msr/corners.csv");
    std::ofstream o(csv2);
    std::string line;
    std::getline(in, line);
    o << line << "\n"
      << "CalibIm1.png,999,0.0,0.0,700.5,10.0,1\n";
    while (std::getline(in, line)) o << line << "\n";
  }
  EXPECT_EQ(RunCli({"calibrate", "persp", "--corners", csv2, "--out", out}), 1);
  EXPECT_FALSE(fs::exists(out));

  // Parallel boards: same orientation, only translated.
  std::vector<ZhangView> views;
  const Eigen::Matrix3d K = (Eigen::Matrix3d() << 500, 0, 320, 0, 500, 240, 0, 0, 1).finished();
  for (int k = 0; k < 4; ++k) {
    ZhangView v;
    v.name = std::to_string(k);
    for (int j = 0; j < 6; ++j) {
      for (int i = 0; i < 9; ++i) {
        const Eigen::Vector3d pc(0.05 * i - 0.2 + 0.03 * k, 0.05 * j - 0.1, 1.0 + 0.2 * k);
        const Eigen::Vector3d h = K * pc;
        v.board.emplace_back(0.05 * i, 0.05 * j);
        v.image.emplace_back(h.x() / h.z(), h.y() / h.z());
      }
    }
    views.push_back(v);
  }
  ZhangResult r;
  std::string error;
  EXPECT_FALSE(ZhangCalibrate(views, ZhangOptions{}, r, error));
  EXPECT_NE(error.find("degenerate"), std::string::npos) << error;

  // A NaN corner.
  views[1].image[3].x() = NAN;
  error.clear();
  EXPECT_FALSE(ZhangCalibrate(views, ZhangOptions{}, r, error));
  EXPECT_NE(error.find("non-finite"), std::string::npos) << error;

  // Too few corners in a view.
  views[1].image.resize(4);
  views[1].board.resize(4);
  EXPECT_FALSE(ZhangCalibrate(views, ZhangOptions{}, r, error));
}

}  // namespace
}  // namespace bv::cli
