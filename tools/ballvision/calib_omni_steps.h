#pragma once
// The steps of the model-free omni calibration (paper section III-B), each a function from its
// inputs to a result struct, without printing: `calibrate omni` (calib_omni.cpp) parses, calls
// them in order and prints; host_tests/calib_omni_steps_test.cpp tests each on its own.
//  1. image centre = centre of the mirror rim circle (mean image, radial edge points, circle fit);
//  2. per frame, the carpet's image direction (most white/blue transitions along a ray); with
//     the known bearing per frame this gives the image-angle <-> robot-azimuth relation, refined
//     from the symmetry of the strip's sides;
//  3. along rays near the carpet centre line, the colour transitions between patches
//     (sub-pixel), numbered by the uniquely coloured (red) patch and the colour sequence; the 12
//     consecutive edges seen most often are kept;
//  4. per 8° sector, k-means (12 clusters, one per edge) over the samples; cluster medians
//     (corrected to the edge's exact ground distance) are the support vectors;
//  5. support vectors off a robust low-harmonic fit across directions are rejected;
//  6. sectors with too few samples (mirror struts) are interpolated and flagged; then median
//     and moving-average smoothing across neighbouring directions per edge;
//  7. a symmetric (one-direction) fit for comparison, and the residuals of both.
// The carpet top is `thickness_m` above the floor: sample distances are projected to z = 0
// through the viewpoint f_O.
#include <array>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "core/calibration/calibration.h"
#include "tools/ballvision/carpet_json.h"

