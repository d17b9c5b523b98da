#pragma once
// The device's front end on single still images (ballvision detect, the real-image figures):
// a scan table for the image's size, the colour table, regions, the checks of core/ball_check
// and the ball choice of core/detect, exactly as `run` and the firmware call them. Host only in
// what it adds around them: image sizes that change from file to file, and the candidates'
// features handed out for training.
#include <memory>
#include <string>
#include <vector>

#include "core/ball_check/ball_check.h"
#include "core/calibration/calibration.h"
#include "core/color_lut/color_lut.h"
#include "core/detect/detect.h"
#include "core/scanline/scanline.h"
#include "tools/ballvision/lut_train.h"

namespace bv::cli {

struct DetectSetup {
  const ColorLut* lut = nullptr;
  FloorBallProfile profile;                    // the teach file's (invalid: none)
  const PerspCalibration* persp = nullptr;     // --calib --camera persp (takes precedence)
  const BallClassifier* classifier = nullptr;  // null or not loaded: no look check
  BallFinderConfig finder;
  BallCheckConfig check;
  BallGeometryConfig geometry;
  float min_diameter_px = 6.0f;  // the scan pattern's smallest ball (with a profile)
  int max_balls = 4;             // balls reported per image, the chosen one first
};

struct StillBall {
  float u_px = 0, v_px = 0, radius_px = 0, score = 0;
};

/// A region that passed the shape test, with what the checks said (training, debugging).
struct StillCandidate {
  CandidateShape shape;
  BallFinder::Refusal refusal = BallFinder::Refusal::kNone;
  CandidateVerdict verdict;
  BallFeatures features;
  bool chosen = false;
};

struct StillResult {
  std::vector<StillBall> balls;  // chosen first
  std::vector<StillCandidate> candidates;
  FrontEndStats stats;
  uint32_t scan_pixels = 0;
  const char* geometry = "none";  // where size and place came from: none, profile, calibration
};

class StillDetector {
 public:
  StillDetector();
  ~StillDetector();
  /// False with `error` for a setup that cannot work (no table, a bad calibration or profile).
  bool Init(const DetectSetup& setup, std::string& error);
  /// Runs the front end on one image. `want_candidates` fills out.candidates.
  bool Detect(const lut::Image& image, StillResult& out, bool want_candidates, std::string& error);
  const BallFinder& finder() const { return *finder_; }
  const ScanlineTableBase& scan() const { return *scan_; }

 private:
  bool Prepare(int width, int height, std::string& error);

  DetectSetup setup_;
  std::unique_ptr<ScanlineTable<kPerspScanPixels>> scan_;
  std::unique_ptr<BallFinder> finder_;
  BallGeometry geometry_;
  BallCheck check_;
  int width_ = 0, height_ = 0;
  const char* geometry_source_ = "none";
};

}  // namespace bv::cli
