#include "tools/ballvision/still_detect.h"

#include <algorithm>
#include <cmath>

namespace bv::cli {

StillDetector::StillDetector()
    : scan_(std::make_unique<ScanlineTable<kPerspScanPixels>>()),
      finder_(std::make_unique<BallFinder>()) {}
StillDetector::~StillDetector() = default;

bool StillDetector::Init(const DetectSetup& setup, std::string& error) {
  if (setup.lut == nullptr) {
    error = "detect: no colour table";
    return false;
  }
  setup_ = setup;
  width_ = height_ = 0;
  return true;
}

// The scan table and the geometry follow the image size: a calibration or a profile learned on
// another size does not describe this image, and is left out (said in the result).
bool StillDetector::Prepare(int width, int height, std::string& error) {
  if (width == width_ && height == height_) return true;
  width_ = height_ = 0;
  geometry_.Clear();
  geometry_source_ = "none";
  PerspScanConfig scan = ReferencePerspScanConfig();
  if (setup_.persp != nullptr && setup_.persp->width_px == width &&
      setup_.persp->height_px == height) {
    if (!geometry_.SetPersp(*setup_.persp, setup_.geometry).ok()) {
      error = "detect: the persp calibration is not usable for size and place";
      return false;
    }
    geometry_source_ = "calibration";
  } else if (setup_.profile.valid && setup_.profile.width_px == width &&
             setup_.profile.height_px == height) {
    if (!geometry_.SetProfile(setup_.profile, setup_.geometry).ok()) {
      error = "detect: the teach file's floor-ball profile is not usable";
      return false;
    }
    scan = PerspScanFromProfile(setup_.profile, setup_.geometry, height, setup_.min_diameter_px);
    geometry_source_ = "profile";
  }
  // A table too large for the device's capacity is made sparser (a larger smallest ball) until
  // it fits, as the device would have to.
  Status st = scan_->BuildPersp(scan, width, height);
  for (int i = 0; i < 8 && st.code() == StatusCode::kResourceExhausted; ++i) {
    for (int k = 0; k < std::max(scan.diameter.count, 1); ++k) {
      if (scan.diameter.count == 0) {
        scan.diameter.at_px[0] = 0;
        scan.diameter.diameter_px[0] = 8.0f;
        scan.diameter.count = 1;
      }
      scan.diameter.diameter_px[k] *= 1.25f;
    }
    st = scan_->BuildPersp(scan, width, height);
  }
  if (!st.ok()) {
    error = std::string("detect: scan table for ") + std::to_string(width) + "x" +
            std::to_string(height) + ": " + st.message();
    return false;
  }
  check_.Init(&geometry_, setup_.classifier, setup_.check);
  BallFinderConfig fc = setup_.finder;
  fc.check = &check_;
  fc.ball_box = setup_.lut->Bounds(ColorClass::kBall);
  if (!finder_->Init(*scan_, fc).ok()) {
    error = "detect: ball finder configuration refused";
    return false;
  }
  width_ = width;
  height_ = height;
  return true;
}

bool StillDetector::Detect(const lut::Image& image, StillResult& out, bool want_candidates,
                           std::string& error) {
  out = StillResult{};
  if (!Prepare(image.width, image.height, error)) return false;
  BallDetection det;
  const Status st = finder_->Find(image.view(), *setup_.lut, nullptr, det, out.stats);
  if (!st.ok()) {
    error = std::string("detect: ") + st.message();
    return false;
  }
  out.scan_pixels = scan_->pixel_count();
  out.geometry = geometry_source_;
  std::vector<BallDetection> ranked(static_cast<size_t>(std::max(setup_.max_balls, 1)));
  const size_t n = finder_->Ranked(ranked);
  for (size_t i = 0; i < n; ++i) {
    out.balls.push_back(
        {ranked[i].u_px, ranked[i].v_px, ranked[i].radius_px, ranked[i].confidence});
  }
  if (want_candidates) {
    const auto regions = finder_->regions().regions();
    for (size_t i = 0; i < regions.size(); ++i) {
      if (regions[i].hole) continue;
      StillCandidate c;
      c.shape = BallFinder::ShapeOf(regions[i]);
      c.refusal = finder_->refusal(i);
      c.verdict = check_.Evaluate(image.view(), *setup_.lut, c.shape, &c.features);
      if (c.verdict.place != PlaceVerdict::kPlausible) {
        ComputeBallFeatures(image.view(), *setup_.lut, c.shape, c.features);
      }
      c.chosen = static_cast<int>(i) == finder_->chosen_region();
      out.candidates.push_back(c);
    }
  }
  return true;
}

}  // namespace bv::cli