namespace bv::cli::omni {

constexpr int kSectors = OmniCalibration::kDirections;
constexpr int kEdges = OmniCalibration::kEdges;

/// One omni frame of the carpet run as BGR (what the colour classes are tuned on).
struct Frame {
  long index = 0;
  std::string name;
  cv::Mat3b bgr;
};

/// frames.csv through the strict sequence reader; every omni image must have the first one's
/// size. Errors name the file.
bool LoadFrames(const std::string& seq, std::vector<Frame>& frames, std::string& error);

/// A colour change between carpet classes (CarpetColorCode) along a ray, at r_px from the centre.
struct Transition {
  double r_px = 0;
  CarpetColorCode from = kCarpetOther, to = kCarpetOther;
};
/// Carpet colour class of an RGB colour.
CarpetColorCode ClassifyCarpetColor(float r, float g, float b);
/// Sub-pixel colour transitions along the ray at image angle phi, radii [r0, r1).
std::vector<Transition> ScanRay(const cv::Mat3b& bgr, double cu, double cv, double phi, double r0,
                                double r1);
/// Numbers a ray's transitions by the carpet's anchor patch: the transition into it is edge
/// `anchor_patch`; neighbours must follow the carpet's colour sequence. Returns (transition
/// index, carpet edge index) pairs.
std::vector<std::pair<int, int>> NumberTransitions(const std::vector<Transition>& tr,
                                                   const Carpet& carpet, int anchor_patch);

/// The patch whose colour occurs once (the last such), or -1 when there is none after the first.
int AnchorPatch(const Carpet& carpet);

/// Step 1.
struct RimFit {
  double cu = 0, cv = 0, radius = 0;
};
/// Fails when fewer than 100 rim points are found or the fit is not finite.
bool FindCentre(const std::vector<Frame>& frames, RimFit& rim, std::string& error);

/// Step 2: image angle = sign * robot azimuth + offset.
struct AngleFit {
  int sign = 1;
  double offset_rad = 0;
  double harmonics_rad[4] = {};   // OmniCalibration::azimuth_harmonics_rad (RefineAngleOffset)
  double consistency = -1;        // mean resultant length of (image angle - sign * bearing)
  std::vector<double> theta_rad;  // per frame: the carpet bearing
};
/// OmniAzimuthCorrection of the fit so far.
double AzimuthCorrection(const AngleFit& fit, double phi);
/// Fails when a frame has no bearing in the carpet description (`carpet_path`, for the
/// message), or consistency < 0.9.
bool FitImageAngle(const std::vector<Frame>& frames, const Carpet& carpet,
                   const std::string& carpet_path, const RimFit& rim, AngleFit& fit,
                   std::string& error);
struct AngleRefinement {
  bool applied = false;  // fewer than 20 fans leave the offset as it was
  size_t fans = 0;
  double correction_rad = 0;
  bool harmonics = false;        // fitted (>= 60 fans, no direction gap over 45 degrees)
  size_t harmonic_outliers = 0;  // fans left out of the harmonic fit (> 3 robust sigma)
  double rms_before_rad = 0;     // fan residual rms with the offset alone
  double rms_after_rad = 0;      // ... and with the harmonics
  double max_gap_rad = 0;        // largest gap between the fans' directions
};
/// Seen from the centre, the strip's two sides are symmetric about its centre line: per frame
/// and edge (>= 1.8 m) the middle of the fan of rays that see that edge is the centre line.
/// The fans' residuals against the bearings give the offset (their median) and, when they cover
/// every direction, the azimuth harmonics (least squares, refitted without 3-sigma outliers).
AngleRefinement RefineAngleOffset(const std::vector<Frame>& frames, const Carpet& carpet,
                                  int anchor_patch, const RimFit& rim, AngleFit& fit);

/// Step 3.
struct Sample {
  double phi = 0;        // image angle of the ray, [0, 2pi)
  double r_px = 0;       // image distance from the centre
  int edge = -1;         // index into the chosen 12 edges (after k-means)
  int carpet_edge = -1;  // index into carpet edges_m (from the colour numbering)
  double d_m = 0;        // true ground distance (z = 0) of the sample
  long frame = 0;
};
struct RawSamples {
  std::vector<Sample> samples;
  int rays = 0, rays_numbered = 0;
};
RawSamples CollectSamples(const std::vector<Frame>& frames, const Carpet& carpet, int anchor_patch,
                          const RimFit& rim, const AngleFit& fit, double viewpoint_z_m);
struct EdgeChoice {
  int first = -1;               // first of the 12 consecutive carpet edges with most samples
  std::vector<int> per_edge;    // samples per carpet edge
  std::vector<Sample> samples;  // those of the chosen edges
  std::array<double, kEdges> edge_m{};
};
/// Fails when the carpet has fewer than 12 edges.
bool ChooseEdges(const RawSamples& raw, const Carpet& carpet, EdgeChoice& out, std::string& error);
/// Fails when a chosen edge was found fewer than 10 times.
bool CheckEdgeCounts(const EdgeChoice& edges, std::string& error);

/// Step 4.
struct SectorFit {
  std::array<double, kEdges> global{};  // per-edge median radius over all directions
  double support[kSectors][kEdges] = {};
  bool have[kSectors][kEdges] = {};
  int moved = 0;  // samples k-means put on another edge than the colour numbering
};
/// Sets each sample's `edge`.
SectorFit FitSectors(std::vector<Sample>& samples, int first_edge,
                     const std::array<double, kEdges>& edge_m);

/// Step 5: returns how many support vectors were rejected (their `have` cleared).
int RejectInconsistent(SectorFit& fit);

/// Step 6. Sectors with all 12 edges.
int CompleteSectors(const SectorFit& fit);
/// Fills the missing support vectors and flags their sectors, smooths, and writes support_px
/// and sector_flags of `cal`.
void InterpolateAndSmooth(SectorFit& fit, OmniCalibration& cal);

/// Step 7.
std::array<double, kEdges> SymmetricSupport(const std::vector<Sample>& samples,
                                            const std::array<double, kEdges>& global,
                                            const std::array<double, kEdges>& edge_m);
struct SectorResidual {
  int samples = 0;
  bool interpolated = false;
  double rms_px = 0, rms_ground_rel = 0, max_ground_rel = 0, symmetric_rms_ground_rel = 0;
};
struct Residuals {
  std::vector<SectorResidual> sectors;  // kSectors
  double rms_ground_rel = 0, symmetric_rms_ground_rel = 0;
};
/// Through the rim fit and angle fit unrounded (cal holds them as float).
Residuals ComputeResiduals(const OmniCalibration& cal, const OmniCalibration& symmetric,
                           const std::vector<Sample>& samples, const RimFit& rim,
                           const AngleFit& fit);

/// The --report files: omni_samples.csv, omni_support.csv, omni_symmetric.csv,
/// omni_residuals.json.
bool WriteReport(const std::string& dir, const std::vector<Sample>& samples,
                 const OmniCalibration& cal, const std::array<double, kEdges>& edge_m,
                 const std::array<double, kEdges>& symmetric, const Residuals& res,
                 std::string& error);
nlohmann::json ResidualsJson(const Residuals& res);
/// The calibration file's "omni" section.
nlohmann::json OmniSection(const OmniCalibration& cal, size_t samples, double rim_radius_px,
                           const std::array<double, kEdges>& symmetric, const Residuals& res);

}  // namespace bv::cli::omni
