// The steps of `calibrate omni` (tools/ballvision/calib_omni_steps.h) one by one, on synthetic
// images and samples. The whole command against the renders: calibration_omni_test.cpp.
#include "tools/ballvision/calib_omni_steps.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "host_tests/test_util.h"

namespace bv::cli::omni {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kCu = 321.3, kCv = 238.6, kRimPx = 210;

// Carpet of 16 edges: white/blue patches with one red one, edge k at 30 + 11 k px in the image.
Carpet TestCarpet() {
  Carpet c;
  for (int k = 0; k < 16; ++k) c.edges_m.push_back(1.0 + 0.25 * k);
  for (int p = 0; p < 15; ++p) c.colors.push_back(p % 2 ? kCarpetBlue : kCarpetWhite);
  c.colors[4] = kCarpetRed;
  c.width_m = 0.6;
  return c;
}
double EdgeRadiusPx(int k) { return 30 + 11.0 * k; }

// Grey mirror disc on black; the carpet strip (12 px either side of its centre line at image
// angle phi) coloured by patch. 4x4 samples per pixel, so edges are sub-pixel exact.
cv::Vec3f Colour(double du, double dv, double c, double s, const Carpet& carpet) {
  if (std::hypot(du, dv) > kRimPx) return {0, 0, 0};
  const double along = du * c + dv * s, across = -du * s + dv * c;
  const int p = static_cast<int>(std::floor((along - EdgeRadiusPx(0)) / 11));
  if (std::fabs(across) > 12 || p < 0 || p >= static_cast<int>(carpet.colors.size())) {
    return {90, 90, 90};
  }
  switch (carpet.colors[p]) {
    case kCarpetBlue:
      return {200, 40, 30};
    case kCarpetRed:
      return {30, 30, 200};
    default:
      return {230, 230, 230};
  }
}

Frame Render(long index, double phi, const Carpet& carpet) {
  Frame f;
  f.index = index;
  f.bgr = cv::Mat3b(480, 640);
  const double c = std::cos(phi), s = std::sin(phi);
  for (int y = 0; y < 480; ++y) {
    for (int x = 0; x < 640; ++x) {
      cv::Vec3f sum(0, 0, 0);
      for (int j = 0; j < 4; ++j) {
        for (int i = 0; i < 4; ++i) {
          sum += Colour(x - 0.375 + 0.25 * i - kCu, y - 0.375 + 0.25 * j - kCv, c, s, carpet);
        }
      }
      f.bgr(y, x) = cv::Vec3b(cv::saturate_cast<uint8_t>(sum[0] / 16),
                              cv::saturate_cast<uint8_t>(sum[1] / 16),
                              cv::saturate_cast<uint8_t>(sum[2] / 16));
    }
  }
  return f;
}

// Image angle = -bearing + 1.0 rad.
constexpr int kSign = -1;
constexpr double kOffset = 1.0;
std::vector<Frame> CarpetRun(Carpet& carpet, int n = 12) {
  std::vector<Frame> frames;
  for (int i = 0; i < n; ++i) {
    const double bearing = i * 2 * kPi / n;
    carpet.azimuth_rad[i] = bearing;
    frames.push_back(Render(i, kSign * bearing + kOffset, carpet));
  }
  return frames;
}

double AngleDiff(double a, double b) { return std::remainder(a - b, 2 * kPi); }

TEST(CalibOmniSteps, ClassifiesCarpetColours) {
  EXPECT_EQ(ClassifyCarpetColor(230, 230, 230), kCarpetWhite);
  EXPECT_EQ(ClassifyCarpetColor(30, 40, 200), kCarpetBlue);
  EXPECT_EQ(ClassifyCarpetColor(200, 30, 30), kCarpetRed);
  EXPECT_EQ(ClassifyCarpetColor(90, 90, 90), kCarpetOther);
  EXPECT_EQ(ClassifyCarpetColor(40, 160, 40), kCarpetOther);
}

TEST(CalibOmniSteps, ScanRayFindsTheEdgesSubPixel) {
  Carpet carpet = TestCarpet();
  const Frame f = Render(0, 0.3, carpet);
  const auto tr = ScanRay(f.bgr, kCu, kCv, 0.3, 20, kRimPx - 3);
  ASSERT_EQ(tr.size(), 14u);  // edges 1..14; 0 and 15 border grey, not a carpet class
  for (size_t i = 0; i < tr.size(); ++i) {
    // The 50 % point of the colour change, not the geometric edge: up to half a pixel out,
    // depending on the pair of colours.
    EXPECT_NEAR(tr[i].r_px, EdgeRadiusPx(static_cast<int>(i) + 1), 0.55) << i;
    EXPECT_EQ(tr[i].from, carpet.colors[i]);
    EXPECT_EQ(tr[i].to, carpet.colors[i + 1]);
  }
  // Off the strip: no carpet transitions.
  EXPECT_TRUE(ScanRay(f.bgr, kCu, kCv, 0.3 + kPi / 2, 20, kRimPx - 3).empty());
}

TEST(CalibOmniSteps, NumbersTransitionsFromTheAnchorPatch) {
  const Carpet carpet = TestCarpet();
  ASSERT_EQ(AnchorPatch(carpet), 4);
  std::vector<Transition> tr;
  for (int m = 2; m <= 8; ++m) {
    tr.push_back({10.0 * m, static_cast<CarpetColorCode>(carpet.colors[m - 1]),
                  static_cast<CarpetColorCode>(carpet.colors[m])});
  }
  const auto numbered = NumberTransitions(tr, carpet, 4);
  ASSERT_EQ(numbered.size(), 7u);
  for (const auto& [k, m] : numbered) EXPECT_EQ(m, k + 2);
  // A transition out of the colour sequence ends the walk outwards.
  tr[5].to = kCarpetRed;
  EXPECT_EQ(NumberTransitions(tr, carpet, 4).size(), 5u);
  // Without the anchor transition nothing is numbered.
  tr[2].to = kCarpetWhite;
  EXPECT_TRUE(NumberTransitions(tr, carpet, 4).empty());
}

TEST(CalibOmniSteps, AnchorPatchNeedsAUniqueColourAfterTheFirst) {
  Carpet carpet = TestCarpet();
  carpet.colors[4] = kCarpetWhite;
  EXPECT_EQ(AnchorPatch(carpet), -1);
  carpet.colors[0] = kCarpetRed;  // unique, but the first patch cannot anchor
  EXPECT_EQ(AnchorPatch(carpet), -1);
}

TEST(CalibOmniSteps, CentreIsTheRimCircle) {
  Carpet carpet = TestCarpet();
  const std::vector<Frame> frames = CarpetRun(carpet, 4);
  RimFit rim;
  std::string error;
  ASSERT_TRUE(FindCentre(frames, rim, error)) << error;
  EXPECT_NEAR(rim.cu, kCu, 0.3);
  EXPECT_NEAR(rim.cv, kCv, 0.3);
  EXPECT_NEAR(rim.radius, kRimPx, 1.0);

  std::vector<Frame> black(1);
  black[0].bgr = cv::Mat3b(480, 640, cv::Vec3b(0, 0, 0));
  EXPECT_FALSE(FindCentre(black, rim, error));
  EXPECT_NE(error.find("mirror rim not found"), std::string::npos) << error;
}

TEST(CalibOmniSteps, ImageAngleFollowsTheBearings) {
  Carpet carpet = TestCarpet();
  const std::vector<Frame> frames = CarpetRun(carpet);
  const RimFit rim{kCu, kCv, kRimPx};
  AngleFit fit;
  std::string error;
  ASSERT_TRUE(FitImageAngle(frames, carpet, "carpet.json", rim, fit, error)) << error;
  EXPECT_EQ(fit.sign, kSign);
  EXPECT_NEAR(AngleDiff(fit.offset_rad, kOffset), 0, 1.0 * kPi / 180);
  EXPECT_GT(fit.consistency, 0.99);

  fit.offset_rad += 0.5 * kPi / 180;  // the refinement must pull it back
  const AngleRefinement ref = RefineAngleOffset(frames, carpet, 4, rim, fit);
  ASSERT_TRUE(ref.applied) << ref.fans;
  EXPECT_NEAR(AngleDiff(fit.offset_rad, kOffset), 0, 0.2 * kPi / 180);
}

// A tilted mirror turns image directions by a small periodic amount: the strip is drawn at
// phi = sign * bearing + offset + h(phi) and the refinement must find h's four coefficients.
TEST(CalibOmniSteps, AzimuthHarmonicsOfATiltedMirror) {
  const double h[4] = {0.005, -0.004, 0.002, 0.001};
  const auto turn = [&h](double phi) {
    return h[0] * std::cos(phi) + h[1] * std::sin(phi) + h[2] * std::cos(2 * phi) +
           h[3] * std::sin(2 * phi);
  };
  Carpet carpet = TestCarpet();
  std::vector<Frame> frames;
  constexpr int kFrames = 72;
  for (int i = 0; i < kFrames; ++i) {
    const double bearing = i * 2 * kPi / kFrames;
    carpet.azimuth_rad[i] = bearing;
    const double phi0 = kSign * bearing + kOffset;
    double phi = phi0;
    for (int it = 0; it < 4; ++it) phi = phi0 + turn(phi);
    frames.push_back(Render(i, phi, carpet));
  }
  const RimFit rim{kCu, kCv, kRimPx};
  AngleFit fit;
  std::string error;
  ASSERT_TRUE(FitImageAngle(frames, carpet, "carpet.json", rim, fit, error)) << error;
  const AngleRefinement ref = RefineAngleOffset(frames, carpet, 4, rim, fit);
  ASSERT_TRUE(ref.harmonics) << ref.fans << " fans, gap " << ref.max_gap_rad;
  for (int k = 0; k < 4; ++k) EXPECT_NEAR(fit.harmonics_rad[k], h[k], 0.0008) << k;
  EXPECT_NEAR(AngleDiff(fit.offset_rad, kOffset), 0, 0.0008);
  EXPECT_LT(ref.rms_after_rad, 0.5 * ref.rms_before_rad);
  // Twelve directions 30 degrees apart determine them (zero here: no tilt drawn).
  Carpet twelve = TestCarpet();
  const std::vector<Frame> run12 = CarpetRun(twelve);
  AngleFit fit12;
  ASSERT_TRUE(FitImageAngle(run12, twelve, "carpet.json", rim, fit12, error)) << error;
  ASSERT_TRUE(RefineAngleOffset(run12, twelve, 4, rim, fit12).harmonics);
  for (double x : fit12.harmonics_rad) EXPECT_NEAR(x, 0.0, 0.0005);
  // Half a turn leaves a gap of over 45 degrees: harmonics there would be guesses; offset only.
  std::vector<Frame> half(frames.begin(), frames.begin() + kFrames / 2);
  AngleFit fit_half;
  ASSERT_TRUE(FitImageAngle(half, carpet, "carpet.json", rim, fit_half, error)) << error;
  const AngleRefinement ref_half = RefineAngleOffset(half, carpet, 4, rim, fit_half);
  EXPECT_TRUE(ref_half.applied);
  EXPECT_FALSE(ref_half.harmonics) << ref_half.max_gap_rad;
  for (double x : fit_half.harmonics_rad) EXPECT_EQ(x, 0.0);
}

TEST(CalibOmniSteps, ImageAngleErrors) {
  Carpet carpet = TestCarpet();
  std::vector<Frame> frames = CarpetRun(carpet);
  const RimFit rim{kCu, kCv, kRimPx};
  AngleFit fit;
  std::string error;
  carpet.azimuth_rad.erase(3);
  EXPECT_FALSE(FitImageAngle(frames, carpet, "c.json", rim, fit, error));
  EXPECT_EQ(error, "frame 3 has no carpet bearing in c.json");
  // Bearings that do not match the images.
  for (auto& [i, b] : carpet.azimuth_rad) b = (i * 7919 % 13) * 0.5;
  carpet.azimuth_rad[3] = 0;
  EXPECT_FALSE(FitImageAngle(frames, carpet, "c.json", rim, fit, error));
  EXPECT_NE(error.find("do not follow the bearings"), std::string::npos) << error;
}

TEST(CalibOmniSteps, SamplesNearTheCentreLineAndTheTwelveBestEdges) {
  Carpet carpet = TestCarpet();
  carpet.thickness_m = 0.01;
  const std::vector<Frame> frames = CarpetRun(carpet, 6);
  const RimFit rim{kCu, kCv, kRimPx};
  AngleFit fit;
  fit.sign = kSign;
  fit.offset_rad = kOffset;
  for (const Frame& f : frames) fit.theta_rad.push_back(carpet.azimuth_rad.at(f.index));
  const RawSamples raw = CollectSamples(frames, carpet, 4, rim, fit, 0.8);
  EXPECT_EQ(raw.rays, 6 * 25);
  EXPECT_GT(raw.rays_numbered, 6 * 10);
  ASSERT_FALSE(raw.samples.empty());
  const double zscale = 0.8 / (0.8 - 0.01);
  for (const Sample& s : raw.samples) {
    // The patch edges cross the strip square: off its centre line by delta, both the image
    // radius and the ground distance grow by 1 / cos(delta).
    const double delta = AngleDiff(kSign * (s.phi - kOffset), carpet.azimuth_rad.at(s.frame));
    EXPECT_NEAR(s.r_px * std::cos(delta), EdgeRadiusPx(s.carpet_edge),
                0.8);  // numbered: 11 px apart
    EXPECT_NEAR(s.d_m, carpet.edges_m[s.carpet_edge] / std::cos(delta) * zscale, 1e-9);
    EXPECT_LE(std::fabs(carpet.edges_m[s.carpet_edge] * std::tan(delta)), 0.2);
  }
  EdgeChoice edges;
  std::string error;
  ASSERT_TRUE(ChooseEdges(raw, carpet, edges, error)) << error;
  // Edge 0 borders grey (never seen): the 12 best start at 1 (ties keep the first).
  EXPECT_EQ(edges.first, 1);
  EXPECT_EQ(edges.edge_m[0], carpet.edges_m[1]);
  for (const Sample& s : edges.samples) {
    EXPECT_GE(s.carpet_edge, 1);
    EXPECT_LE(s.carpet_edge, 12);
  }
  EXPECT_TRUE(CheckEdgeCounts(edges, error)) << error;
  edges.per_edge[5] = 9;
  EXPECT_FALSE(CheckEdgeCounts(edges, error));
  EXPECT_EQ(error, "edge 2.25 m found only 9 times: the run misses directions or edges");

  carpet.edges_m.resize(11);
  RawSamples none;
  EXPECT_FALSE(ChooseEdges(none, carpet, edges, error));
  EXPECT_EQ(error, "the carpet has fewer than 12 edges");
}

// Samples of edge k at radius 40 + 10 k (+ `wobble` per sector), 3 per sector and edge.
std::vector<Sample> GridSamples(double wobble) {
  std::vector<Sample> out;
  for (int s = 0; s < kSectors; ++s) {
    const double phi = (s + 0.5) * 2 * kPi / kSectors;
    for (int k = 0; k < kEdges; ++k) {
      for (int j = 0; j < 3; ++j) {
        out.push_back({phi, 40 + 10.0 * k + wobble * std::cos(phi) + 0.1 * (j - 1), -1, 3 + k,
                       1.0 + 0.3 * k, 0});
      }
    }
  }
  return out;
}
std::array<double, kEdges> GridEdges() {
  std::array<double, kEdges> e{};
  for (int k = 0; k < kEdges; ++k) e[k] = 1.0 + 0.3 * k;
  return e;
}

TEST(CalibOmniSteps, SectorKMeansGivesTheSupportVectors) {
  std::vector<Sample> samples = GridSamples(2.0);
  samples[1].carpet_edge = 5;  // misnumbered by colour; k-means puts it back on edge 0
  const SectorFit fit = FitSectors(samples, 3, GridEdges());
  EXPECT_EQ(fit.moved, 1);
  EXPECT_EQ(samples[1].edge, 0);
  for (int s = 0; s < kSectors; ++s) {
    const double phi = (s + 0.5) * 2 * kPi / kSectors;
    for (int k = 0; k < kEdges; ++k) {
      EXPECT_TRUE(fit.have[s][k]);
      EXPECT_NEAR(fit.support[s][k], 40 + 10.0 * k + 2.0 * std::cos(phi), 1e-9);
    }
  }
  for (int k = 0; k < kEdges; ++k) EXPECT_NEAR(fit.global[k], 40 + 10.0 * k, 2.0);
}

TEST(CalibOmniSteps, SectorWithTooFewSamplesIsOccluded) {
  std::vector<Sample> kept;
  for (const Sample& x : GridSamples(0)) {
    if (!(static_cast<int>(x.phi / (2 * kPi / kSectors)) == 7 && x.carpet_edge == 3 + 4)) {
      kept.push_back(x);
    }
  }
  kept.push_back({(7 + 0.5) * 2 * kPi / kSectors, 80, -1, 7, 2.2, 0});  // 1 sample: too few
  const SectorFit fit = FitSectors(kept, 3, GridEdges());
  EXPECT_FALSE(fit.have[7][4]);
  EXPECT_TRUE(fit.have[7][3]);
  EXPECT_EQ(CompleteSectors(fit), kSectors - 1);
}

TEST(CalibOmniSteps, RejectsSupportVectorsOffTheHarmonicFit) {
  std::vector<Sample> samples = GridSamples(1.5);
  SectorFit fit = FitSectors(samples, 3, GridEdges());
  fit.support[11][6] += 8;
  EXPECT_EQ(RejectInconsistent(fit), 1);
  EXPECT_FALSE(fit.have[11][6]);
  EXPECT_EQ(CompleteSectors(fit), kSectors - 1);
}

TEST(CalibOmniSteps, InterpolatesFlagsAndSmooths) {
  SectorFit fit;
  for (int s = 0; s < kSectors; ++s) {
    for (int k = 0; k < kEdges; ++k) {
      fit.have[s][k] = true;
      fit.support[s][k] = 50 + 10.0 * k;
    }
  }
  fit.have[20][2] = fit.have[21][2] = false;
  fit.support[19][2] = 60;
  fit.support[22][2] = 90;
  OmniCalibration cal;
  InterpolateAndSmooth(fit, cal);
  EXPECT_DOUBLE_EQ(fit.support[20][2], 70);
  EXPECT_DOUBLE_EQ(fit.support[21][2], 80);
  for (int s = 0; s < kSectors; ++s) {
    EXPECT_EQ(cal.sector_flags[s], s == 20 || s == 21 ? kOmniSectorInterpolated : 0) << s;
  }
  // Median of 3 then mean of 3 across directions: a constant stays, the ramp is smoothed.
  EXPECT_FLOAT_EQ(cal.support_px[5][7], 120.0f);
  EXPECT_FLOAT_EQ(cal.support_px[20][2], (70.0f + 70 + 80) / 3);
}

TEST(CalibOmniSteps, SymmetricSupportIsTheMedianPerEdge) {
  std::vector<Sample> samples = GridSamples(3.0);
  const SectorFit fit = FitSectors(samples, 3, GridEdges());
  const auto sym = SymmetricSupport(samples, fit.global, GridEdges());
  for (int k = 0; k < kEdges; ++k) EXPECT_NEAR(sym[k], 40 + 10.0 * k, 0.3) << k;
  // An edge without samples reads 0, as the calibration file has always written it.
  for (Sample& x : samples) x.edge = x.edge == 4 ? 5 : x.edge;
  EXPECT_EQ(SymmetricSupport(samples, fit.global, GridEdges())[4], 0);
}

OmniCalibration ModelCal() {
  OmniCalibration c;
  c.valid = true;
  c.center_u = 320;
  c.center_v = 240;
  c.viewpoint_z_m = 0.8f;
  c.image_angle_sign = 1;
  c.image_angle_offset_rad = 0;
  for (int k = 0; k < kEdges; ++k) c.edge_ground_m[k] = 0.8f + 0.4f * k;
  for (int s = 0; s < kSectors; ++s)
    for (int k = 0; k < kEdges; ++k) c.support_px[s][k] = 40.0f + 12.0f * k;
  return c;
}

TEST(CalibOmniSteps, ResidualsAreZeroOnTheModelAndShowABias) {
  const OmniCalibration cal = ModelCal();
  std::vector<Sample> samples;
  for (int s = 0; s < kSectors; ++s) {
    const double phi = (s + 0.5) * 2 * kPi / kSectors;
    for (int k = 1; k + 1 < kEdges; ++k) {
      samples.push_back({phi, 40.0 + 12.0 * k, k, k, cal.edge_ground_m[k], 0});
    }
  }
  const RimFit rim{320, 240, 200};
  AngleFit fit;
  const Residuals res = ComputeResiduals(cal, cal, samples, rim, fit);
  ASSERT_EQ(res.sectors.size(), static_cast<size_t>(kSectors));
  EXPECT_EQ(res.sectors[0].samples, kEdges - 2);
  EXPECT_LT(res.rms_ground_rel, 1e-5);
  EXPECT_LT(res.sectors[3].rms_px, 1e-3);
  EXPECT_DOUBLE_EQ(res.rms_ground_rel, res.symmetric_rms_ground_rel);
  // The symmetric map 2 px too far out: ground distances too short.
  OmniCalibration sym = cal;
  for (auto& row : sym.support_px)
    for (float& r : row) r += 2;
  const Residuals biased = ComputeResiduals(cal, sym, samples, rim, fit);
  EXPECT_GT(biased.symmetric_rms_ground_rel, 0.01);
  EXPECT_LT(biased.rms_ground_rel, 1e-5);
}

TEST(CalibOmniSteps, SectionAndReport) {
  OmniCalibration cal = ModelCal();
  cal.sector_flags[4] = kOmniSectorInterpolated;
  std::array<double, kEdges> sym{};
  sym[3] = 77.5;
  Residuals res;
  res.sectors.resize(kSectors);
  res.sectors[4].interpolated = true;
  res.rms_ground_rel = 0.004;
  res.symmetric_rms_ground_rel = 0.02;
  const auto j = OmniSection(cal, 1234, 205.5, sym, res);
  EXPECT_EQ(j.at("samples"), 1234);
  EXPECT_EQ(j.at("rim_radius_px"), 205.5);
  EXPECT_EQ(j.at("symmetric_support_px").at(3), 77.5);
  EXPECT_EQ(j.at("rms_ground_rel"), 0.004);
  EXPECT_EQ(j.at("symmetric_rms_ground_rel"), 0.02);
  EXPECT_TRUE(j.contains("center_u"));

  const std::string dir = test::TempDir("omni_report") + "/r";
  const std::vector<Sample> samples = {{kPi / 2, 55.5, 2, 5, 1.6, 17}};
  std::string error;
  ASSERT_TRUE(WriteReport(dir, samples, cal, GridEdges(), sym, res, error)) << error;
  std::ifstream f(dir + "/omni_samples.csv");
  std::string header, row;
  std::getline(f, header);
  std::getline(f, row);
  EXPECT_EQ(header, "phi_deg,r_px,edge,edge_m,d_m,frame");
  EXPECT_EQ(row, "90,55.5,2,1.6,1.6,17");
  for (const char* name : {"omni_support.csv", "omni_symmetric.csv", "omni_residuals.json"}) {
    EXPECT_TRUE(std::filesystem::exists(dir + "/" + name)) << name;
  }
  const auto residuals = nlohmann::json::parse(std::ifstream(dir + "/omni_residuals.json"));
  EXPECT_EQ(residuals.size(), static_cast<size_t>(kSectors));
  EXPECT_EQ(residuals.at(4).at("interpolated"), true);
}

}  // namespace
}  // namespace bv::cli::omni
