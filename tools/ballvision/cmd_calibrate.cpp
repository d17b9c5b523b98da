// `ballvision calibrate persp|omni ...` (forms in DESIGN.md §4). Each sub-command creates the
// calibration file or replaces only its own section.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "hal/host/sequence.h"
#include "tools/ballvision/calib_io.h"
#include "tools/ballvision/calib_omni.h"
#include "tools/ballvision/calib_zhang.h"
#include "tools/ballvision/cli_args.h"
#include "tools/ballvision/commands.h"
#include "tools/ballvision/signals.h"
#include "tools/ballvision/still_image.h"
#include "tools/ballvision/strict_json.h"
#include "tools/ballvision/truth_csv.h"

namespace bv::cli {
namespace {

namespace fs = std::filesystem;

// Chessboard pictures may come from a better camera than the device's frames.
constexpr int kMaxCalibImageSide = 8192;
using nlohmann::json;

constexpr char kPerspUsage[] =
    "usage: ballvision calibrate persp (--images DIR | --corners corners.csv)\n"
    "         [--board 9x6] [--square 0.07] [--skew] [--poses POSES.json]\n"
    "         [--size 640x480] --out CALIB.json\n"
    "  DIR: a folder of images (--prefix P: only names starting with P), or a\n"
    "       sequence folder with frames.csv (persp_file column)\n"
    "  corners.csv: image,corner,X,Y,u,v,in_image (board-plane X, Y)\n";

// Through the strict CSV reader: a bad number or a short row is an error naming the line and
// column; rows with in_image 0 are skipped.
bool LoadCornersCsv(const std::string& path, std::vector<ZhangView>& views, std::string& error) {
  TruthCsv csv;
  if (!csv.Load(path, {"image", "X", "Y", "u", "v"}, error)) return false;
  std::map<std::string, size_t> index;
  for (size_t i = 0; i < csv.rows(); ++i) {
    if (csv.Text(i, "in_image") == "0") continue;
    double X = 0, Y = 0, u = 0, v = 0;
    if (!csv.Number(i, "X", X, false, error) || !csv.Number(i, "Y", Y, false, error) ||
        !csv.Number(i, "u", u, false, error) || !csv.Number(i, "v", v, false, error)) {
      return false;
    }
    const std::string& name = csv.Text(i, "image");
    if (!index.count(name)) {
      index[name] = views.size();
      views.push_back(ZhangView{name, {}, {}});
    }
    views[index[name]].board.emplace_back(X, Y);
    views[index[name]].image.emplace_back(u, v);
  }
  return true;
}

// Corner order: row-major, i fastest; board +Z towards the camera (image cross product of the
// i and j directions negative, v down) and the square between corners (0,0) and (1,1) light.
void CanonicalOrder(const cv::Mat& gray, int nx, int ny, std::vector<cv::Point2f>& c) {
  auto at = [&](int i, int j) { return c[static_cast<size_t>(j * nx + i)]; };
  const cv::Point2f a = at(1, 0) - at(0, 0), b = at(0, 1) - at(0, 0);
  std::vector<cv::Point2f> o(c.size());
  if (a.x * b.y - a.y * b.x > 0) {  // mirror i
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) o[j * nx + i] = at(nx - 1 - i, j);
    c = o;
  }
  auto sample = [&](cv::Point2f p) {
    const int x = std::clamp(static_cast<int>(std::lround(p.x)), 0, gray.cols - 1);
    const int y = std::clamp(static_cast<int>(std::lround(p.y)), 0, gray.rows - 1);
    return static_cast<int>(gray.at<uint8_t>(y, x));
  };
  const int s00 = sample((at(0, 0) + at(1, 1)) * 0.5f);
  const int s10 = sample((at(1, 0) + at(2, 1)) * 0.5f);
  if (s00 < s10) std::reverse(c.begin(), c.end());  // 180° rotation keeps the handedness
}

bool DetectImages(const std::string& dir, const std::string& prefix, int nx, int ny, double square,
                  std::vector<ZhangView>& views, int& width, int& height, std::string& error) {
  std::vector<std::pair<std::string, std::string>> files;  // name, path
  if (fs::exists(fs::path(dir) / "frames.csv")) {
    // Through the strict sequence reader; the view is named as in frames.csv.
    host::Sequence seq;
    if (!host::LoadSequence(dir, seq, error)) return false;
    for (const host::SequenceEntry& e : seq.entries) {
      if (e.persp_path.empty()) continue;
      const bool relative = e.persp_path.rfind(dir + "/", 0) == 0;
      files.emplace_back(relative ? e.persp_path.substr(dir.size() + 1) : e.persp_path,
                         e.persp_path);
    }
  } else if (fs::is_directory(dir)) {
    for (const auto& e : fs::directory_iterator(dir)) {
      std::string ext = e.path().extension().string();
      std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
      const std::string fname = e.path().filename().string();
      if (fname.rfind(prefix, 0) != 0) continue;
      if (ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".bmp" || ext == ".yuyv") {
        files.emplace_back(e.path().filename().string(), e.path().string());
      }
    }
    std::sort(files.begin(), files.end());
  } else {
    error = "no such image folder: " + dir;
    return false;
  }
  if (files.empty()) {
    error = "no images in " + dir;
    return false;
  }
  for (const auto& [name, path] : files) {
    if (InterruptSignal()) {
      error = "interrupted";
      return false;
    }
    cv::Mat gray;
    std::string why;
    if (fs::path(path).extension() == ".yuyv") {  // raw camera frame: take the Y channel
      std::vector<uint8_t> yuyv;
      int w = 0, h = 0;
      if (host::LoadYuyv(path, yuyv, w, h, why)) {
        gray.create(h, w, CV_8UC1);
        for (int i = 0; i < w * h; ++i) gray.data[i] = yuyv[2 * static_cast<size_t>(i)];
      }
    } else {  // JPEG or PNG (a .bmp is named and skipped: the strict decoders take neither)
      std::vector<uint8_t> rgb;
      int w = 0, h = 0;
      if (LoadRgb(path, kMaxCalibImageSide, kMaxCalibImageSide, rgb, w, h, why)) {
        gray.create(h, w, CV_8UC1);
        for (size_t i = 0; i < static_cast<size_t>(w) * h; ++i) {
          const uint8_t* p = &rgb[3 * i];  // BT.601 luma, as OpenCV's grey conversion
          gray.data[i] =
              static_cast<uint8_t>((p[0] * 4899 + p[1] * 9617 + p[2] * 1868 + 8192) >> 14);
        }
      }
    }
    if (gray.empty()) {
      std::fprintf(stderr, "  %s: cannot read (%s), skipped\n", name.c_str(), why.c_str());
      continue;
    }
    width = gray.cols;
    height = gray.rows;
    std::vector<cv::Point2f> corners;
    bool found =
        cv::findChessboardCorners(gray, cv::Size(nx, ny), corners,
                                  cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE);
    if (!found) {
      found = cv::findChessboardCornersSB(gray, cv::Size(nx, ny), corners);
      if (found) std::fprintf(stderr, "  %s: found by the sector-based detector\n", name.c_str());
    }
    if (!found || static_cast<int>(corners.size()) != nx * ny) {
      std::fprintf(stderr, "  %s: board not found, skipped\n", name.c_str());
      continue;
    }
    cv::cornerSubPix(gray, corners, cv::Size(5, 5), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 30, 0.1));
    CanonicalOrder(gray, nx, ny, corners);
    ZhangView v{name, {}, {}};
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) {
        v.board.emplace_back(i * square, j * square);
        const cv::Point2f& p = corners[static_cast<size_t>(j * nx + i)];
        v.image.emplace_back(p.x, p.y);
      }
    }
    views.push_back(std::move(v));
  }
  return true;
}

