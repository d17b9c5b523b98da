// `calibrate omni`: the model-free omni calibration (paper section III-B) from a carpet run.
// The steps and their order are described in calib_omni_steps.h; this file parses, calls them
// and prints what each found.
#include "tools/ballvision/calib_omni.h"

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "tools/ballvision/calib_io.h"
#include "tools/ballvision/calib_omni_selfmask.h"
#include "tools/ballvision/calib_omni_steps.h"
#include "tools/ballvision/carpet_json.h"
#include "tools/ballvision/cli_args.h"
#include "tools/ballvision/signals.h"

namespace bv::cli {
namespace {

namespace fs = std::filesystem;
using namespace omni;  // NOLINT: the steps of this command

constexpr double kPi = 3.14159265358979323846;

constexpr char kUsage[] =
    "usage: ballvision calibrate omni SEQ --carpet SEQ/carpet.json --viewpoint-z F_O\n"
    "         --out CALIB.json [--report DIR]\n"
    "  F_O: mirror viewpoint height (m), a mechanical constant of the rig\n"
    "  --report DIR: samples, support vectors, residuals as CSV (plot with\n"
    "                tools/python/plot_omni_calib.py DIR)\n";

struct OmniArgs {
  std::string seq, carpet_path, out, report;
  double f_o = 0;
};

// Returns -1 to go on, else the exit code.
int ParseArgs(int argc, char** argv, OmniArgs& a) {
  ArgParser p("ballvision calibrate omni", kUsage);
  p.Positional("SEQ", a.seq)
      .Text("--carpet", a.carpet_path)
      .Text("--out", a.out)
      .Required("--out")
      .Text("--report", a.report)
      .Custom(
          "--viewpoint-z",
          [&a](const std::string& v, std::string& error) {
            if (ArgNumber("--viewpoint-z", v, 0.05, 5, a.f_o, error) && a.f_o > 0.05 && a.f_o < 5) {
              return true;
            }
            error = "--viewpoint-z: got '" + v +
                    "', expected the mirror viewpoint height in metres in (0.05, 5)";
            return false;
          })
      .Required("--viewpoint-z");
  if (const int rc = p.Parse(argc, argv); rc >= 0) return rc;
  if (a.carpet_path.empty()) a.carpet_path = (fs::path(a.seq) / "carpet.json").string();
  return -1;
}

int Fail(const std::string& error) {
  std::fprintf(stderr, "calibrate omni: %s; no calibration written\n", error.c_str());
  return 1;
}

void PrintResiduals(const Residuals& res) {
  std::printf(
      "sector  deg        n  flag  rms_px  rms_ground_%%  max_ground_%%  symmetric_rms_%%\n");
  for (int s = 0; s < kSectors; ++s) {
    const SectorResidual& r = res.sectors[s];
    std::printf("%4d  %3d-%3d  %5d  %4s  %6.3f  %11.3f  %12.3f  %15.3f\n", s, s * 8, s * 8 + 8,
                r.samples, r.interpolated ? "int" : "", r.rms_px, 100 * r.rms_ground_rel,
                100 * r.max_ground_rel, 100 * r.symmetric_rms_ground_rel);
  }
  std::printf("all samples: ground-distance rms %.3f %% (model-free) vs %.3f %% (symmetric fit)\n",
              100 * res.rms_ground_rel, 100 * res.symmetric_rms_ground_rel);
}

void PrintRefinement(const AngleRefinement& refined, const AngleFit& angle) {
  if (refined.applied) {
    std::printf("angle offset refined by %+.3f deg from the strip sides (%zu fans): %+.3f deg\n",
                refined.correction_rad * 180 / kPi, refined.fans, angle.offset_rad * 180 / kPi);
  }
  if (refined.harmonics) {
    std::printf(
        "azimuth harmonics (mirror tilt) a1 %+.2f b1 %+.2f a2 %+.2f b2 %+.2f mrad: fan residual "
        "rms %.2f -> %.2f mrad (%zu outliers)\n",
        angle.harmonics_rad[0] * 1e3, angle.harmonics_rad[1] * 1e3, angle.harmonics_rad[2] * 1e3,
        angle.harmonics_rad[3] * 1e3, refined.rms_before_rad * 1e3, refined.rms_after_rad * 1e3,
        refined.harmonic_outliers);
  } else if (refined.applied) {
    std::printf("azimuth harmonics not fitted: %zu fans, largest direction gap %.0f deg\n",
                refined.fans, refined.max_gap_rad * 180 / kPi);
  }
}

// Centre, viewpoint, image angle and edge distances; the support vectors come from the sectors.
OmniCalibration FittedGeometry(const RimFit& rim, const AngleFit& angle, const EdgeChoice& edges,
                               double f_o) {
  OmniCalibration cal;
  cal.valid = true;
  cal.center_u = static_cast<float>(rim.cu);
  cal.center_v = static_cast<float>(rim.cv);
  cal.viewpoint_z_m = static_cast<float>(f_o);
  cal.image_angle_sign = static_cast<int8_t>(angle.sign);
  cal.image_angle_offset_rad = static_cast<float>(angle.offset_rad);
  for (int k = 0; k < 4; ++k) {
    cal.azimuth_harmonics_rad[k] = static_cast<float>(angle.harmonics_rad[k]);
  }
  for (int k = 0; k < kEdges; ++k) cal.edge_ground_m[k] = static_cast<float>(edges.edge_m[k]);
  PrepareOmniAngles(cal);
  return cal;
}

}  // namespace

int CalibrateOmni(int argc, char** argv) {
  OmniArgs a;
  if (const int rc = ParseArgs(argc, argv, a); rc >= 0) return rc;
  std::string error;
  Carpet carpet;
  std::vector<Frame> frames;
  if (!LoadCarpet(a.carpet_path, carpet, error) || !LoadFrames(a.seq, frames, error)) {
    return Fail(error);
  }
  const int anchor = AnchorPatch(carpet);
  if (anchor < 0) {
    return Fail(
        "the carpet needs one uniquely coloured patch (after the first) to number the "
        "edges");
  }

  RimFit rim;
  if (!FindCentre(frames, rim, error)) return Fail(error);
  std::printf("image centre (mirror rim circle): (%.2f, %.2f) px, rim radius %.1f px\n", rim.cu,
              rim.cv, rim.radius);
  SelfMaskResult self;
  if (!LearnSelfMask(frames, rim, self, error)) return Fail(error);
  std::printf("self-mask: %.1f %% of the mirror ring never changed; %s\n",
              100.0 * self.unchanged_fraction, SelfMaskSummary(self.mask).c_str());

  AngleFit angle;
  if (!FitImageAngle(frames, carpet, a.carpet_path, rim, angle, error)) return Fail(error);
  std::printf("image angle = %+d * robot azimuth %+.2f deg (consistency %.4f over %zu frames)\n",
              angle.sign, angle.offset_rad * 180 / kPi, angle.consistency, frames.size());
  const AngleRefinement refined = RefineAngleOffset(frames, carpet, anchor, rim, angle);
  PrintRefinement(refined, angle);

  const RawSamples raw = CollectSamples(frames, carpet, anchor, rim, angle, a.f_o);
  EdgeChoice edges;
  if (!ChooseEdges(raw, carpet, edges, error)) return Fail(error);
  std::printf("%d rays, %d numbered by the red patch, %zu samples of edges %.2f..%.2f m\n",
              raw.rays, raw.rays_numbered, edges.samples.size(), edges.edge_m[0],
              edges.edge_m[kEdges - 1]);
  if (!CheckEdgeCounts(edges, error)) return Fail(error);
  if (edges.samples.size() < 1000) {
    std::fprintf(stderr, "calibrate omni: warning: only %zu samples (paper: over 1000)\n",
                 edges.samples.size());
  }

  OmniCalibration cal = FittedGeometry(rim, angle, edges, a.f_o);
  cal.self_mask = self.mask;
  SectorFit sectors = FitSectors(edges.samples, edges.first, edges.edge_m);
  std::printf("%d support vectors rejected as inconsistent with their neighbours\n",
              RejectInconsistent(sectors));
  const int complete = CompleteSectors(sectors);
  if (complete < kSectors / 2) {
    return Fail("only " + std::to_string(complete) + " of " + std::to_string(kSectors) +
                " directions have samples of all 12 edges (the run misses directions)");
  }
  InterpolateAndSmooth(sectors, cal);

  const auto sym = SymmetricSupport(edges.samples, sectors.global, edges.edge_m);
  OmniCalibration symcal = cal;
  for (int s = 0; s < kSectors; ++s)
    for (int k = 0; k < kEdges; ++k) symcal.support_px[s][k] = static_cast<float>(sym[k]);
  std::printf("%zu samples; k-means moved %d samples to another edge than the colour numbering\n",
              edges.samples.size(), sectors.moved);
  const Residuals res = ComputeResiduals(cal, symcal, edges.samples, rim, angle);
  PrintResiduals(res);

  if (!a.report.empty()) {
    if (!WriteReport(a.report, edges.samples, cal, edges.edge_m, sym, res, error)) {
      std::fprintf(stderr, "calibrate omni: report: %s\n", error.c_str());
      return 1;
    }
    std::printf("report written to %s\n", a.report.c_str());
  }
  auto section = OmniSection(cal, edges.samples.size(), rim.radius, sym, res);
  section["self_mask"]["unchanged_fraction"] = self.unchanged_fraction;
  section["self_mask"]["frames"] = static_cast<int>(frames.size());
  if (InterruptSignal()) return 1;  // CmdCalibrate reports it; nothing written
  if (!UpdateCalibrationSection(a.out, "omni", section, error)) {
    std::fprintf(stderr, "calibrate omni: %s\n", error.c_str());
    return 1;
  }
  std::printf("wrote omni section of %s\n", a.out.c_str());
  return 0;
}

}  // namespace bv::cli
