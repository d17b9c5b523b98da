#pragma once
// Host-side colour LUT training and evaluation (ballvision lut). May allocate, may use OpenCV.
//
// Training model: the ball class is learnt from labelled pixels (masks, boxes, truth.csv of the
// rendered sets, or a region grown from one clicked pixel); every labelled ball pixel is also
// added at several brightness factors k (Y, U-128, V-128 scaled by k), which is what shadow and
// uneven light do to a surface of fixed chromaticity. A cell becomes "ball" when its normalised
// ball density beats `ratio` times the normalised density of everything else. Highlights are
// not learnt as ball (they look like lines); the contour stage fills them as holes. The other
// classes (field, line, obstacle) come from fixed rules on the cell colour, overridden by any
// samples taught for them explicitly.
#include <cstdint>
#include <string>
#include <vector>

#include "core/color_lut/color_lut.h"
#include "core/common/ball_state.h"
#include "core/detect/detect.h"
#include "core/scanline/scanline.h"

namespace bv::lut {

struct Image {
  std::vector<uint8_t> yuyv;
  int width = 0, height = 0;
  YuyvImage view() const { return MakeYuyvImage(yuyv.data(), width, height); }
};

/// JPEG or PNG through cli::LoadStill (strict decode, BT.601 full range as the pipeline loads;
/// an odd width padded by its last column), or a raw 640x480 .yuyv. False with `error` set.
bool LoadImage(const std::string& path, Image& out, std::string& error);

struct TrainOptions {
  float ratio = 2.0f;            // ball if ball_density > ratio * other_density
  float min_ball_weight = 2.0f;  // raw (augmented) ball samples a cell needs
  float shade_min = 0.55f, shade_max = 1.30f;
  int shade_steps = 7;
  int other_stride = 2;  // subsample background pixels
  // Optional chroma model: a cell is also ball when its shade-normalised chroma
  // ((U-128)/(Y+16), (V-128)/(Y+16)) lies within `gauss_d2` (squared Mahalanobis distance) of the
  // ball samples' Gaussian, its Y is above the 2nd percentile of ball Y times 0.6, and fewer than
  // `gauss_veto` of the other samples fall in it. 0 = off. Generalises across hue drift.
  float gauss_d2 = 0.0f;
  float gauss_veto = 5e-5f;
  // Both densities box-blurred over +-smooth cells in U and V (+-1 in Y when > 0) before the
  // ratio test: a cell the taught images never showed takes its neighbours' verdict.
  int smooth = 0;
};

class Trainer {
 public:
  explicit Trainer(const TrainOptions& options = {});
  void AddBall(uint8_t y, uint8_t u, uint8_t v, float weight = 1.0f);
  void AddOther(uint8_t y, uint8_t u, uint8_t v, float weight = 1.0f);
  void AddClass(ColorClass c, uint8_t y, uint8_t u, uint8_t v);
  /// mask: 1 = ball, 0 = other, anything else ignored (same size as the image).
  void AddMask(const Image& img, const std::vector<uint8_t>& mask);
  /// Ball box (inclusive pixel bounds): the inscribed ellipse shrunk by `shrink` is ball, the box
  /// grown by `margin` is ignored; pixels outside all boxes are other. Call AddBoxes once per
  /// image.
  struct Box {
    float u0, v0, u1, v1;
  };
  void AddBoxes(const Image& img, const std::vector<Box>& balls, float shrink = 0.8f,
                int margin = 4);
  /// Grows a region from (u, v) over 4-neighbours whose shade-normalised chroma stays within
  /// `tolerance` of the seed's running mean; adds it as `cls`. Returns the pixel count.
  int Teach(const Image& img, int u, int v, ColorClass cls, float tolerance = 0.12f,
            int max_pixels = 40000);
  ColorLut Build() const;
  /// The blur of TrainOptions::smooth, for a Build after the samples are in.
  void SetSmooth(int smooth) { opt_.smooth = smooth; }
  double ball_samples() const { return ball_total_; }
  double other_samples() const { return other_total_; }

 private:
  TrainOptions opt_;
  std::vector<float> ball_, other_;
  std::vector<uint32_t> taught_[kColorClassCount];
  double ball_total_ = 0, other_total_ = 0;
  double sa_ = 0, sb_ = 0, saa_ = 0, sab_ = 0, sbb_ = 0, sn_ = 0;
  std::vector<double> ball_y_hist_ = std::vector<double>(256, 0.0);
};

// ---- rendered sequences with truth.csv ----
struct SimTruth {
  int64_t index = 0;
  bool has[2] = {false, false};  // [0] omni, [1] persp: ball centre projects into the image
  bool visible[2] = {false, false};
  float cu[2] = {0, 0}, cv[2] = {0, 0}, area[2] = {0, 0}, fullarea[2] = {0, 0};
  float fullcu[2] = {0, 0}, fullcv[2] = {0, 0}, visfrac[2] = {0, 0};
  float bbox[2][4] = {};
};
bool LoadSimTruth(const std::string& dir, std::vector<SimTruth>& out, std::string& error);

enum class Camera { kOmni = 0, kPersp = 1 };

/// Adds a rendered sequence: fully visible balls (visfrac >= 0.95) give ball samples from their
/// silhouette disc, everything away from the ball gives other samples. Frames with
/// index % every != phase are skipped (train/test split). Returns frames used.
int AddSimSequence(Trainer& t, const std::string& dir, Camera cam, int every, int phase,
                   std::string& error);

struct EvalCounts {
  int frames = 0;
  int ball_frames = 0;    // visible, >= 4 px
  int found_on_ball = 0;  // detection within max(3, radius) px of the visible centroid
  int within_1px = 0;     // ... and within 1 px
  int false_det = 0;      // detection elsewhere (on a ball frame: wrong object) or on no-ball frame
  int missed = 0;
  double err_sum_px = 0;
  std::vector<float> errors_px;  // of found_on_ball
  double pixels_read_sum = 0;
  uint32_t overflows = 0;
};

struct FinderSetup {
  OmniScanConfig omni;
  PerspScanConfig persp;
  BallFinderConfig finder;
  bool track = true;  // previous detection -> prediction (Monte-Carlo attention)
  bool verbose = false;
  bool dump_regions = false;  // print every outer region of every frame (shape measures)
  std::string annotate_dir;   // when set, EvalSim writes one picture per frame there
};

/// Prints the outer regions of the finder's last Find ('*' = chosen).
void PrintRegions(const BallFinder& finder);

/// Runs the BallFinder over a rendered sequence (frames with index % every == phase).
bool EvalSim(const std::string& dir, Camera cam, const ColorLut& lut, const FinderSetup& setup,
             int every, int phase, EvalCounts& out, std::string& error);

// ---- annotated still images (boxes) ----
struct BoxImage {
  std::string path;
  std::vector<Trainer::Box> balls;
};
/// A box file (tools/ballvision/box_file.h: every mistake refused with file and line), its ball
/// boxes per image. Images listed without ball rows have no ball.
bool LoadBoxFile(const std::string& file, const std::string& image_dir, std::vector<BoxImage>& out,
                 std::string& error);

struct BoxEvalCounts {
  int images = 0, images_with_ball = 0, balls = 0;
  int hit = 0;        // detection inside a ball box (images)
  int false_det = 0;  // detection outside every ball box
  int missed = 0;     // image with a ball, nothing detected
};
bool EvalBoxes(const std::vector<BoxImage>& images, const ColorLut& lut, const FinderSetup& setup,
               BoxEvalCounts& out, std::string& error, bool verbose = false);

}  // namespace bv::lut