// One {"image", "R" (3x3), "t" [x,y,z]} entry through the strict reader.
bool ReadPose(const json& p, const std::string& path, size_t i, std::string& name,
              Eigen::Matrix3d& R, Eigen::Vector3d& t, std::string& error) {
  StrictObject r(p, path, "poses[" + std::to_string(i) + "]");
  const json* rows = nullptr;
  bool ok = r.IsObject() && r.String("image", name, {}) && (rows = r.Child("R")) != nullptr;
  if (ok && (!rows->is_array() || rows->size() != 3)) ok = r.Fail("R", *rows, "3 rows of 3");
  for (int k = 0; ok && k < 3; ++k) {
    std::string key = "R[";
    key += std::to_string(k);
    key += ']';
    const json wrap{{key, (*rows)[k]}};
    StrictObject rr(wrap, path, "poses[" + std::to_string(i) + "]");
    std::vector<double> row;
    ok = (rr.NumberArray(key.c_str(), row, -1.001, 1.001) &&
          (row.size() == 3 || rr.Fail(key, (*rows)[k], "3 numbers"))) ||
         r.Adopt(rr);
    for (int c = 0; ok && c < 3; ++c) R(k, c) = row[c];
  }
  std::vector<double> tv;
  ok = ok && r.NumberArray("t", tv, -100, 100) &&
       (tv.size() == 3 || r.Fail("t", p["t"], "3 numbers (m)"));
  if (ok) t = Eigen::Vector3d(tv[0], tv[1], tv[2]);
  if (!ok) error = r.error();
  return ok;
}

