// `ballvision eval-field`: the field figures of a captured sequence against its truth.csv (the
// robot's field pose, the ball's image centroids) and, when given, the other robots' positions:
// pose error and time to converge, line-point distance to the true lines, obstacle recall and
// centre error within 5 m, ball recall and false balls per camera, 3D error.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/field/field_model.h"
#include "core/pipeline.h"
#include "hal/host/sequence.h"
#include "tools/ballvision/calib_io.h"
#include "tools/ballvision/cli_args.h"
#include "tools/ballvision/commands.h"
#include "tools/ballvision/run_common.h"
#include "tools/ballvision/run_pipeline.h"
#include "tools/ballvision/truth_csv.h"

namespace bv::cli {
namespace {

constexpr double kPi = 3.14159265358979;
constexpr double kObstacleRangeM = 5.0;
constexpr double kObstacleHitM = 0.3;
constexpr double kGoalRangeM = 5.0;  // goal mouths this near (centre) count as in view
constexpr double kGoalHitM = 0.75;   // a goal found within this of the true mouth segment

struct FieldArgs {
  std::string seq, calib, lut, robots, ball, classifier;
  int half = 0;
  bool per_frame = false, stills = false, no_field = false, adapt = false;
};

constexpr char kFieldUsage[] =
    "usage: ballvision eval-field SEQ --calib FILE [--lut FILE] [--ball NAME] [--robots CSV]\n"
    "       [--classifier FILE|builtin|off]\n"
    "       [--half -1|0|1] [--stills] [--no-field] [--per-frame]\n"
    "       [--adapt]  (online colour adaptation from the built-in model, as on the device)\n"
    "  field figures against SEQ/truth.csv: pose (from an unknown start), line\n"
    "  points, obstacles (--robots: index,x,y,radius, robot frame; see\n"
    "  tools/python/scene_robots.py), ball recall and false balls per camera\n"
    "  --half     the main computer's hint: sign of the robot's field x\n"
    "  --stills   frames are unrelated stills: no ball tracking across frames\n"
    "  --no-field field features and localisation off (the comparison)\n";

struct TruthRow {
  double rx = 0, ry = 0, rh_deg = 0;
  bool has_pose = false;
  bool has_ball = false;
  double bx = 0, by = 0, bz = 0;
  bool vis[2] = {false, false};
  bool proj[2] = {false, false};
  double cu[2] = {0, 0}, cv[2] = {0, 0}, area[2] = {0, 0};
  // The whole ball's silhouette (as if nothing hid it): where a ray should point. Without the
  // column (older sets), the visible part's.
  double full_cu[2] = {0, 0}, full_cv[2] = {0, 0};
  double proj_u[2] = {0, 0}, proj_v[2] = {0, 0};  // the centre's exact projection
};

// Reads one row's optional numbers: absent columns and empty fields are "not given", anything
// else must be a number (an error names the file, line and column).
class OptionalNumbers {
 public:
  OptionalNumbers(const TruthCsv& t, size_t row, std::string& err) : t_(t), row_(row), err_(err) {}
  bool Get(const std::string& column, double& v) {
    if (failed_ || !t_.Has(column) || t_.Empty(row_, column)) return false;
    double x = 0;
    if (!t_.Number(row_, column, x, false, err_)) {
      failed_ = true;
      return false;
    }
    v = x;
    return true;
  }
  bool failed() const { return failed_; }

