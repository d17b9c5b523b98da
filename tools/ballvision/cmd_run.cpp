// `ballvision run`, `eval` and `demo`: the full pipeline on captured sequences, its error
// tables against truth.csv, and a self-contained demonstration.
#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/pipeline.h"
#include "hal/host/sequence.h"
#include "tools/ballvision/calib_io.h"
#include "tools/ballvision/cli_args.h"
#include "tools/ballvision/commands.h"
#include "tools/ballvision/demo_scene.h"
#include "tools/ballvision/plot.h"
#include "tools/ballvision/run_common.h"
#include "tools/ballvision/run_pipeline.h"
#include "tools/ballvision/safe_write.h"
#include "tools/ballvision/signals.h"
#include "tools/ballvision/states_csv.h"
#include "tools/ballvision/strict_json.h"
#include "tools/ballvision/truth_csv.h"

namespace bv::cli {
namespace {

struct Args {
  std::string seq, calib, out, lut, annotate, plots, features, paths, sigma_errors, ball;
  std::string classifier;
  int predict_ms = -1;
  double at_ms = -1;
  double bounce_factor = -1;
  int frames = 75;
  bool stills = false;
};

constexpr char kRunUsage[] =
    "usage: ballvision run SEQ --calib FILE [--out states.csv] [--predict-ms N]\n"
    "       [--lut FILE] [--ball red|orange|yellow] [--classifier FILE|builtin|off]\n"
    "       [--annotate DIR] [--features DIR] [--stills] [--bounce-factor B (0.7)]\n"
    "  --lut      colour LUT blob, or 'builtin'; default $BV_LUT, then\n"
    "             <calib dir>/luts/*.lut, then the built-in colour model's table\n"
    "  --ball     the built-in model of this match ball (red: red to orange-red, the default;\n"
    "             orange; yellow: today's MSL ball)\n"
    "  --classifier  the persp candidates' appearance classifier (default builtin)\n"
    "  --stills   frames are unrelated stills: no tracking across frames\n"
    "  --features DIR  field features per frame: DIR/lines.csv (index,x,y) and\n"
    "             DIR/obstacles.csv (index,x,y,radius), robot frame, metres\n"
    "  --paths FILE  per frame with the ball, the filter's prediction from then on:\n"
    "             index,kind,t_us,x,y,z with kind 'path' every 50 ms for 2.5 s and\n"
    "             'contact' for each predicted floor contact (robot frame, metres)\n";
constexpr char kEvalUsage[] =
    "usage: ballvision eval SEQ --calib FILE [--lut FILE] [--ball NAME] [--plots DIR]\n"
    "       [--classifier FILE|builtin|off]\n"
    "       [--predict-ms N (200)] [--at-ms T (prediction plot start)]\n"
    "       [--bounce-factor B (0.7)] [--out states.csv] [--annotate DIR] [--stills]\n"
    "       [--sigma-errors FILE]\n"
    "  --sigma-errors FILE  per state axis scored for the uncertainty: index,phase,axis,\n"
    "             error_m,sigma_m (to pool the calibration over several sequences)\n";
constexpr char kDemoUsage[] =
    "usage: ballvision demo [--out DIR (./demo_out)] [--frames N (75)]\n"
    "Draws a bouncing lob and a static grid through the built-in reference-rig\n"
    "calibration, runs the full pipeline, prints the ball states and writes\n"
    "states.csv and the plots (Fig. 4 and Fig. 5 style) to DIR.\n";

// The options `run` and `eval` share.
void PipelineOptions(ArgParser& p, Args& a) {
  p.Positional("SEQ", a.seq)
      .Text("--calib", a.calib)
      .Required("--calib")
      .Text("--out", a.out)
      .Text("--lut", a.lut)
      .Text("--ball", a.ball)
      .Text("--classifier", a.classifier)
      .Text("--annotate", a.annotate)
      .Flag("--stills", a.stills)
      .Int("--predict-ms", 0, 1000000, a.predict_ms)
      .Custom("--bounce-factor", [&a](const std::string& v, std::string& error) {
        // Open interval: 0 stops the ball at the first bounce, 1 never loses energy.
        if (!ArgNumber("--bounce-factor", v, 0, 1, a.bounce_factor, error) ||
            a.bounce_factor <= 0 || a.bounce_factor >= 1) {
          error = "--bounce-factor: got '" + v + "', expected a number in (0, 1)";
          return false;
        }
        return true;
      });
}

// Everything `run` and `eval` share: sequence, calibration, LUT, pipeline.
struct Setup {
  host::Sequence seq;
  RigCalibration cal;
  ColorLut lut;
  BallClassifier classifier;
  std::unique_ptr<OwnedPipeline> pipeline = std::make_unique<OwnedPipeline>();
  PipelineConfig config;
};

bool Prepare(const Args& a, const char* cmd, Setup& s) {
  std::string err, used;
  if (!host::LoadSequence(a.seq, s.seq, err)) {
    std::fprintf(stderr, "ballvision %s: %s\n", cmd, err.c_str());
    return false;
  }
  if (!LoadCalibrationFile(a.calib, s.cal, err)) {
    std::fprintf(stderr, "ballvision %s: %s\n", cmd, err.c_str());
    return false;
  }
  if (!LoadLutOrDefault(a.lut, a.calib, s.lut, used, err, a.ball) ||
      !LoadClassifierArg(a.classifier, s.classifier, err)) {
    std::fprintf(stderr, "ballvision %s: %s\n", cmd, err.c_str());
    return false;
  }
  std::fprintf(stderr, "colour LUT: %s\n", used.c_str());
  s.config.classifier = s.classifier.loaded() ? &s.classifier : nullptr;
  if (a.predict_ms >= 0) s.config.predict_ahead_us = static_cast<uint32_t>(a.predict_ms) * 1000u;
  if (a.bounce_factor > 0) s.config.filter.bounce_factor = static_cast<float>(a.bounce_factor);
  const Status st = s.pipeline->Init(s.cal, s.lut, s.config);
  if (!st.ok()) {
    std::fprintf(stderr, "ballvision %s: pipeline: %s\n", cmd, st.message());
    return false;
  }
  return true;
}

bool WriteStates(const std::string& path, const std::vector<FrameRecord>& recs, bool predict,
                 std::string& error) {
  // Pose columns when the pipeline localised itself (DESIGN.md §4).
  const bool pose = !recs.empty() && recs.front().field_features;
  std::string text = StatesCsvHeader(predict);
  if (pose) text.insert(text.size() - 1, kStatesPoseHeader);
  for (const auto& r : recs) {
    std::string row = StatesCsvRow(r.index, r.state, predict);
    if (pose) {
      row.insert(row.size() - 1,
                 StatesCsvPose(r.pose.usable(), r.pose.x_m, r.pose.y_m, r.pose.heading_rad));
    }
    text += row;
  }
  if (path.empty() || path == "-") {
    if (std::fputs(text.c_str(), stdout) < 0 || std::fflush(stdout) != 0) {
      error = std::string("writing states to standard output failed: ") + std::strerror(errno);
      return false;
    }
    return true;
  }
  return WriteFileAtomic(path, text, error);
}

// The prediction the filter holds after a frame (the studio's top view and Fig. 5 plot).
void AppendPaths(const Pipeline& pl, const FrameRecord& r, std::string& out) {
  if (!r.state.found) return;
  char row[160];
  const auto add = [&](const char* kind, uint64_t t, float x, float y, float z) {
    std::snprintf(row, sizeof row, "%lld,%s,%llu,%.4f,%.4f,%.4f\n", static_cast<long long>(r.index),
                  kind, static_cast<unsigned long long>(t), x, y, z);
    out += row;
  };
  for (int k = 0; k <= 50; ++k) {
    const uint64_t t = r.state.t_us + static_cast<uint64_t>(k) * 50000u;
    Eigen::Vector3f p, v;
    BallMode m;
    if (pl.filter().StateAt(t, p, v, m)) add("path", t, p.x(), p.y(), p.z());
  }
  uint64_t tc[8];
  float xs[8], ys[8];
  const int nc = pl.filter().ContactsAfter(r.state.t_us, tc, xs, ys, 8);
  for (int i = 0; i < nc; ++i) add("contact", tc[i], xs[i], ys[i], 0.f);
}

const char* MeasKind(const BallState& s) {
  if (s.flags & kFlagTriangulated) return "tri";
  if (s.flags & kFlagOmniGroundFallback) return "omni";
  if (s.flags & kFlagPerspSizeFallback) return "size";
  return "-";
}

}  // namespace

int CmdRun(int argc, char** argv) {
  Args a;
  ArgParser p("ballvision run", kRunUsage);
  PipelineOptions(p, a);
  p.Text("--features", a.features).Text("--paths", a.paths);
  if (const int rc = p.Parse(argc, argv); rc >= 0) return rc;
  std::string err;
  Setup s;
  if (!Prepare(a, "run", s)) return 1;
  RunSettings rs;
  rs.progress = s.seq.entries.size() >= 30;
  rs.reset_each_frame = a.stills;
  rs.annotate_dir = a.annotate;
  rs.features_dir = a.features;
  std::string paths = "index,kind,t_us,x,y,z\n";
  if (!a.paths.empty()) {
    rs.on_frame = [&paths](const Pipeline& pl, const FrameRecord& r) { AppendPaths(pl, r, paths); };
  }
  std::vector<FrameRecord> recs;
  InstallInterruptHandlers();
  if (!RunSequence(s.seq, *s.pipeline, rs, recs, err) ||
      !WriteStates(a.out, recs, a.predict_ms >= 0, err) ||
      (!a.paths.empty() && !WriteFileAtomic(a.paths, paths, err))) {
    std::fprintf(stderr, "ballvision run: %s\n", err.c_str());
    return 1;
  }
  int found = 0, tri = 0;
  for (const auto& r : recs) {
    found += r.state.found;
    tri += (r.state.flags & kFlagTriangulated) != 0;
  }
  std::fprintf(stderr, "%zu frames, ball found in %d, triangulated in %d%s%s\n", recs.size(), found,
               tri, a.out.empty() ? "" : ", states in ", a.out.c_str());
  // A camera that froze, went blind or stopped (core/health): said, never silent.
  for (const bool omni : {true, false}) {
    int refused = 0, unusable = 0, first = -1;
    for (const auto& r : recs) {
      const CameraCheck& c = omni ? r.state.omni_check : r.state.persp_check;
      refused += c.faults != 0 && !(c.faults & kCameraMissing);
      if (c.state == CameraState::kUnusable && unusable++ == 0) first = static_cast<int>(r.index);
    }
    if (refused + unusable == 0) continue;
    std::fprintf(stderr,
                 "%s camera: %d frame(s) refused (repeated, stale or blind), unusable in %d%s\n",
                 omni ? "omni" : "persp", refused, unusable,
                 first < 0 ? "" : (", first at frame " + std::to_string(first)).c_str());
  }
  if (InterruptSignal()) {
    ReportInterrupt("ballvision run");
    return InterruptExitCode();
  }
  return 0;
}

namespace {

struct Truth {
  bool has = false;
  double x = 0, y = 0, z = 0, vx = 0, vy = 0, vz = 0;
  std::string state;
};

// Strict: a garbage truth.csv is an error naming the line, not "0 with a ball in truth".
bool ReadTruth(const std::string& path, std::map<uint64_t, Truth>& out, std::string& error) {
  TruthCsv csv;
  if (!csv.Load(path, {"t_us", "ball_x", "ball_y", "ball_z"}, error)) return false;
  for (size_t i = 0; i < csv.rows(); ++i) {
    int64_t tu = 0;
    Truth tr;
    if (!csv.Integer(i, "t_us", 0, INT64_MAX, tu, error)) return false;
    tr.has = !csv.Empty(i, "ball_x");
    const std::pair<const char*, double*> pos[] = {
        {"ball_x", &tr.x}, {"ball_y", &tr.y}, {"ball_z", &tr.z}};
    for (const auto& [c, v] : pos) {
      if (!csv.Number(i, c, *v, /*allow_empty=*/!tr.has, error)) return false;
    }
    if (!csv.Number(i, "ball_vx", tr.vx, true, error) ||
        !csv.Number(i, "ball_vy", tr.vy, true, error) ||
        !csv.Number(i, "ball_vz", tr.vz, true, error)) {
      return false;
    }
    tr.state = csv.Text(i, "ball_state");
    if (!out.emplace(static_cast<uint64_t>(tu), tr).second) {
      error = csv.Where(i) + ": duplicate t_us " + std::to_string(tu);
      return false;
    }
  }
  return true;
}

// The static grid's cells: index, distance_m, z_m (and bearing_deg, 0 when absent).
struct GridRow {
  int64_t index = 0;
  double d_m = 0, z_m = 0, bearing_deg = 0;
};
// Strict: every row must be usable, or the file is refused.
bool ReadGridCsv(const std::string& path, std::vector<GridRow>& rows, std::string& error) {
  TruthCsv csv;
  if (!csv.Load(path, {"index", "distance_m", "z_m"}, error)) return false;
  for (size_t i = 0; i < csv.rows(); ++i) {
    GridRow r;
    if (!csv.Integer(i, "index", INT64_MIN, INT64_MAX, r.index, error) ||
        !csv.Number(i, "distance_m", r.d_m, false, error) ||
        !csv.Number(i, "z_m", r.z_m, false, error) ||
        !csv.Number(i, "bearing_deg", r.bearing_deg, true, error)) {
      return false;
    }
    rows.push_back(r);
  }
  return true;
}

const Truth* TruthAt(const std::map<uint64_t, Truth>& m, uint64_t t_us) {
  auto it = m.lower_bound(t_us > 1000 ? t_us - 1000 : 0);
  if (it == m.end() || it->first > t_us + 1000 || !it->second.has) return nullptr;
  return &it->second;
}

double Dist3(const BallState& s, const Truth& t) {
  return std::sqrt((s.x_m - t.x) * (s.x_m - t.x) + (s.y_m - t.y) * (s.y_m - t.y) +
                   (s.z_m - t.z) * (s.z_m - t.z));
}

double Dist3(const Eigen::Vector3f& p, const Truth& t) {
  return std::sqrt((p.x() - t.x) * (p.x() - t.x) + (p.y() - t.y) * (p.y() - t.y) +
                   (p.z() - t.z) * (p.z() - t.z));
}

std::string Joined(const std::vector<std::string>& files) {
  std::string out;
  for (const auto& f : files) out += (out.empty() ? "" : ", ") + f;
  return out;
}

// What a plot request wrote (PNGs, or tables and why) or why it failed; the figures printed
// before stand either way, so eval carries on.
void PrintPlots(const char* cmd, const PlotOutcome& o) {
  if (!o.ok) {
    std::fprintf(stderr, "%s: %s\n", cmd, o.error.c_str());
    return;
  }
  if (!o.note.empty()) std::fprintf(stderr, "%s: %s\n", cmd, o.note.c_str());
  std::printf("wrote %s\n", Joined(o.written).c_str());
}

// Paper Fig. 4: per ball height, the 3D error of the measurement and of the omni-only "2D"
// estimate against the distance.
struct GridCell {
  double d_m, e3_cm, e2_cm;
};
using Fig4Cells = std::map<double, std::vector<GridCell>>;  // by height (m), distance ascending

std::vector<PlotSeries> Fig4Series(const Fig4Cells& cells) {
  const uint8_t colors[3][3] = {{200, 30, 30}, {30, 140, 30}, {30, 60, 200}};
  std::vector<PlotSeries> series;
  int ci = 0;
  for (const auto& [h, row] : cells) {
    PlotSeries s3, s2;
    char name[64];
    std::snprintf(name, sizeof name, "3D z=%.0fcm", h * 100);
    s3.name = name;
    std::snprintf(name, sizeof name, "2D (omni only) z=%.0fcm", h * 100);
    s2.name = name;
    for (const GridCell& c : row) {
      s3.x.push_back(c.d_m);
      s3.y.push_back(c.e3_cm);
      s2.x.push_back(c.d_m);
      s2.y.push_back(c.e2_cm);
    }
    const uint8_t* c = colors[ci++ % 3];
    s3.r = s2.r = c[0];
    s3.g = s2.g = c[1];
    s3.b = s2.b = c[2];
    s3.style = PlotSeries::kLinePoints;
    s2.style = PlotSeries::kDashed;
    series.push_back(s3);
    if (h > 0.15) series.push_back(s2);  // on the floor the 2D estimate is the same idea
  }
  return series;
}

// Paper Fig. 5 left: true and estimated height and vertical velocity over time. The truth as
// time, z, vz; the estimate from the records (a gap where the ball was not found).
std::vector<PlotSeries> Fig5Series(const std::vector<double>& t_s, const std::vector<double>& z,
                                   const std::vector<double>& vz,
                                   const std::vector<FrameRecord>& recs) {
  PlotSeries zt{"true height", t_s, z, 0, 160, 0}, ze{"estimated height", {}, {}, 220, 30, 30};
  PlotSeries vt{"true vz", t_s, vz, 240, 150, 0}, ve{"estimated vz", {}, {}, 30, 60, 220};
  ze.style = ve.style = PlotSeries::kLinePoints;
  for (const auto& r : recs) {
    ze.x.push_back(r.state.t_us * 1e-6);
    ze.y.push_back(r.state.found ? r.state.z_m : NAN);
    ve.x.push_back(r.state.t_us * 1e-6);
    ve.y.push_back(r.state.found ? r.state.vz_mps : NAN);
  }
  return {zt, ze, vt, ve};
}

// Paper Fig. 5 right: the height the filter predicts from `from_us` on, every 10 ms.
struct Prediction {
  std::vector<double> t_s, z;
};
Prediction SamplePrediction(const BallFilter& filter, uint64_t from_us, int steps) {
  Prediction out;
  for (int k = 0; k <= steps; ++k) {
    const uint64_t t = from_us + static_cast<uint64_t>(k) * 10000;
    Eigen::Vector3f pp, vv;
    BallMode m;
    if (filter.StateAt(t, pp, vv, m)) {
      out.t_s.push_back(t * 1e-6);
      out.z.push_back(pp.z());
    }
  }
  return out;
}

// The omni pixel whose (extended) ray points at p: OmniProject below the distance map's reach,
// otherwise Newton on the ray's direction from the pixel of a nearer point in that direction
// (a raised ball far out is seen beyond the map).
bool OmniPixelOf(const OmniCalibration& cal, const Eigen::Vector3f& p, float& u, float& v) {
  if (OmniProject(cal, p, u, v).ok()) return true;
  const Eigen::Vector3f o(0.f, 0.f, cal.viewpoint_z_m);
  const Eigen::Vector3f want = (p - o).normalized();
  bool start = false;
  for (float f = 0.9f; f > 0.1f && !start; f -= 0.1f) {
    start = OmniProject(cal, Eigen::Vector3f(p.x() * f, p.y() * f, 0.1f), u, v).ok();
  }
  if (!start) return false;
  const auto err = [&](float uu, float vv, Eigen::Vector2f& e) {
    auto r = OmniPixelToRayExtended(cal, uu, vv);
    if (!r.ok()) return false;
    const Eigen::Vector3f d = r->dir - want;
    e = Eigen::Vector2f(d.x() * want.y() - d.y() * want.x(), d.z());  // across, up
    return true;
  };
  for (int it = 0; it < 12; ++it) {
    Eigen::Vector2f e, eu, ev;
    if (!err(u, v, e) || !err(u + 0.5f, v, eu) || !err(u, v + 0.5f, ev)) return false;
    if (e.norm() < 1e-6f) return true;
    const Eigen::Vector2f ju = (eu - e) / 0.5f, jv = (ev - e) / 0.5f;  // Jacobian columns
    const float det = ju.x() * jv.y() - jv.x() * ju.y();
    if (!(std::fabs(det) > 1e-12f)) return false;
    const Eigen::Vector2f step((jv.y() * e.x() - jv.x() * e.y()) / det,
                               (ju.x() * e.y() - ju.y() * e.x()) / det);
    u -= std::clamp(step.x(), -20.f, 20.f);
    v -= std::clamp(step.y(), -20.f, 20.f);
  }
  Eigen::Vector2f e;
  return err(u, v, e) && e.norm() < 1e-4f;
}

// The rig's geometric limit at p: how far the two-ray midpoint moves when one camera's image of
// the centre moves by the pixel grid's own uncertainty (rounding to the nearest pixel: 1/sqrt(12)
// px), in u or in v; the four moves added in quadrature. NaN where a camera does not see p.
double GeometricLimitM(const RigCalibration& cal, const Eigen::Vector3f& p) {
  float uo, vo, up, vp;
  if (!OmniPixelOf(cal.omni, p, uo, vo) || !PerspProject(cal.persp, p, up, vp).ok()) return NAN;
  const float h = 0.2887f;
  const auto rays = [&](float du_o, float dv_o, float du_p, float dv_p) -> Result<Triangulation> {
    auto o = OmniPixelToRayExtended(cal.omni, uo + du_o, vo + dv_o);
    auto q = PerspPixelToRay(cal.persp, up + du_p, vp + dv_p);
    if (!o.ok() || !q.ok()) return Status(StatusCode::kOutOfRange, "no ray");
    return TriangulateRays(*q, *o);
  };
  const auto base = rays(0, 0, 0, 0);
  if (!base.ok()) return NAN;
  double sum = 0;
  for (const auto& [du_o, dv_o, du_p, dv_p] :
       {std::array<float, 4>{h, 0, 0, 0}, {0, h, 0, 0}, {0, 0, h, 0}, {0, 0, 0, h}}) {
    const auto moved = rays(du_o, dv_o, du_p, dv_p);
    if (!moved.ok()) return NAN;
    sum += (moved->point - base->point).squaredNorm();
  }
  return std::sqrt(sum);
}

// The static-grid goal per cell: the filter's state within max(1.5 x the geometric
// limit, 3 cm), and within 5 cm at 0.5 m.
void PrintGridAgainstLimit(const RigCalibration& cal, const std::vector<GridRow>& grid,
                           const std::map<int64_t, const FrameRecord*>& by_index,
                           const std::map<uint64_t, Truth>& truth) {
  std::printf(
      "\nState (filter) against the rig's geometric limit (each camera's centre to the nearest "
      "pixel)\n");
  std::printf("%6s %6s %6s | %9s %9s %9s | %s\n", "dist_m", "h_m", "brg", "state_cm", "limit_cm",
              "bound_cm", "within");
  int cells = 0, within = 0;
  for (const GridRow& row : grid) {
    auto it = by_index.find(row.index);
    if (it == by_index.end()) continue;
    const FrameRecord& r = *it->second;
    const Truth* t = TruthAt(truth, r.state.t_us);
    if (!t) continue;
    const double e = r.state.found ? Dist3(r.state, *t) : NAN;
    const double limit =
        GeometricLimitM(cal, Eigen::Vector3f(static_cast<float>(t->x), static_cast<float>(t->y),
                                             static_cast<float>(t->z)));
    double bound = std::max(std::isfinite(limit) ? 1.5 * limit : 0.0, 0.03);
    if (row.d_m < 0.51) bound = std::min(bound, 0.05);
    const bool ok = std::isfinite(e) && e <= bound;
    ++cells;
    within += ok;
    std::printf("%6.2f %6.2f %6.0f | %9.2f %9.2f %9.2f | %s\n", row.d_m, row.z_m, row.bearing_deg,
                e * 100, limit * 100, bound * 100, ok ? "yes" : "NO");
  }
  std::printf("cells within max(1.5 x limit, 3 cm), <= 5 cm at 0.5 m: %d of %d\n", within, cells);
}

// Static grid: per distance x height the 3D error of the measurement (no filter, no ground
// constraint) and of the omni-only "2D" estimate (paper Fig. 4).
void EvalGrid(const Args& a, const RigCalibration& cal, const std::vector<GridRow>& grid,
              const std::vector<FrameRecord>& recs, const std::map<uint64_t, Truth>& truth) {
  std::map<int64_t, const FrameRecord*> by_index;
  for (const auto& r : recs) by_index[r.index] = &r;
  std::map<double, std::map<double, std::pair<double, double>>> cell;  // h -> d -> (3d, 2d)
  std::printf("\n3D error of the per-frame measurement (paper Fig. 4), static_grid\n");
  std::printf("%6s %6s %6s | %9s %-5s | %9s | %7s\n", "dist_m", "h_m", "brg", "err3d_cm", "kind",
              "err2d_cm", "gap_cm");
  for (const GridRow& row : grid) {
    const double d = row.d_m, h = row.z_m, brg = row.bearing_deg;
    auto it = by_index.find(row.index);
    if (it == by_index.end()) continue;
    const FrameRecord& r = *it->second;
    const Truth* t = TruthAt(truth, r.state.t_us);
    if (!t) continue;
    double e3 = NAN, e2 = NAN;
    if (r.meas.valid) e3 = Dist3(r.meas.p_m, *t);
    if (r.meas.omni_ground_valid) e2 = Dist3(r.meas.omni_ground_m, *t);
    cell[h][d] = {e3, e2};
    char gap[32] = "";
    if (r.state.ray_gap_m >= 0) std::snprintf(gap, sizeof gap, "%.2f", r.state.ray_gap_m * 100);
    std::printf("%6.2f %6.2f %6.0f | %9.2f %-5s | %9.2f | %7s\n", d, h, brg, e3 * 100,
                MeasKind(r.state), e2 * 100, gap);
  }
  PrintGridAgainstLimit(cal, grid, by_index, truth);
  // Goal table: median over bearings for each distance band.
  std::printf("\nGoals: median 3D error <= 3 cm at <= 2 m, <= 15 cm at 5 m\n");
  std::printf("%8s", "h_m");
  for (const char* band : {"<=2m", "2.5-4m", "4.5-5m", "5.5m"}) std::printf(" %10s", band);
  std::printf("\n");
  for (const auto& [h, ds] : cell) {
    std::vector<double> b[4];
    for (const auto& [d, e] : ds) {
      const int k = d <= 2.01 ? 0 : d <= 4.01 ? 1 : d <= 5.01 ? 2 : 3;
      b[k].push_back(std::isfinite(e.first) ? e.first : 1e9);
    }
    std::printf("%8.2f", h);
    for (auto& v : b) std::printf(" %8.2fcm", v.empty() ? NAN : Median(v) * 100);
    std::printf("\n");
  }
  if (a.plots.empty()) return;
  Fig4Cells cells;
  for (const auto& [h, ds] : cell) {
    for (const auto& [d, e] : ds) cells[h].push_back({d, e.first * 100, e.second * 100});
  }
  const std::vector<PlotSeries> series = Fig4Series(cells);
  std::vector<PlotSeries> only3d;
  for (const auto& s : series) {
    if (s.style != PlotSeries::kDashed) only3d.push_back(s);
  }
  const std::string path = a.plots + "/fig4_error_vs_distance.png";
  const std::string zoom = a.plots + "/fig4_error_vs_distance_3d_only.png";
  PrintPlots("ballvision eval",
             WritePlots({{path, "3D error vs distance (static grid), dashed: omni only + floor",
                          "distance [m]", "error [cm]", series},
                         {zoom, "3D error vs distance (static grid), stereo only", "distance [m]",
                          "error [cm]", only3d}}));
}

// truth.csv, and grid.csv when the sequence is the static grid (`grid` left empty otherwise).
bool LoadEvalTruth(const std::string& seq, std::map<uint64_t, Truth>& truth,
                   std::vector<GridRow>& grid, bool& is_grid) {
  namespace fs = std::filesystem;
  std::string err;
  if (!ReadTruth((fs::path(seq) / "truth.csv").string(), truth, err)) {
    std::fprintf(stderr, "ballvision eval: %s (eval needs ground truth)\n", err.c_str());
    return false;
  }
  const std::string grid_path = (fs::path(seq) / "grid.csv").string();
  is_grid = fs::exists(grid_path);
  if (is_grid && !ReadGridCsv(grid_path, grid, err)) {
    std::fprintf(stderr, "ballvision eval: %s\n", err.c_str());
    return false;
  }
  return true;
}

// The data behind the figures, for tools/python/plot_ball_eval.py.
bool WritePlotData(const std::string& dir, const std::vector<FrameRecord>& recs,
                   const Prediction& pred) {
  SafeOutput m, pr;
  std::string e2;
  if (!m.Open(dir + "/measurements.csv", e2) || !pr.Open(dir + "/prediction.csv", e2)) {
    std::fprintf(stderr, "ballvision eval: %s\n", e2.c_str());
    return false;
  }
  m << "index,t_us,kind,mx,my,mz,z_valid,gx,gy,gz\n";
  for (const auto& r : recs) {
    m << r.index << "," << r.state.t_us << "," << MeasKind(r.state) << ",";
    if (r.meas.valid) {
      m << r.meas.p_m.x() << "," << r.meas.p_m.y() << "," << r.meas.p_m.z() << ","
        << (r.meas.z_valid ? 1 : 0);
    } else {
      m << ",,,";
    }
    m << ",";
    if (r.meas.omni_ground_valid) {
      m << r.meas.omni_ground_m.x() << "," << r.meas.omni_ground_m.y() << ","
        << r.meas.omni_ground_m.z();
    } else {
      m << ",,";
    }
    m << "\n";
  }
  pr << "t_s,z\n";
  for (size_t i = 0; i < pred.t_s.size(); ++i) pr << pred.t_s[i] << "," << pred.z[i] << "\n";
  if (!m.Commit(e2) || !pr.Commit(e2)) {
    std::fprintf(stderr, "ballvision eval: %s\n", e2.c_str());
    return false;
  }
  if (!WriteStates(dir + "/states.csv", recs, true, e2)) {
    std::fprintf(stderr, "ballvision eval: %s\n", e2.c_str());
  }
  return true;
}

// The raw measurements (before the filter) against truth.
void PrintMeasurementError(const std::vector<FrameRecord>& recs,
                           const std::map<uint64_t, Truth>& truth) {
  std::vector<double> e;
  double sx = 0, sy = 0, sz = 0;
  for (const auto& r : recs) {
    const Truth* t = TruthAt(truth, r.state.t_us);
    if (!t || !r.meas.valid || !r.meas.z_valid) continue;
    e.push_back(Dist3(r.meas.p_m, *t));
    sx += r.meas.p_m.x() - t->x;
    sy += r.meas.p_m.y() - t->y;
    sz += r.meas.p_m.z() - t->z;
  }
  if (!e.empty()) {
    const double n = static_cast<double>(e.size());
    std::printf(
        "measurement 3D error: median %.2f cm, p90 %.2f cm (n=%zu); mean offset x %+.2f "
        "y %+.2f z %+.2f cm\n",
        Median(e) * 100, Percentile(e, 0.9) * 100, e.size(), sx / n * 100, sy / n * 100,
        sz / n * 100);
  }
}

// How often the true error per axis lies within 1, 2, 3 of the state's sigma, pooled and by phase,
// and the shape of |error| / sigma.
void PrintUncertainty(const char* const phase_names[4], const int phase_inside[4][3],
                      const int phase_axes[4], const std::vector<double>& in_sigmas,
                      int unobservable) {
  int inside[3] = {}, axes = 0;
  for (int k = 0; k < 4; ++k) {
    for (int m = 0; m < 3; ++m) inside[m] += phase_inside[k][m];
    axes += phase_axes[k];
  }
  if (axes == 0) return;
  std::printf(
      "uncertainty: true error within the state's 1-sigma on %.1f %% of axes (68 %% when "
      "calibrated, n=%d), within 2 sigma on %.1f %% (95 %%), within 3 sigma on %.1f %% (99.7 "
      "%%); flagged unobservable in %d frames\n",
      100.0 * inside[0] / axes, axes, 100.0 * inside[1] / axes, 100.0 * inside[2] / axes,
      unobservable);
  // The shape: heavier tails than a Gaussian's show as a small 68th and a large 99.7th; the
  // rms, what a consumer weighting by 1 / sigma^2 relies on, is 1 for a right variance whatever
  // the shape.
  double sum_sq = 0;
  for (const double r : in_sigmas) sum_sq += std::min(r, 1e3) * std::min(r, 1e3);
  std::printf(
      "uncertainty percentiles: |error| / sigma at the 68th / 95th / 99.7th %.2f / %.2f / %.2f "
      "(1 / 1.96 / 3 when calibrated); rms %.2f (1)\n",
      Percentile(in_sigmas, 0.68), Percentile(in_sigmas, 0.95), Percentile(in_sigmas, 0.997),
      std::sqrt(sum_sq / static_cast<double>(in_sigmas.size())));
  std::printf("uncertainty by phase, within 1 / 2 / 3 sigma:");
  for (int k = 0; k < 4; ++k) {
    if (phase_axes[k] == 0) continue;
    const double n = phase_axes[k];
    std::printf(" %s %.1f / %.1f / %.1f %% (n=%d);", phase_names[k], 100.0 * phase_inside[k][0] / n,
                100.0 * phase_inside[k][1] / n, 100.0 * phase_inside[k][2] / n, phase_axes[k]);
  }
  std::printf("\n");
}

// Detection and state error, then the raw measurements (before the filter).
bool PrintOverall(const std::string& seq, const std::vector<FrameRecord>& recs,
                  const std::map<uint64_t, Truth>& truth, const std::string& sigma_errors) {
  int with_truth = 0, found = 0, tri = 0;
  std::vector<double> err_state;
  for (const auto& r : recs) {
    const Truth* t = TruthAt(truth, r.state.t_us);
    if (!t) continue;
    ++with_truth;
    tri += (r.state.flags & kFlagTriangulated) != 0;
    if (!r.state.found) continue;
    ++found;
    err_state.push_back(Dist3(r.state, *t));
  }
  std::printf("%s: %zu frames, %d with a ball in truth, state found in %d, triangulated in %d\n",
              seq.c_str(), recs.size(), with_truth, found, tri);
  if (!err_state.empty()) {
    std::printf("state 3D error: median %.2f cm, p90 %.2f cm, max %.2f cm\n",
                Median(err_state) * 100, Percentile(err_state, 0.9) * 100,
                Percentile(err_state, 1.0) * 100);
  }
  // By what the frame contributed (issue 12): both rays, one camera's, none (coasting); and how
  // often the true error per axis lies within the state's 1-sigma (68 % when calibrated).
  const char* kPhase[4] = {"seen by both", "omni only", "persp only", "coasting"};
  std::vector<double> by_phase[4];
  int unobservable = 0;
  int phase_inside[4][3] = {}, phase_axes[4] = {};  // within 1, 2, 3 sigma, by phase
  std::vector<double> in_sigmas;                    // |error| / sigma per axis
  SafeOutput scored;
  std::string error;
  if (!sigma_errors.empty()) {
    if (!scored.Open(sigma_errors, error)) {
      std::fprintf(stderr, "ballvision eval: %s\n", error.c_str());
      return false;
    }
    scored << "index,phase,axis,error_m,sigma_m\n";
  }
  for (const auto& r : recs) {
    const Truth* t = TruthAt(truth, r.state.t_us);
    if (!t || !r.state.found) continue;
    const uint16_t f = r.state.flags;
    const int phase = (f & kFlagCoasting)             ? 3
                      : (f & kFlagTriangulated)       ? 0
                      : (f & kFlagOmniGroundFallback) ? 1
                      : (f & kFlagPerspSizeFallback)  ? 2
                      : (f & (kFlagSeenOmni | kFlagSeenPersp)) == (kFlagSeenOmni | kFlagSeenPersp)
                          ? 0
                      : (f & kFlagSeenOmni) ? 1
                                            : 2;
    by_phase[phase].push_back(Dist3(r.state, *t));
    unobservable += (f & kFlagUnobservable) != 0;
    const double err[3] = {r.state.x_m - t->x, r.state.y_m - t->y, r.state.z_m - t->z};
    const double sig[3] = {r.state.sigma_x_m, r.state.sigma_y_m, r.state.sigma_z_m};
    for (int j = 0; j < 3; ++j) {
      if (j == 2 && r.state.mode == BallMode::kRolling) continue;  // z is the floor constraint
      for (int m = 0; m < 3; ++m) phase_inside[phase][m] += std::fabs(err[j]) <= (m + 1) * sig[j];
      ++phase_axes[phase];
      in_sigmas.push_back(sig[j] > 0 ? std::fabs(err[j]) / sig[j] : 1e9);
      if (scored.is_open()) {
        char row[96];
        std::snprintf(row, sizeof row, "%lld,%d,%c,%.6f,%.6f\n", static_cast<long long>(r.index),
                      phase, "xyz"[j], err[j], sig[j]);
        scored << row;
      }
    }
  }
  std::printf("state 3D error by phase:");
  for (int k = 0; k < 4; ++k) {
    if (by_phase[k].empty()) continue;
    std::printf(" %s %.2f / %.2f cm (n=%zu);", kPhase[k], Median(by_phase[k]) * 100,
                Percentile(by_phase[k], 0.9) * 100, by_phase[k].size());
  }
  std::printf(" median / p90\n");
  PrintUncertainty(kPhase, phase_inside, phase_axes, in_sigmas, unobservable);
  PrintMeasurementError(recs, truth);
  if (scored.is_open() && !scored.Commit(error)) {
    std::fprintf(stderr, "ballvision eval: %s\n", error.c_str());
    return false;
  }
  return true;
}

// physics.bounces[].t_s of the renderer's scene_extra.json; none when the file has none.
bool ParseBounces(const nlohmann::json& j, const std::string& path, std::vector<double>& out,
                  std::string& error) {
  if (!j.is_object() || !j.contains("physics")) return true;
  StrictObject physics(j.at("physics"), path, "physics");
  const nlohmann::json* list = physics.IsObject() ? physics.Child("bounces", false) : nullptr;
  if (!physics.error().empty()) {
    error = physics.error();
    return false;
  }
  if (!list) return true;
  if (!list->is_array()) {
    error = path + ": physics.bounces: expected an array";
    return false;
  }
  for (size_t i = 0; i < list->size(); ++i) {
    StrictObject b((*list)[i], path, "physics.bounces[" + std::to_string(i) + "]");
    double t = 0;
    if (!b.IsObject() || !b.Number("t_s", t, 0, 1e9)) {
      error = b.error();
      return false;
    }
    out.push_back(t);
  }
  return true;
}

// The floor contacts of a rendered sequence (none without scene_extra.json; a malformed file
// skips the table with a message).
std::vector<double> ReadBounces(const std::string& seq) {
  const std::string path = (std::filesystem::path(seq) / "scene_extra.json").string();
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return {};
  nlohmann::json j;
  std::string error;
  std::vector<double> bounces;
  if (!ReadJsonFile(path, j, error) || !ParseBounces(j, path, bounces, error)) {
    std::fprintf(stderr, "%s (bounce table skipped)\n", error.c_str());
    return {};
  }
  return bounces;
}

// The position predicted `predict_ms` ahead against the truth then, for frames in flight.
void PrintPredictionErrors(int predict_ms, const std::vector<FrameRecord>& recs,
                           const std::map<uint64_t, Truth>& truth,
                           const std::vector<double>& bounces) {
  const uint64_t ahead_us = static_cast<uint64_t>(predict_ms) * 1000u;
  std::vector<double> e_all, e_nobounce, e_uncertain;
  std::vector<double> in_sigmas;  // |error| / the prediction's own sigma, per axis
  std::printf("\nPosition predicted %d ms ahead vs truth (frames with the ball in flight)\n",
              predict_ms);
  std::printf("%8s %-9s %-5s | %8s %8s %8s | %8s\n", "t_s", "mode", "kind", "pred_x", "pred_y",
              "pred_z", "err_cm");
  for (const auto& r : recs) {
    const Truth* t0 = TruthAt(truth, r.state.t_us);
    const Truth* t1 = TruthAt(truth, r.state.t_us + ahead_us);
    if (!t0 || !t1 || !r.state.found || !(r.state.flags & kFlagHasPrediction)) continue;
    if (t0->state != "flight" || r.state.mode == BallMode::kRolling) continue;
    const Eigen::Vector3f p(r.state.px_m, r.state.py_m, r.state.pz_m);
    const double e = Dist3(p, *t1);
    e_all.push_back(e);
    bool crosses = false;
    for (double b : bounces) {
      crosses |= b > r.state.t_us * 1e-6 && b <= (r.state.t_us + ahead_us) * 1e-6;
    }
    if (!crosses) e_nobounce.push_back(e);
    const double err[3] = {p.x() - t1->x, p.y() - t1->y, p.z() - t1->z};
    const double sig[3] = {r.state.psigma_x_m, r.state.psigma_y_m, r.state.psigma_z_m};
    for (int j = 0; j < 3; ++j) in_sigmas.push_back(sig[j] > 0 ? std::fabs(err[j]) / sig[j] : 1e9);
    const bool uncertain = (r.state.flags & kFlagPredictionUncertain) != 0;
    if (uncertain) e_uncertain.push_back(e);
    std::printf("%8.3f %-9s %-5s | %8.3f %8.3f %8.3f | %8.2f%s%s\n", r.state.t_us * 1e-6,
                BallModeName(r.state.mode), MeasKind(r.state), p.x(), p.y(), p.z(), e * 100,
                crosses ? "  (bounce in between)" : "", uncertain ? "  (flagged uncertain)" : "");
  }
  if (!e_all.empty()) {
    std::printf("prediction error %d ms ahead: median %.2f cm, p90 %.2f cm, max %.2f cm (n=%zu)\n",
                predict_ms, Median(e_all) * 100, Percentile(e_all, 0.9) * 100,
                Percentile(e_all, 1.0) * 100, e_all.size());
  }
  if (!e_nobounce.empty()) {
    std::printf(
        "  without a bounce in the horizon: median %.2f cm, p90 %.2f cm, max %.2f cm (n=%zu)\n",
        Median(e_nobounce) * 100, Percentile(e_nobounce, 0.9) * 100,
        Percentile(e_nobounce, 1.0) * 100, e_nobounce.size());
  }
  if (!in_sigmas.empty()) {
    auto within = [&](double k) {
      return 100.0 *
             std::count_if(in_sigmas.begin(), in_sigmas.end(), [k](double x) { return x <= k; }) /
             static_cast<double>(in_sigmas.size());
    };
    std::printf(
        "  its own sigma (psigma): error within 1 / 2 / 3 sigma on %.1f / %.1f / %.1f %% of axes "
        "(68 / 95 / 99.7 when calibrated), |error| / sigma at the 68th / 95th / 99.7th %.2f / "
        "%.2f / %.2f\n",
        within(1), within(2), within(3), Percentile(in_sigmas, 0.68), Percentile(in_sigmas, 0.95),
        Percentile(in_sigmas, 0.997));
  }
  // Counted above too: the flag tells the robot, it does not hide the frame here.
  if (!e_uncertain.empty()) {
    std::printf("  flagged uncertain (the prediction's sigma > %.1f m): %zu frames, max %.2f cm\n",
                PipelineConfig{}.filter.unobservable_sigma_m, e_uncertain.size(),
                Percentile(e_uncertain, 1.0) * 100);
  }
}

// Per true floor contact, the contact the filter predicted 2.5 s (the paper's Fig. 5 horizon),
// 1 s and 0.5 s before it: the nearest of the contacts predicted then.
void PrintContactPredictions(const std::vector<FrameRecord>& recs,
                             const std::vector<double>& bounces) {
  std::printf("\nFloor contacts predicted ahead (goal: 1 s ahead within 0.03 s)\n");
  std::printf("%10s | %12s %12s %10s | %12s %12s %10s | %12s %12s %10s\n", "truth_t_s",
              "pred@-2.5s", "made_at", "err_s", "pred@-1s", "made_at", "err_s", "pred@-0.5s",
              "made_at", "err_s");
  const double t_first = recs.empty() ? 0 : recs.front().state.t_us * 1e-6;
  const double t_last = recs.empty() ? 0 : recs.back().state.t_us * 1e-6;
  for (double b : bounces) {
    if (b > t_last + 0.05) continue;
    std::printf("%10.3f |", b);
    for (double lead : {2.5, 1.0, 0.5}) {
      const double want = b - lead;
      const FrameRecord* best = nullptr;
      for (const auto& r : recs) {
        const double t = r.state.t_us * 1e-6;
        if (t <= want + 1e-6 && (!best || t > best->state.t_us * 1e-6)) best = &r;
      }
      if (want < t_first - 1e-6 || !best || best->contacts_us.empty()) {
        std::printf(" %12s %12s %10s |", "-", "-", "-");
        continue;
      }
      double pb = NAN;
      for (uint64_t c : best->contacts_us) {
        if (!std::isfinite(pb) || std::fabs(c * 1e-6 - b) < std::fabs(pb - b)) pb = c * 1e-6;
      }
      std::printf(" %12.3f %12.3f %10.3f |", pb, best->state.t_us * 1e-6, pb - b);
    }
    std::printf("\n");
  }
  // The next contact every packet carries (t_bounce_us) against the true next one, by how far
  // ahead that was (the goal: 0.02 s median when it is 0.3-1 s ahead).
  const double kLeads[] = {0.0, 0.3, 1.0, 2.5};
  std::vector<double> sorted = bounces, err[3];
  std::sort(sorted.begin(), sorted.end());
  int missing[3] = {};
  for (const auto& r : recs) {
    const double t = r.state.t_us * 1e-6;
    const auto next = std::upper_bound(sorted.begin(), sorted.end(), t);
    if (next == sorted.end() || !r.state.found) continue;
    const double lead = *next - t;
    int bin = 0;
    while (bin < 3 && lead > kLeads[bin + 1]) ++bin;
    if (bin == 3) continue;
    if (!(r.state.flags & kFlagHasBounce)) {
      ++missing[bin];
      continue;
    }
    err[bin].push_back(std::fabs(r.state.t_bounce_us * 1e-6 - *next));
  }
  std::printf("next contact in the packet vs the true next one, by lead, |error| median / p90:");
  for (int b = 0; b < 3; ++b) {
    if (err[b].empty() && missing[b] == 0) continue;
    std::printf(" %.1f-%.1f s ", kLeads[b], kLeads[b + 1]);
    if (!err[b].empty()) {
      std::printf("%.3f / %.3f s (n=%zu", Median(err[b]), Percentile(err[b], 0.9), err[b].size());
    } else {
      std::printf("- (n=0");
    }
    std::printf(missing[b] ? ", %d without one);" : ");", missing[b]);
  }
  std::printf("\n");
}

// Fig. 5 of a captured sequence: the truth where truth.csv has the ball.
void PlotEvalFig5(const std::string& dir, const std::vector<FrameRecord>& recs,
                  const std::map<uint64_t, Truth>& truth, double at_s, const Prediction& pred) {
  std::vector<double> t_s, z, vz;
  for (const auto& r : recs) {
    const Truth* t = TruthAt(truth, r.state.t_us);
    if (!t) continue;
    t_s.push_back(r.state.t_us * 1e-6);
    z.push_back(t->z);
    vz.push_back(t->vz);
  }
  const std::vector<PlotSeries> f5 = Fig5Series(t_s, z, vz, recs);
  PlotSeries pz{"prediction made at " + std::to_string(at_s).substr(0, 5) + " s",
                pred.t_s,
                pred.z,
                30,
                60,
                220};
  pz.style = PlotSeries::kDashed;
  PrintPlots("ballvision eval", WritePlots({{dir + "/fig5_height_velocity.png",
                                             "Height [m] and vertical velocity [m/s]", "time [s]",
                                             "z [m], vz [m/s]", f5},
                                            {dir + "/fig5_prediction.png",
                                             "Height predicted into the future",
                                             "time [s]",
                                             "z [m]",
                                             {f5[0], f5[1], pz}}}));
}

}  // namespace

int CmdEval(int argc, char** argv) {
  Args a;
  ArgParser p("ballvision eval", kEvalUsage);
  PipelineOptions(p, a);
  p.Text("--plots", a.plots)
      .Text("--sigma-errors", a.sigma_errors)
      .Number("--at-ms", 0, 1e6, a.at_ms);
  if (const int rc = p.Parse(argc, argv); rc >= 0) return rc;
  // Refused before the sequence runs, not after.
  for (const std::string* path : {&a.out, &a.sigma_errors}) {
    std::string err;
    if (!path->empty() && !CheckOutputPath(*path, err)) {
      std::fprintf(stderr, "ballvision eval: %s\n", err.c_str());
      return 1;
    }
  }
  std::vector<GridRow> grid;
  std::map<uint64_t, Truth> truth;
  bool is_grid = false;
  if (!LoadEvalTruth(a.seq, truth, grid, is_grid)) return 1;
  if (a.predict_ms < 0) a.predict_ms = 200;
  Setup s;
  if (!Prepare(a, "eval", s)) return 1;
  if (!a.plots.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(a.plots, ec);
  }

  // The prediction made at the chosen time (default a third into the sequence).
  Prediction pred;
  double at_s = a.at_ms >= 0 ? a.at_ms / 1000.0 : -1;
  if (at_s < 0 && !s.seq.entries.empty()) {
    at_s = (s.seq.entries.front().t_us +
            (s.seq.entries.back().t_us - s.seq.entries.front().t_us) / 3) *
           1e-6;
  }
  bool sampled = false;
  RunSettings rs;
  rs.progress = s.seq.entries.size() >= 30;
  rs.reset_each_frame = is_grid || a.stills;
  rs.annotate_dir = a.annotate;
  rs.on_frame = [&](const Pipeline& pl, const FrameRecord& r) {
    if (sampled || r.state.t_us * 1e-6 + 1e-6 < at_s || !r.state.found) return;
    sampled = true;
    pred = SamplePrediction(pl.filter(), r.state.t_us, 200);
  };
  std::vector<FrameRecord> recs;
  std::string err;
  InstallInterruptHandlers();
  if (!RunSequence(s.seq, *s.pipeline, rs, recs, err) ||
      (!a.out.empty() && !WriteStates(a.out, recs, true, err))) {
    std::fprintf(stderr, "ballvision eval: %s\n", err.c_str());
    return 1;
  }
  if (!a.plots.empty() && !WritePlotData(a.plots, recs, pred)) return 1;

  if (!PrintOverall(a.seq, recs, truth, a.sigma_errors)) return 1;
  if (InterruptSignal()) ReportInterrupt("ballvision eval");
  if (is_grid) {
    EvalGrid(a, *s.pipeline->calibration(), grid, recs, truth);
    return InterruptSignal() ? InterruptExitCode() : 0;
  }
  const std::vector<double> bounces = ReadBounces(a.seq);
  PrintPredictionErrors(a.predict_ms, recs, truth, bounces);
  std::printf("filter restitution b: configured %.2f, estimated at the end %.2f\n",
              s.config.filter.bounce_factor, s.pipeline->filter().bounce_factor());
  if (!bounces.empty()) PrintContactPredictions(recs, bounces);
  if (!a.plots.empty()) PlotEvalFig5(a.plots, recs, truth, at_s, pred);
  return InterruptSignal() ? InterruptExitCode() : 0;
}

namespace {

constexpr double kDemoBounceFactor = 0.7;
constexpr double kDemoPredictFromS = 0.9;

struct DemoLobResult {
  std::vector<FrameRecord> recs;
  std::vector<double> errs;        // 3D state error where found (m)
  std::vector<double> t_s, z, vz;  // the truth per frame
  Prediction pred;
};

// The lob: 30 Hz frame pairs straight into Pipeline::Process; every third frame printed.
bool RunDemoLob(Pipeline& pipeline, const DemoRenderer& renderer, int frames, DemoLobResult& out) {
  std::printf("%5s %7s | %-8s %-5s | %7s %7s %7s | %7s %7s %7s | %7s %6s | %8s\n", "frame", "t_s",
              "mode", "meas", "x", "y", "z", "true_x", "true_y", "true_z", "vz", "err_cm",
              "bounce_s");
  std::vector<uint8_t> omni, persp;
  for (int k = 0; k < frames; ++k) {
    const uint64_t t_us = static_cast<uint64_t>(std::llround(k * 1e6 / 30.0));
    const DemoTruth tr = DemoLob(t_us * 1e-6, kDemoBounceFactor);
    renderer.Render(tr.p, static_cast<uint32_t>(k + 1), omni, persp);
    FrameInput in;
    in.t_us = t_us;
    in.omni = MakeYuyvImage(omni.data(), kFrameWidth, kFrameHeight);
    in.persp = MakeYuyvImage(persp.data(), kFrameWidth, kFrameHeight);
    FrameRecord r;
    r.index = k;
    const auto t0 = std::chrono::steady_clock::now();
    const Status st = pipeline.Process(in, r.state);
    r.state.proc_us = static_cast<uint32_t>(
        std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now() - t0)
            .count());
    if (!st.ok()) {
      std::fprintf(stderr, "ballvision demo: frame %d: %s\n", k, st.message());
      return false;
    }
    const BallState& s = r.state;
    const double e = std::sqrt((s.x_m - tr.p.x()) * (s.x_m - tr.p.x()) +
                               (s.y_m - tr.p.y()) * (s.y_m - tr.p.y()) +
                               (s.z_m - tr.p.z()) * (s.z_m - tr.p.z()));
    if (s.found) out.errs.push_back(e);
    if (k % 3 == 0 || k + 1 == frames) {
      char bounce[16] = "-";
      if (s.flags & kFlagHasBounce)
        std::snprintf(bounce, sizeof bounce, "%.3f", s.t_bounce_us * 1e-6);
      std::printf(
          "%5d %7.3f | %-8s %-5s | %7.3f %7.3f %7.3f | %7.3f %7.3f %7.3f | %7.2f %6.1f | %8s\n", k,
          t_us * 1e-6, BallModeName(s.mode), MeasKind(s), s.x_m, s.y_m, s.z_m, tr.p.x(), tr.p.y(),
          tr.p.z(), s.vz_mps, s.found ? e * 100 : NAN, bounce);
    }
    out.t_s.push_back(t_us * 1e-6);
    out.z.push_back(tr.p.z());
    out.vz.push_back(tr.v.z());
    if (out.pred.t_s.empty() && t_us * 1e-6 + 1e-6 >= kDemoPredictFromS && s.found) {
      out.pred = SamplePrediction(pipeline.filter(), t_us, 150);
    }
    out.recs.push_back(r);
  }
  return true;
}

// The static grid (Fig. 4 set-up): unrelated stills, the measurement against the truth, and
// the omni-only "2D" estimate; prints the table.
Fig4Cells RunDemoGrid(Pipeline& pipeline, const DemoRenderer& renderer) {
  std::printf("\nstatic grid: 3D error [cm] of the measurement (2D omni-only in brackets)\n%6s",
              "dist_m");
  const float heights[3] = {0.11f, 0.21f, 0.41f};
  for (float h : heights) std::printf("   z=%.2f m      ", h);
  std::printf("\n");
  Fig4Cells cells;
  std::vector<uint8_t> omni, persp;
  for (int di = 1; di <= 11; ++di) {
    const float d = 0.5f * di;
    std::printf("%6.2f", d);
    for (int hi = 0; hi < 3; ++hi) {
      const Eigen::Vector3f ball(0.f, d, heights[hi]);
      renderer.Render(ball, static_cast<uint32_t>(1000 + di * 3 + hi), omni, persp);
      FrameInput in;
      in.t_us = static_cast<uint64_t>(10000000 + (di * 3 + hi) * 33333);
      in.omni = MakeYuyvImage(omni.data(), kFrameWidth, kFrameHeight);
      in.persp = MakeYuyvImage(persp.data(), kFrameWidth, kFrameHeight);
      pipeline.ResetTrack();
      BallState s;
      // Not checked (as it never was): the row shows the measurement the frame left.
      (void)pipeline.Process(in, s);
      const MeasurementInfo& m = pipeline.last_measurement();
      const double e3 = m.valid ? (m.p_m - ball).norm() : NAN;
      const double e2 = m.omni_ground_valid ? (m.omni_ground_m - ball).norm() : NAN;
      cells[heights[hi]].push_back({d, e3 * 100, e2 * 100});
      std::printf("  %5.1f %-4s (%5.1f)", e3 * 100, MeasKind(s), e2 * 100);
    }
    std::printf("\n");
  }
  return cells;
}

}  // namespace