bool LoadPoses(const std::string& path, const std::vector<ZhangView>& views,
               std::vector<BoardPose>& poses, std::string& error) {
  json j;
  if (!ReadJsonFile(path, j, error)) return false;
  StrictObject top(j, path, "");
  const json* list = top.IsObject() ? top.Child("poses") : nullptr;
  if (list && !list->is_array()) top.Fail("poses", *list, "an array of {image, R, t}");
  if (!top.error().empty()) {
    error = top.error();
    return false;
  }
  for (size_t i = 0; i < list->size(); ++i) {
    std::string name;
    BoardPose bp;
    if (!ReadPose((*list)[i], path, i, name, bp.R, bp.t, error)) return false;
    if ((bp.R.transpose() * bp.R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-4) {
      error = path + ": poses[" + std::to_string(i) + "].R (" + name + ") is not a rotation";
      return false;
    }
    int view = -1;
    for (size_t k = 0; k < views.size(); ++k) {
      if (views[k].name == name ||
          fs::path(views[k].name).filename() == fs::path(name).filename()) {
        view = static_cast<int>(k);
      }
    }
    if (view < 0) continue;  // that image was not usable
    bp.view = view;
    poses.push_back(bp);
  }
  return true;
}

bool CornersInImage(const std::vector<ZhangView>& views, int width, int height,
                    std::string& error) {
  for (const auto& v : views) {
    for (size_t i = 0; i < v.image.size(); ++i) {
      const Eigen::Vector2d& q = v.image[i];
      if (!(q.x() >= -0.5 && q.x() <= width - 0.5 && q.y() >= -0.5 && q.y() <= height - 0.5)) {
        char buf[256];
        std::snprintf(buf, sizeof buf, "%s corner %zu at (%.2f, %.2f) is outside the %dx%d image",
                      v.name.c_str(), i, q.x(), q.y(), width, height);
        error = buf;
        return false;
      }
    }
  }
  return true;
}

// Prints the result; returns the rms per image for the calibration file.
json PrintZhangResult(const std::vector<ZhangView>& views, const ZhangResult& r, bool skew) {
  std::printf(
      "Zhang calibration, %zu views%s (closed form: fx %.2f fy %.2f cx %.2f cy %.2f "
      "skew %.4f; LM %d iterations)\n",
      views.size(), skew ? ", with skew" : "", r.init_fx, r.init_fy, r.init_cx, r.init_cy,
      r.init_skew, r.iterations);
  json per_image = json::object();
  for (size_t i = 0; i < views.size(); ++i) {
    std::printf("  %-28s %3zu corners  rms %.4f px\n", views[i].name.c_str(), views[i].image.size(),
                r.rms_per_view_px[i]);
    per_image[views[i].name] = r.rms_per_view_px[i];
  }
  std::printf("fx %.4f fy %.4f cx %.4f cy %.4f skew %.5f k1 %.6f k2 %.6f\n", r.fx, r.fy, r.cx, r.cy,
              r.skew, r.k1, r.k2);
  std::printf("overall reprojection rms %.4f px\n", r.rms_px);
  return per_image;
}

struct PerspArgs {
  std::string images, corners, poses_path, out, prefix;
  int nx = 9, ny = 6, width = 640, height = 480;
  double square = 0.07;
  ZhangOptions opt;
};

// "AxB" integer pairs, with what they mean in the message.
ArgParser::Handler IntPair(const char* name, int64_t lo, int64_t hi, const char* meaning, int& a,
                           int& b) {
  return [=, &a, &b](const std::string& v, std::string& error) {
    int64_t x = 0, y = 0;
    if (!ArgIntPair(name, v, 'x', lo, hi, x, y, error)) {
      error += meaning;
      return false;
    }
    a = static_cast<int>(x);
    b = static_cast<int>(y);
    return true;
  };
}

// Returns -1 to go on, else the exit code.
int ParsePerspArgs(int argc, char** argv, PerspArgs& a) {
  ArgParser p("ballvision calibrate persp", kPerspUsage);
  p.Flag("--skew", a.opt.skew)
      .Text("--images", a.images)
      .Text("--prefix", a.prefix)
      .Text("--corners", a.corners)
      .Text("--poses", a.poses_path)
      .Text("--out", a.out)
      .Required("--out")
      .Custom("--square",
              [&a](const std::string& v, std::string& error) {
                if (ArgNumber("--square", v, 1e-4, 10, a.square, error)) return true;
                error += " (board square size in metres)";
                return false;
              })
      .Custom("--board", IntPair("--board", 2, 100, " (NXxNY inner corners, e.g. 9x6)", a.nx, a.ny))
      .Custom("--size",
              IntPair("--size", 16, 4096, " (image size WxH in pixels)", a.width, a.height));
  if (const int rc = p.Parse(argc, argv); rc >= 0) return rc;
  if (a.images.empty() == a.corners.empty()) return p.UsageError("give --images or --corners");
  return -1;
}

int CalibratePersp(int argc, char** argv) {
  PerspArgs a;
  if (const int rc = ParsePerspArgs(argc, argv, a); rc >= 0) return rc;
  const std::string &images = a.images, &corners = a.corners, &poses_path = a.poses_path;
  const std::string &out = a.out, &prefix = a.prefix;
  const int nx = a.nx, ny = a.ny;
  int &width = a.width, &height = a.height;  // from the images when detected
  const double square = a.square;
  const ZhangOptions& opt = a.opt;
  std::vector<ZhangView> views;
  std::string error;
  std::vector<BoardPose> checked;
  if (!poses_path.empty() && !LoadPoses(poses_path, {}, checked, error)) {
    // Checked before the calibration: a bad poses file should not cost the whole run.
    std::fprintf(stderr, "calibrate persp: %s; no calibration written\n", error.c_str());
    return 1;
  }
  if (!corners.empty()
          ? !LoadCornersCsv(corners, views, error)
          : !DetectImages(images, prefix, nx, ny, square, views, width, height, error)) {
    std::fprintf(stderr, "calibrate persp: %s; no calibration written\n", error.c_str());
    return 1;
  }
  ZhangResult r;
  if (!CornersInImage(views, width, height, error) || !ZhangCalibrate(views, opt, r, error)) {
    std::fprintf(stderr, "calibrate persp: %s; no calibration written\n", error.c_str());
    return 1;
  }
  const json per_image = PrintZhangResult(views, r, opt.skew);

  PerspCalibration p;
  p.valid = true;
  p.width_px = width;
  p.height_px = height;
  p.fx = static_cast<float>(r.fx);
  p.fy = static_cast<float>(r.fy);
  p.cx = static_cast<float>(r.cx);
  p.cy = static_cast<float>(r.cy);
  p.skew = static_cast<float>(r.skew);
  p.k1 = static_cast<float>(r.k1);
  p.k2 = static_cast<float>(r.k2);
  p.rms_px = static_cast<float>(r.rms_px);
  json extra;
  if (!poses_path.empty()) {
    std::vector<BoardPose> poses;
    Eigen::Matrix3d R;
    Eigen::Vector3d t;
    double pose_rms = 0;
    if (!LoadPoses(poses_path, views, poses, error) ||
        !EstimateRigPose(views, r, poses, R, t, pose_rms, error)) {
      std::fprintf(stderr, "calibrate persp: %s; no calibration written\n", error.c_str());
      return 1;
    }
    p.R_robot_cam = R.cast<float>();
    p.t_robot_cam = t.cast<float>();
    const Eigen::Vector3d axis = R.col(2);
    std::printf(
        "camera pose from %zu board poses: position (%.4f, %.4f, %.4f) m, optical axis "
        "(%.4f, %.4f, %.4f), pitch %.3f deg, rms %.4f px\n",
        poses.size(), t.x(), t.y(), t.z(), axis.x(), axis.y(), axis.z(),
        std::asin(std::clamp(axis.z(), -1.0, 1.0)) * 180 / M_PI, pose_rms);
    extra["pose_views"] = static_cast<int>(poses.size());
    extra["pose_rms_px"] = pose_rms;
  } else {
    std::printf("no --poses: intrinsics only (camera pose left at identity)\n");
  }
  json section = PerspToJson(p);
  section["model"] = opt.skew ? "zhang_k1k2_skew" : "zhang_k1k2";
  section["views"] = static_cast<int>(views.size());
  section["per_image_rms_px"] = per_image;
  for (auto& [k, v] : extra.items()) section[k] = v;
  if (InterruptSignal()) return 1;  // CmdCalibrate reports it; nothing written
  if (!UpdateCalibrationSection(out, "persp", section, error)) {
    std::fprintf(stderr, "calibrate persp: %s\n", error.c_str());
    return 1;
  }
  std::printf("wrote persp section of %s\n", out.c_str());
  return 0;
}

}  // namespace

int CmdCalibrate(int argc, char** argv) {
  // Ctrl-C: the steps stop at the next image; a calibration from part of the data is not
  // written (the file keeps its old content).
  InstallInterruptHandlers();
  const int rc = RunSubCommand(
      "ballvision calibrate",
      "usage: ballvision calibrate persp|omni ... ('calibrate persp --help' for options)\n", argc,
      argv, {{"persp", CalibratePersp}, {"omni", CalibrateOmni}});
  if (InterruptSignal()) {
    ReportInterrupt("ballvision calibrate");
    return InterruptExitCode();
  }
  return rc;
}

}  // namespace bv::cli