 private:
  const TruthCsv& t_;
  size_t row_;
  std::string& err_;
  bool failed_ = false;
};

bool LoadTruth(const std::string& path, std::map<uint64_t, TruthRow>& out, std::string& err) {
  TruthCsv t;
  if (!t.Load(path, {"t_us"}, err)) return false;
  for (size_t i = 0; i < t.rows(); ++i) {
    int64_t ts = 0;
    if (!t.Integer(i, "t_us", 0, INT64_MAX, ts, err)) return false;
    OptionalNumbers f(t, i, err);
    TruthRow r;
    r.has_pose = f.Get("robot_field_x", r.rx) && f.Get("robot_field_y", r.ry) &&
                 f.Get("robot_field_heading_deg", r.rh_deg);
    r.has_ball = f.Get("ball_x", r.bx) && f.Get("ball_y", r.by) && f.Get("ball_z", r.bz);
    const char* cams[2] = {"omni", "persp"};
    for (int c = 0; c < 2; ++c) {
      const std::string cam = cams[c];
      double v = 0;
      r.vis[c] = f.Get("visible_" + cam, v) && v > 0.5;
      r.proj[c] = f.Get("u_" + cam, r.proj_u[c]) && f.Get("v_" + cam, r.proj_v[c]);
      f.Get("cu_" + cam, r.cu[c]);
      f.Get("cv_" + cam, r.cv[c]);
      f.Get("area_" + cam, r.area[c]);
      if (!f.Get("fullcu_" + cam, r.full_cu[c]) || !f.Get("fullcv_" + cam, r.full_cv[c])) {
        r.full_cu[c] = r.cu[c];
        r.full_cv[c] = r.cv[c];
      }
    }
    if (f.failed()) return false;
    out[static_cast<uint64_t>(ts)] = r;
  }
  return true;
}

struct RobotTruth {
  double x, y, radius;
};

bool LoadRobots(const std::string& path, std::map<int64_t, std::vector<RobotTruth>>& out,
                std::string& err) {
  TruthCsv t;
  if (!t.Load(path, {"index", "x", "y", "radius"}, err)) return false;
  for (size_t i = 0; i < t.rows(); ++i) {
    int64_t index = 0;
    RobotTruth r{};
    if (!t.Integer(i, "index", INT64_MIN, INT64_MAX, index, err) ||
        !t.Number(i, "x", r.x, false, err) || !t.Number(i, "y", r.y, false, err) ||
        !t.Number(i, "radius", r.radius, false, err)) {
      return false;
    }
    out[index].push_back(r);
  }
  return true;
}

double AngleDiff(double a, double b) {
  double d = std::fmod(a - b, 2 * kPi);
  if (d > kPi) d -= 2 * kPi;
  if (d < -kPi) d += 2 * kPi;
  return d;
}

// Robot frame -> field frame with a pose (heading = field angle of robot +y).
void ToField(double px, double py, double ph, double x, double y, double& fx, double& fy) {
  fx = px + x * std::sin(ph) + y * std::cos(ph);
  fy = py - x * std::cos(ph) + y * std::sin(ph);
}

struct Figures {
  std::vector<double> pose_xy, pose_h_deg;  // after the first second
  double converge_s = -1;
  int frames = 0, frames_pose_usable = 0, ambiguous_frames = 0;
  std::vector<double> line_d;
  int robots_in_range = 0, robots_found = 0, obstacles = 0, obstacles_false = 0;
  int obstacles_refused = 0;  // by the pose: beyond the border or inside a goal (any range)
  std::vector<double> obstacle_err;
  int ball_vis[2] = {0, 0}, ball_found[2] = {0, 0}, ball_false[2] = {0, 0};
  std::vector<double> centre_err[2];  // to the whole ball's centre (where the ray points)
  // To what the detection measures: the visible part's centroid, or for a circle fitted to the
  // outline (BallDetection::arc_sectors) the whole ball's centre.
  std::vector<double> centre_err_own[2];
  std::vector<double> err3d;
  int state_found = 0, state_false = 0;
  double max_feature_lookups = 0, sum_feature_lookups = 0;
  int line_points_max = 0;
  double sum_line_points = 0;
  int goals_in_view = 0, goals_found = 0, goals_reported = 0, goals_false = 0;
  int goals_false_unnamed = 0;  // false ones the pose did not check (no usable pose yet)
  int goals_named = 0, goals_named_right = 0;
  std::vector<double> goal_err, goal_bearing_deg, goal_dist_err;
};

void ScorePose(const PoseEstimate& p, const TruthRow& t, double t_s, Figures& f) {
  if (!t.has_pose) return;
  if (p.ambiguous) ++f.ambiguous_frames;
  if (!p.usable()) return;
  ++f.frames_pose_usable;
  const double th = t.rh_deg * kPi / 180.0;
  double dxy = std::hypot(p.x_m - t.rx, p.y_m - t.ry);
  double dh = std::fabs(AngleDiff(p.heading_rad, th));
  if (p.ambiguous) {  // either twin is a correct answer while the symmetry is unresolved
    const double dxy2 = std::hypot(-p.x_m - t.rx, -p.y_m - t.ry);
    const double dh2 = std::fabs(AngleDiff(p.heading_rad + kPi, th));
    if (dxy2 < dxy) {
      dxy = dxy2;
      dh = dh2;
    }
  }
  if (f.converge_s < 0 && dxy < 0.2 && dh < 5 * kPi / 180) f.converge_s = t_s;
  if (t_s >= 1.0) {
    f.pose_xy.push_back(dxy);
    f.pose_h_deg.push_back(dh * 180 / kPi);
  }
}

void ScoreLines(const FieldFeatures& ff, const FieldModel& model, const TruthRow& t, Figures& f) {
  if (!t.has_pose) return;
  const double th = t.rh_deg * kPi / 180.0;
  for (int i = 0; i < ff.line_count; ++i) {
    double fx, fy;
    ToField(t.rx, t.ry, th, ff.lines[i].x_m, ff.lines[i].y_m, fx, fy);
    float gx, gy;
    f.line_d.push_back(model.Distance(static_cast<float>(fx), static_cast<float>(fy), gx, gy));
  }
  f.line_points_max = std::max(f.line_points_max, ff.line_count);
  f.sum_line_points += ff.line_count;
}

void ScoreObstacles(const FieldFeatures& ff, const std::vector<RobotTruth>& robots, Figures& f) {
  f.obstacles_refused += static_cast<int>(ff.obstacles_refused);
  for (const auto& r : robots) {
    if (std::hypot(r.x, r.y) > kObstacleRangeM) continue;
    ++f.robots_in_range;
    double best = 1e9;
    for (int i = 0; i < ff.obstacle_count; ++i) {
      best = std::min(best, std::hypot(ff.obstacles[i].x_m - r.x, ff.obstacles[i].y_m - r.y));
    }
    if (best <= kObstacleHitM) {
      ++f.robots_found;
      f.obstacle_err.push_back(best);
    }
  }
  for (int i = 0; i < ff.obstacle_count; ++i) {
    const Obstacle& o = ff.obstacles[i];
    if (std::hypot(o.x_m, o.y_m) > kObstacleRangeM) continue;
    ++f.obstacles;
    bool near = false;
    for (const auto& r : robots) near |= std::hypot(o.x_m - r.x, o.y_m - r.y) <= 2 * kObstacleHitM;
    f.obstacles_false += !near;
  }
}

// Distance from (x, y) to the segment a-b, and the parameter of the nearest point.
double SegmentDistance(double x, double y, double ax, double ay, double bx, double by) {
  const double dx = bx - ax, dy = by - ay, len2 = dx * dx + dy * dy;
  const double t = len2 > 0 ? std::clamp(((x - ax) * dx + (y - ay) * dy) / len2, 0.0, 1.0) : 0.0;
  return std::hypot(x - ax - t * dx, y - ay - t * dy);
}

// Goal truth: the mouth (goal line between the posts) of each goal from the field geometry of
// the calibration and the true robot pose, in the robot frame.
void ScoreGoals(const FieldFeatures& ff, const FieldConfig& field, const TruthRow& t, Figures& f) {
  if (!t.has_pose) return;
  const double th = t.rh_deg * kPi / 180.0, s = std::sin(th), c = std::cos(th);
  const auto to_robot = [&](double fx, double fy, double& x, double& y) {
    const double dx = fx - t.rx, dy = fy - t.ry;
    x = dx * s - dy * c;
    y = dx * c + dy * s;
  };
  double mouth[2][4];  // per goal (-X, +X): post a, post b (robot frame)
  for (int g = 0; g < 2; ++g) {
    const double gx = (g == 0 ? -0.5 : 0.5) * field.length_m, hw = 0.5 * field.goal_width_m;
    to_robot(gx, -hw, mouth[g][0], mouth[g][1]);
    to_robot(gx, hw, mouth[g][2], mouth[g][3]);
    const double cx = 0.5 * (mouth[g][0] + mouth[g][2]), cy = 0.5 * (mouth[g][1] + mouth[g][3]);
    if (std::hypot(cx, cy) > kGoalRangeM) continue;
    ++f.goals_in_view;
    double best = 1e9;
    int best_i = -1;
    for (int i = 0; i < ff.goal_count; ++i) {
      const double d = SegmentDistance(ff.goals[i].x_m, ff.goals[i].y_m, mouth[g][0], mouth[g][1],
                                       mouth[g][2], mouth[g][3]);
      if (d < best) {
        best = d;
        best_i = i;
      }
    }
    if (best <= kGoalHitM) {
      ++f.goals_found;
      f.goal_err.push_back(best);
      const Goal& d = ff.goals[best_i];
      // Bearing of the true mouth centre against the middle of the seen range, and the distance.
      f.goal_bearing_deg.push_back(std::fabs(AngleDiff(d.bearing_rad, std::atan2(cy, cx))) * 180.0 /
                                   kPi);
      f.goal_dist_err.push_back(std::fabs(d.distance_m - std::hypot(cx, cy)));
      if (d.which != 0) {
        ++f.goals_named;
        const int truth_which = g == 0 ? -1 : 1;
        f.goals_named_right +=
            d.which == truth_which || (d.which_ambiguous && d.which == -truth_which);
      }
    }
  }
  for (int i = 0; i < ff.goal_count; ++i) {
    ++f.goals_reported;
    bool near = false;
    for (int g = 0; g < 2; ++g) {
      near |= SegmentDistance(ff.goals[i].x_m, ff.goals[i].y_m, mouth[g][0], mouth[g][1],
                              mouth[g][2], mouth[g][3]) <= kGoalHitM;
    }
    f.goals_false += !near;
    f.goals_false_unnamed += !near && ff.goals[i].which == 0;
  }
}

void ScoreBall(const BallState& s, const TruthRow& t, Figures& f) {
  const BallDetection* det[2] = {&s.omni, &s.persp};
  for (int c = 0; c < 2; ++c) {
    const bool found = det[c]->found;
    const double tol = std::max(3.0, 1.5 * std::sqrt(std::max(t.area[c], 1.0) / kPi));
    // On the ball: near the visible part's centroid, or near the whole ball's centre (a circle
    // fitted to a partly hidden ball's outline). The error is the whole ball's: the ray's. The
    // whole silhouette is clipped to the image, so a ball cut by the border has its centre's
    // projection as the other reference; a centre outside the image has no error figure.
    const double e_vis = std::hypot(det[c]->u_px - t.cu[c], det[c]->v_px - t.cv[c]);
    double e = std::hypot(det[c]->u_px - t.full_cu[c], det[c]->v_px - t.full_cv[c]);
    if (t.proj[c])
      e = std::min(e, std::hypot(det[c]->u_px - t.proj_u[c], det[c]->v_px - t.proj_v[c]));
    const bool on_ball = found && t.area[c] > 0 && std::min(e, e_vis) <= tol;
    // Visible: at least 4 px across (as lut eval and issue #11 count recall).
    if (t.vis[c] && 2.0 * std::sqrt(t.area[c] / kPi) >= 4.0) {
      ++f.ball_vis[c];
      if (on_ball) {
        ++f.ball_found[c];
        if (t.proj[c]) f.centre_err[c].push_back(e);
        if (det[c]->arc_sectors == 0 || t.proj[c]) {
          f.centre_err_own[c].push_back(det[c]->arc_sectors > 0 ? e : e_vis);
        }
      }
    }
    if (found && !on_ball) ++f.ball_false[c];
  }
  if (s.found) {
    ++f.state_found;
    if (t.has_ball) {
      const double e = std::sqrt((s.x_m - t.bx) * (s.x_m - t.bx) + (s.y_m - t.by) * (s.y_m - t.by) +
                                 (s.z_m - t.bz) * (s.z_m - t.bz));
      f.err3d.push_back(e);
      f.state_false += e > 0.5;
    } else {
      ++f.state_false;
    }
  }
}

void PrintFigures(const Figures& f, bool have_robots) {
  const auto pct = [](int a, int b) { return b > 0 ? 100.0 * a / b : 0.0; };
  std::printf("frames                    %d\n", f.frames);
  std::printf("pose usable               %d frames; ambiguous (symmetry unresolved) %d\n",
              f.frames_pose_usable, f.ambiguous_frames);
  if (f.converge_s >= 0) {
    std::printf("converged (0.2 m, 5 deg)  at t = %.3f s from an unknown start\n", f.converge_s);
  } else {
    std::printf("converged                 never\n");
  }
  if (!f.pose_xy.empty()) {
    std::printf(
        "pose error after 1 s      median %.3f m / %.2f deg, p90 %.3f m / %.2f deg (%zu frames)\n",
        Median(f.pose_xy), Median(f.pose_h_deg), Percentile(f.pose_xy, 0.9),
        Percentile(f.pose_h_deg, 0.9), f.pose_xy.size());
  }
  if (!f.line_d.empty()) {
    std::printf(
        "line points               %zu (mean %.1f, max %d per frame); distance to the true "
        "lines median %.3f m, p90 %.3f m\n",
        f.line_d.size(), f.sum_line_points / std::max(1, f.frames), f.line_points_max,
        Median(f.line_d), Percentile(f.line_d, 0.9));
  }
  if (have_robots) {
    std::printf(
        "robots within 5 m         found %d of %d (%.1f %%) within %.2f m; centre error "
        "median %.3f m\n",
        f.robots_found, f.robots_in_range, pct(f.robots_found, f.robots_in_range), kObstacleHitM,
        f.obstacle_err.empty() ? 0.0 : Median(f.obstacle_err));
    std::printf(
        "obstacles within 5 m      %d reported, %d false (%.1f %%); %d refused by the pose (beyond "
        "the border or inside a goal)\n",
        f.obstacles, f.obstacles_false, pct(f.obstacles_false, f.obstacles), f.obstacles_refused);
  }
  std::printf(
      "goals within %.0f m         found %d of %d (%.1f %%) within %.2f m of the mouth; %d "
      "reported, "
      "%d false (%d before the pose could check them)",
      kGoalRangeM, f.goals_found, f.goals_in_view, pct(f.goals_found, f.goals_in_view), kGoalHitM,
      f.goals_reported, f.goals_false, f.goals_false_unnamed);
  if (!f.goal_err.empty()) {
    std::printf(
        "; off the mouth median %.3f m, bearing of the mouth centre median %.1f deg, distance "
        "median %.3f m",
        Median(f.goal_err), Median(f.goal_bearing_deg), Median(f.goal_dist_err));
  }
  std::printf("; named by the pose %d (right up to the symmetry %d)\n", f.goals_named,
              f.goals_named_right);
  const char* cams[2] = {"omni", "persp"};
  for (int c = 0; c < 2; ++c) {
    std::printf("ball %-5s                found %d of %d visible (%.1f %%), false %d", cams[c],
                f.ball_found[c], f.ball_vis[c], pct(f.ball_found[c], f.ball_vis[c]),
                f.ball_false[c]);
    if (!f.centre_err_own[c].empty()) {
      std::printf(", centre error median %.2f px p90 %.2f px (of what it measures)",
                  Median(f.centre_err_own[c]), Percentile(f.centre_err_own[c], 0.9));
    }
    if (!f.centre_err[c].empty()) {
      std::printf(", %.2f / %.2f px (whole ball)", Median(f.centre_err[c]),
                  Percentile(f.centre_err[c], 0.9));
    }
    std::printf("\n");
  }
  std::printf("ball 3D                   found %d frames, %d more than 0.5 m off", f.state_found,
              f.state_false);
  if (!f.err3d.empty()) {
    std::printf("; error median %.3f m, p90 %.3f m", Median(f.err3d), Percentile(f.err3d, 0.9));
  }
  std::printf("\nfeature pass              %.0f LUT lookups per frame (max %.0f)\n",
              f.sum_feature_lookups / std::max(1, f.frames), f.max_feature_lookups);
}

// Returns -1 to go on, else the exit code.
int ParseFieldArgs(int argc, char** argv, FieldArgs& a) {
  ArgParser args("ballvision eval-field", kFieldUsage);
  args.Positional("SEQ", a.seq)
      .Text("--calib", a.calib)
      .Required("--calib")
      .Text("--lut", a.lut)
      .Text("--ball", a.ball)
      .Text("--classifier", a.classifier)
      .Text("--robots", a.robots)
      .Int("--half", -1, 1, a.half)
      .Flag("--stills", a.stills)
      .Flag("--no-field", a.no_field)
      .Flag("--per-frame", a.per_frame)
      .Flag("--adapt", a.adapt);
  return args.Parse(argc, argv);
}

struct FieldInputs {
  host::Sequence seq;
  RigCalibration cal;
  ColorLut lut;
  BallClassifier classifier;
  std::string lut_used;  // what LoadLutOrDefault took
  std::map<uint64_t, TruthRow> truth;
  std::map<int64_t, std::vector<RobotTruth>> robots;
};

bool LoadFieldInputs(const FieldArgs& a, FieldInputs& in, std::string& err) {
  return host::LoadSequence(a.seq, in.seq, err) && LoadCalibrationFile(a.calib, in.cal, err) &&
         LoadLutOrDefault(a.lut, a.calib, in.lut, in.lut_used, err, a.ball) &&
         LoadClassifierArg(a.classifier, in.classifier, err) &&
         LoadTruth(a.seq + "/truth.csv", in.truth, err) &&
         (a.robots.empty() || LoadRobots(a.robots, in.robots, err));
}

void PrintFrame(const Pipeline& p, const FrameRecord& rec, const TruthRow& t, double t_s) {
  const FieldFeatures& ff = p.features();
  if (t.vis[1] && !rec.state.persp.found) {
    std::printf(
        "frame %lld: persp ball visible (%.1f, %.1f, area %.0f) not found (out-of-field refused "
        "%u, dropped %u)\n",
        static_cast<long long>(rec.index), t.cu[1], t.cv[1], t.area[1],
        p.last_stats().out_of_field_rejected, p.last_stats().tracks_dropped_out_of_field);
  }
  const PoseEstimate& e = p.localisation();
  std::printf(
      "frame %lld t %.3f pose state %d (%.2f, %.2f, %.1f deg) sigma %.2f q %.2f "
      "amb %d lines %d obstacles %d goals %d | truth (%.2f, %.2f, %.1f)\n",
      static_cast<long long>(rec.index), t_s, e.state, e.x_m, e.y_m, e.heading_rad * 180 / kPi,
      e.sigma_x_m, e.quality, e.ambiguous, ff.line_count, ff.obstacle_count, ff.goal_count, t.rx,
      t.ry, t.rh_deg);
  std::printf("  ball %s (%.2f, %.2f, %.2f) | truth (%.2f, %.2f, %.2f) | handovers so far %u\n",
              rec.state.found ? "found" : "none", rec.state.x_m, rec.state.y_m, rec.state.z_m, t.bx,
              t.by, t.bz, p.last_stats().track_handovers);
  for (int i = 0; i < ff.goal_count; ++i) {
    const Goal& g = ff.goals[i];
    std::printf("  goal (%.2f, %.2f) d %.2f bearing %.1f +- %.1f deg rays %d posts %d which %d\n",
                g.x_m, g.y_m, g.distance_m, g.bearing_rad * 180 / kPi, g.half_width_rad * 180 / kPi,
                g.rays, g.post_rays, g.which);
  }
}

// One replayed frame against its truth row (frames without one count only their lookups).
void ScoreFrame(const FieldArgs& a, FieldInputs& in, uint64_t t0, const Pipeline& p,
                const FrameRecord& rec, Figures& fig) {
  ++fig.frames;
  const auto it = in.truth.find(rec.state.t_us);
  const FieldFeatures& ff = p.features();
  fig.sum_feature_lookups += ff.lookups;
  fig.max_feature_lookups = std::max<double>(fig.max_feature_lookups, ff.lookups);
  if (it == in.truth.end()) return;
  const double t_s = static_cast<double>(rec.state.t_us - t0) * 1e-6;
  ScorePose(p.localisation(), it->second, t_s, fig);
  ScoreLines(ff, p.field_model(), it->second, fig);
  if (!a.robots.empty()) ScoreObstacles(ff, in.robots[rec.index], fig);
  ScoreGoals(ff, p.field_model().config(), it->second, fig);
  ScoreBall(rec.state, it->second, fig);
  if (a.per_frame) PrintFrame(p, rec, it->second, t_s);
}

void PrintAdaptation(const ColorAdapter& adapter) {
  const ColorAdaptStats& s = adapter.stats();
  const BallColorModel& m = adapter.model();
  std::printf(
      "colour adaptation        %u confirmed frames, %u refits (%u refused, %u left the model as "
      "it was), model now hue %.1f..%.1f deg, chroma >= %.2f, Y >= %d\n",
      s.frames_observed, s.refits, s.refits_refused, s.refits_unchanged, m.hue_min_deg,
      m.hue_max_deg, m.chroma_min, m.y_min);
}

}  // namespace

int CmdEvalField(int argc, char** argv) {
  FieldArgs a;
  if (const int rc = ParseFieldArgs(argc, argv, a); rc >= 0) return rc;
  std::string err;
  FieldInputs in;
  if (!LoadFieldInputs(a, in, err)) {
    std::fprintf(stderr, "ballvision eval-field: %s\n", err.c_str());
    return 1;
  }
  std::fprintf(stderr, "colour LUT: %s\n", in.lut_used.c_str());
  static ColorAdapter adapter;
  if (a.adapt) {
    if (in.lut_used.rfind("built-in", 0) != 0) {
      std::fprintf(stderr,
                   "ballvision eval-field: --adapt starts from the built-in colour model (--lut "
                   "builtin): a table file does not carry the model it was built from\n");
      return 2;
    }
    BallName b = BallName::kRed;
    ParseBallName(a.ball.empty() ? "red" : a.ball.c_str(), b);
    adapter.Start(BuiltInBallModel(b), &in.lut);
  }
  auto pipeline = std::make_unique<OwnedPipeline>();
  PipelineConfig config;
  config.field_features = !a.no_field;
  config.classifier = in.classifier.loaded() ? &in.classifier : nullptr;
  Status st = pipeline->Init(in.cal, in.lut, config);
  if (a.adapt) pipeline->SetColorAdapter(&adapter);
  if (st.ok() && a.half != 0) st = pipeline->SetFieldHalf(static_cast<int8_t>(a.half));
  if (!st.ok()) {
    std::fprintf(stderr, "ballvision eval-field: pipeline: %s\n", st.message());
    return 1;
  }
  Figures fig;
  const uint64_t t0 = in.seq.entries.empty() ? 0 : in.seq.entries.front().t_us;
  RunSettings rs;
  rs.reset_each_frame = a.stills;
  rs.on_frame = [&](const Pipeline& p, const FrameRecord& rec) {
    ScoreFrame(a, in, t0, p, rec, fig);
  };
  std::vector<FrameRecord> recs;
  if (!RunSequence(in.seq, *pipeline, rs, recs, err)) {
    std::fprintf(stderr, "ballvision eval-field: %s\n", err.c_str());
    return 1;
  }
  PrintFigures(fig, !a.robots.empty());
  if (a.adapt) PrintAdaptation(adapter);
  return 0;
}

}  // namespace bv::cli