int CmdDemo(int argc, char** argv) {
  Args a;
  ArgParser p("ballvision demo", kDemoUsage);
  p.Text("--out", a.out).Int("--frames", 10, 1000000, a.frames);
  if (const int rc = p.Parse(argc, argv); rc >= 0) return rc;
  const std::string dir = a.out.empty() ? "demo_out" : a.out;
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) {
    std::fprintf(stderr, "ballvision demo: cannot create %s: %s\n", dir.c_str(),
                 ec.message().c_str());
    return 1;
  }
  const auto t_start = std::chrono::steady_clock::now();
  const RigCalibration cal = MakeDemoCalibration();
  auto lut = std::make_unique<ColorLut>();
  FillBuiltInLut(*lut);
  auto pipeline = std::make_unique<OwnedPipeline>();
  // No appearance classifier: the demo draws flat-shaded discs, unlike the balls it was trained
  // on, and it refuses some of them. The size-and-place checks stay on.
  PipelineConfig config;
  const Status st = pipeline->Init(cal, *lut, config);
  if (!st.ok()) {
    std::fprintf(stderr, "ballvision demo: pipeline: %s\n", st.message());
    return 1;
  }
  const DemoRenderer renderer(cal);
  std::vector<double> bounce_times;
  DemoLob(100.0, kDemoBounceFactor, &bounce_times);

  std::printf(
      "ballvision demo: a lob that bounces, drawn with the built-in calibration of the\n"
      "reference rig, through the full pipeline (front end, rays, triangulation, filter;\n"
      "the appearance classifier off: the demo's balls are flat-shaded discs)\n\n");
  DemoLobResult lob;
  if (!RunDemoLob(*pipeline, renderer, a.frames, lob)) return 1;
  std::printf("\ntrue floor contacts:");
  for (double b : bounce_times) {
    if (b < a.frames / 30.0) std::printf(" %.3f", b);
  }
  std::printf(" s; filter restitution estimate b = %.2f (true %.2f)\n",
              pipeline->filter().bounce_factor(), kDemoBounceFactor);
  if (!lob.errs.empty()) {
    std::printf("state 3D error over %zu frames: median %.1f cm, p90 %.1f cm\n", lob.errs.size(),
                Median(lob.errs) * 100, Percentile(lob.errs, 0.9) * 100);
  }
  std::string err;
  if (!WriteStates(dir + "/states.csv", lob.recs, true, err)) {
    std::fprintf(stderr, "ballvision demo: %s\n", err.c_str());
    return 1;
  }
  const Fig4Cells grid = RunDemoGrid(*pipeline, renderer);

  const std::vector<PlotSeries> f5 = Fig5Series(lob.t_s, lob.z, lob.vz, lob.recs);
  PlotSeries pz{"prediction made at 0.9 s", lob.pred.t_s, lob.pred.z, 30, 60, 220};
  pz.style = PlotSeries::kDashed;
  const PlotOutcome plots = WritePlots(
      {{dir + "/demo_fig4_error_vs_distance.png", "Demo: 3D error vs distance (built-in scene)",
        "distance [m]", "error [cm]", Fig4Series(grid)},
       {dir + "/demo_fig5_height_velocity.png", "Demo lob: height [m] and vertical velocity [m/s]",
        "time [s]", "z [m], vz [m/s]", f5},
       {dir + "/demo_fig5_prediction.png",
        "Demo lob: height predicted from t = 0.9 s",
        "time [s]",
        "z [m]",
        {f5[0], f5[1], pz}}});
  if (!plots.ok) {
    std::fprintf(stderr, "ballvision demo: %s\n", plots.error.c_str());
    return 1;
  }
  if (!plots.note.empty()) std::fprintf(stderr, "ballvision demo: %s\n", plots.note.c_str());
  const double secs =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  std::printf("\nwrote %s/states.csv, %s (%.1f s)\n", dir.c_str(), Joined(plots.written).c_str(),
              secs);
  return 0;
}

}  // namespace bv::cli
