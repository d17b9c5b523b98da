// ballvision detect: the device's front end on still images; ballvision detect-eval: the
// real-image figures (per set and pooled) for teaching from half a set, from its first five
// ball images, and for the built-in table.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include <sys/stat.h>

#include "core/ball_check/ball_check.h"
#include "core/color_lut/color_model.h"
#include "hal/host/sequence.h"
#include "tools/ballvision/annotate_frontend.h"
#include "tools/ballvision/box_file.h"
#include "tools/ballvision/box_teach.h"
#include "tools/ballvision/calib_io.h"
#include "tools/ballvision/cli_args.h"
#include "tools/ballvision/commands.h"
#include "tools/ballvision/run_common.h"
#include "tools/ballvision/safe_write.h"
#include "tools/ballvision/signals.h"
#include "tools/ballvision/still_detect.h"
#include "tools/ballvision/still_image.h"

namespace bv::cli {
namespace {

constexpr char kDetectUsage[] =
    "usage: ballvision detect --lut FILE|builtin [--ball red|orange|yellow]\n"
    "                         [--calib CALIB --camera persp] [--classifier FILE|builtin|off]\n"
    "                         --json OUT [--annotate DIR] [--candidates CSV] [--max-balls N]\n"
    "                         IMAGE|DIR...\n"
    "  Runs the device's front end (scan table for the image's size, colour table, regions,\n"
    "  size-and-place and appearance checks, ball choice) on JPEG or PNG stills up to 1280x1024.\n"
    "  --lut FILE     a table or teach file (`lut teach --boxes` adds the camera's floor-ball\n"
    "                 profile, used for size and place when no --calib is given)\n"
    "  --lut builtin  the built-in model of --ball (default red)\n"
    "  --calib CALIB --camera persp   size and place from the calibrated persp camera\n"
    "  --classifier   the appearance classifier's weights blob (default builtin); off: none\n"
    "  --json OUT     {\"images\": [{\"file\", \"width\", \"height\", \"balls\": [{\"u\", \"v\",\n"
    "                 \"r\", \"score\"}]}]}, the chosen ball first, at most --max-balls (4)\n"
    "  --annotate DIR one picture per image (scan pixels, regions, the choice)\n"
    "  --candidates CSV   every candidate's features and verdicts (classifier training)\n";

constexpr char kEvalUsage[] =
    "usage: ballvision detect-eval --boxes FILE --images DIR [--protocol half|first5|builtin|all]\n"
    "                              [--ball red|orange|yellow] [--classifier FILE|builtin|off]\n"
    "                              [--sets PREFIX[,PREFIX...]] [--verbose] [--json OUT]\n"
    "                              [--candidates CSV]  (every candidate's features, labelled)\n"
    "                              [--more-boxes FILE]  (boxes the first file lacks, same format)\n"
    "       ballvision detect-eval --sim SEQ [--lut FILE|builtin] [--ball NAME] [--calib CALIB]\n"
    "                              [--classifier FILE|builtin|off] [--candidates CSV]\n"
    "  (a rendered sequence's persp frames against its truth.csv)\n"
    "  Real-image figures per set (images sharing the name up to the second '_') and pooled:\n"
    "  half     per set, taught (lut teach --boxes) from the even images, tested on the odd ones,\n"
    "           and the other way round\n"
    "  first5   taught from the set's first five images with a ball, tested on the rest\n"
    "  builtin  the built-in table of --ball (default yellow), no teaching, every image\n"
    "  Scoring: the first ball is found when it lies inside a ball box grown by 15 % (a box on\n"
    "  the image border, which the border clips, also beyond it by the ball's visible extent:\n"
    "  a cut ball's fitted centre lies there); an image\n"
    "  counts for recall when it has a ball box at least 10 px wide whose sides are at least\n"
    "  half as long as each other (not mostly hidden or cut); a first ball matching no box is\n"
    "  false on any image. Centre error: first ball to the matched box's centre. The candidates'\n"
    "  box column: the matched ball box, -1 none, -2 a ball box matched only beyond the border.\n";

bool ReadFile(const std::string& path, std::vector<uint8_t>& out, std::string& error) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    error = path + ": cannot read";
    return false;
  }
  out.assign(std::istreambuf_iterator<char>(in), {});
  return true;
}

// --lut FILE|builtin with --ball: the table, and the teach file's profile if it has one.
bool LoadTable(const std::string& lut_arg, const std::string& ball, ColorLut& lut,
               FloorBallProfile& profile, std::string& error) {
  profile = FloorBallProfile{};
  if (lut_arg == "builtin") return FillBuiltInBallLut(ball.empty() ? "red" : ball, lut, error);
  std::vector<uint8_t> blob;
  if (!ReadFile(lut_arg, blob, error)) return false;
  const Status st = ParseLut(blob, lut, &profile);
  if (!st.ok()) {
    error = lut_arg + ": " + st.message();
    return false;
  }
  return true;
}

bool LoadClassifier(const std::string& arg, BallClassifier& c, std::string& error) {
  return LoadClassifierArg(arg, c, error);
}

BallFinderConfig StillFinderConfig() {
  BallFinderConfig f;
  f.fit_circles = true;  // persp stills: a ball cut by the border or merged with its surroundings
  return f;
}

// ---- detect ----

struct DetectArgs {
  std::string lut, ball, calib, camera = "persp", classifier, json, annotate, candidates;
  int max_balls = 4;
  std::vector<std::string> inputs;
};

void CandidateHeader(SafeOutput& out) {
  out << "file,u,v,r,area,chosen,refusal,place,height_m,floor_ratio,logit,score";
  for (int i = 0; i < kBallFeatureCount; ++i) out << ",f" << i;
  out << "\n";
}

void CandidateRows(SafeOutput& out, const std::string& file, const StillResult& r) {
  static const char* kRefusal[] = {"none", "shape", "place", "look"};
  for (const StillCandidate& c : r.candidates) {
    char buf[256];
    std::snprintf(buf, sizeof buf, "%s,%.2f,%.2f,%.2f,%.1f,%d,%s,%d,%.3f,%.3f,%.4f,%.4f",
                  file.c_str(), c.shape.u_px, c.shape.v_px, c.shape.radius_px, c.shape.area_px,
                  c.chosen ? 1 : 0, kRefusal[static_cast<int>(c.refusal)],
                  static_cast<int>(c.verdict.place), c.verdict.where.height_m,
                  c.verdict.where.floor_ratio, c.verdict.logit, c.verdict.score);
    out << buf;
    for (float f : c.features.f) {
      std::snprintf(buf, sizeof buf, ",%.5g", f);
      out << buf;
    }
    out << "\n";
  }
}

// IMAGE|DIR arguments as image files, a directory's in name order.
bool ExpandInputs(const std::vector<std::string>& inputs, std::vector<std::string>& files,
                  std::string& error) {
  for (const std::string& in : inputs) {
    struct stat st;
    if (stat(in.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) {
      files.push_back(in);
      continue;
    }
    std::vector<std::string> listed;
    if (!ListStills(in, {}, listed, error)) return false;
    if (listed.empty()) {
      error = in + ": no JPEG or PNG image in it";
      return false;
    }
    files.insert(files.end(), listed.begin(), listed.end());
  }
  return true;
}

nlohmann::json BallsJson(const StillResult& r) {
  nlohmann::json balls = nlohmann::json::array();
  for (const StillBall& b : r.balls) {
    balls.push_back({{"u", std::round(b.u_px * 100) / 100},
                     {"v", std::round(b.v_px * 100) / 100},
                     {"r", std::round(b.radius_px * 100) / 100},
                     {"score", std::round(b.score * 1e4) / 1e4}});
  }
  return balls;
}

void PrintStill(const std::string& f, const Still& still, const StillResult& r) {
  if (r.balls.empty()) {
    std::printf("%s: %dx%d  no ball  (candidates %u, refused by place %u, by look %u)\n", f.c_str(),
                still.width, still.height, r.stats.candidates, r.stats.refused_place,
                r.stats.refused_look);
    return;
  }
  std::printf(
      "%s: %dx%d  ball (%.1f, %.1f) r %.1f score %.3f  (+%zu more; refused by place %u, by look "
      "%u)\n",
      f.c_str(), still.width, still.height, r.balls[0].u_px, r.balls[0].v_px, r.balls[0].radius_px,
      r.balls[0].score, r.balls.size() - 1, r.stats.refused_place, r.stats.refused_look);
}

bool AnnotateStill(const std::string& dir, const std::string& f, const Still& still,
                   const StillResult& r, const ColorLut& lut, const StillDetector& detector,
                   std::string& error) {
  BallDetection det;
  if (!r.balls.empty()) {
    det.found = true;
    det.u_px = r.balls[0].u_px;
    det.v_px = r.balls[0].v_px;
    det.radius_px = r.balls[0].radius_px;
  }
  const std::string base = f.substr(f.find_last_of('/') + 1);
  return AnnotateFrontEnd(still.image.view(), lut, detector.scan(), detector.finder(), nullptr, det,
                          dir + "/" + base + ".png", &error, 1);
}

// What detect runs with, loaded and checked.
struct DetectInputs {
  FloorBallProfile profile;
  BallClassifier classifier;
  RigCalibration cal;
  std::vector<std::string> files;
};

int ParseDetect(int argc, char** argv, DetectArgs& a, ColorLut& lut, DetectInputs& in) {
  ArgParser p("ballvision detect", kDetectUsage);
  p.Text("--lut", a.lut)
      .Text("--ball", a.ball)
      .Text("--calib", a.calib)
      .Text("--camera", a.camera)
      .Text("--classifier", a.classifier)
      .Text("--json", a.json)
      .Text("--annotate", a.annotate)
      .Text("--candidates", a.candidates)
      .Int("--max-balls", 1, 16, a.max_balls)
      .Rest("IMAGE", a.inputs)
      .Required("--lut")
      .Required("--json");
  if (const int rc = p.Parse(argc, argv); rc >= 0) return rc;
  if (a.inputs.empty()) return p.UsageError("no IMAGE or DIR given");
  if (a.camera != "persp") {
    return p.UsageError("--camera: got '" + a.camera +
                        "'; stills are detected as the persp camera sees them (persp)");
  }
  if (!a.ball.empty() && a.lut != "builtin") {
    return p.UsageError("--ball chooses a built-in model: it needs --lut builtin");
  }
  std::string error;
  const bool ok = CheckOutputPath(a.json, error) &&
                  (a.candidates.empty() || CheckOutputPath(a.candidates, error)) &&
                  (a.annotate.empty() || MakeOutputDirectory(a.annotate, error)) &&
                  LoadTable(a.lut, a.ball, lut, in.profile, error) &&
                  LoadClassifier(a.classifier, in.classifier, error) &&
                  (a.calib.empty() || LoadCalibrationFile(a.calib, in.cal, error)) &&
                  ExpandInputs(a.inputs, in.files, error);
  if (ok && !a.calib.empty() && !in.cal.persp.valid) error = a.calib + " has no persp camera";
  if (!ok || !error.empty()) {
    std::fprintf(stderr, "ballvision detect: %s\n", error.c_str());
    return 1;
  }
  return -1;
}

int Detect(int argc, char** argv) {
  DetectArgs a;
  static ColorLut lut;
  DetectInputs in;
  if (const int rc = ParseDetect(argc, argv, a, lut, in); rc >= 0) return rc;
  std::string error;
  DetectSetup setup;
  setup.lut = &lut;
  setup.profile = in.profile;
  setup.persp = a.calib.empty() ? nullptr : &in.cal.persp;
  setup.classifier = &in.classifier;
  setup.finder = StillFinderConfig();
  setup.max_balls = a.max_balls;
  StillDetector detector;
  SafeOutput cand;
  if (!detector.Init(setup, error) || (!a.candidates.empty() && !cand.Open(a.candidates, error))) {
    std::fprintf(stderr, "ballvision detect: %s\n", error.c_str());
    return 1;
  }
  if (cand.is_open()) CandidateHeader(cand);
  InstallInterruptHandlers();
  nlohmann::json images = nlohmann::json::array();
  int with_ball = 0;
  for (const std::string& f : in.files) {
    if (InterruptSignal()) {
      ReportInterrupt("ballvision detect");
      std::fprintf(stderr, "ballvision detect: %s not written\n", a.json.c_str());
      return InterruptExitCode();
    }
    Still still;
    StillResult r;
    if (!LoadStill(f, still, error) || !detector.Detect(still.image, r, cand.is_open(), error) ||
        (!a.annotate.empty() && !AnnotateStill(a.annotate, f, still, r, lut, detector, error))) {
      std::fprintf(stderr, "ballvision detect: %s\n", error.c_str());
      std::fprintf(stderr, "ballvision detect: %s not written\n", a.json.c_str());
      return 1;
    }
    images.push_back(
        {{"file", f}, {"width", still.width}, {"height", still.height}, {"balls", BallsJson(r)}});
    with_ball += !r.balls.empty();
    PrintStill(f, still, r);
    if (cand.is_open()) CandidateRows(cand, f, r);
  }
  const nlohmann::json doc = {{"images", images}};
  if (!WriteFileAtomic(a.json, doc.dump(1) + "\n", error) ||
      (cand.is_open() && !cand.Commit(error))) {
    std::fprintf(stderr, "ballvision detect: %s\n", error.c_str());
    return 1;
  }
  std::printf("%zu images, a ball in %d; size and place: %s; classifier: %s; wrote %s\n",
              in.files.size(), with_ball,
              !a.calib.empty() ? "calibration" : (in.profile.valid ? "teach profile" : "none"),
              in.classifier.loaded() ? "on" : "off", a.json.c_str());
  return 0;
}

// ---- detect-eval ----

struct Score {
  int images = 0, countable = 0, found = 0, false_images = 0;
  std::vector<float> centre_err;
  void Add(const Score& o) {
    images += o.images, countable += o.countable, found += o.found;
    false_images += o.false_images;
    centre_err.insert(centre_err.end(), o.centre_err.begin(), o.centre_err.end());
  }
};

bool Countable(const AnnotatedBox& b) {
  const float w = b.u1 - b.u0, h = b.v1 - b.v0;
  return b.class_id == 0 && std::max(w, h) >= 10.0f && std::min(w, h) >= 0.5f * std::max(w, h);
}

// The ball box a detection at (u, v) falls in (grown by 7.5 % a side), the nearest centre first;
// -1 for none. The dataset clips a box to the image: one on its border is also grown beyond it by
// the ball's visible extent, where the fitted circle of a ball the border cuts has its centre
// (`beyond` says when only that part matched).
int MatchBox(const AnnotatedImage& im, int width, int height, float u, float v,
             float* centre_err = nullptr, bool* beyond = nullptr) {
  int best = -1;
  float best_e = 0;
  if (beyond != nullptr) *beyond = false;
  for (size_t i = 0; i < im.boxes.size(); ++i) {
    const AnnotatedBox& x = im.boxes[i];
    if (x.class_id != 0) continue;
    const float gw = 0.075f * (x.u1 - x.u0), gh = 0.075f * (x.v1 - x.v0);
    const float cut = std::max(x.u1 - x.u0, x.v1 - x.v0);
    // The box grown by these margins on its left, top, right and bottom.
    const auto within = [&](float left, float top, float right, float bottom) {
      return u >= x.u0 - left && u <= x.u1 + right && v >= x.v0 - top && v <= x.v1 + bottom;
    };
    const bool at_right = width > 0 && x.u1 >= static_cast<float>(width) - 1.0f;
    const bool at_bottom = height > 0 && x.v1 >= static_cast<float>(height) - 1.0f;
    if (!within(x.u0 <= 1.0f ? cut : gw, x.v0 <= 1.0f ? cut : gh, at_right ? cut : gw,
                at_bottom ? cut : gh)) {
      continue;
    }
    const float e = std::hypot(u - 0.5f * (x.u0 + x.u1), v - 0.5f * (x.v0 + x.v1));
    if (best < 0 || e < best_e) {
      best = static_cast<int>(i);
      best_e = e;
      if (beyond != nullptr) *beyond = !within(gw, gh, gw, gh);
    }
  }
  if (centre_err != nullptr) *centre_err = best_e;
  return best;
}

// The first ball against the image's boxes (`width`, `height`: the image's size).
void ScoreImage(const AnnotatedImage& im, int width, int height, const StillResult& r, Score& s,
                bool verbose) {
  ++s.images;
  const bool countable = std::any_of(im.boxes.begin(), im.boxes.end(), Countable);
  s.countable += countable;
  if (r.balls.empty()) {
    if (verbose && countable) std::printf("    %s: MISS (nothing)\n", im.name.c_str());
    return;
  }
  const StillBall& b = r.balls[0];
  float best = 0;
  if (MatchBox(im, width, height, b.u_px, b.v_px, &best) < 0) {
    ++s.false_images;
    if (verbose) {
      std::printf("    %s: FALSE at (%.0f, %.0f) r %.1f score %.3f%s\n", im.name.c_str(), b.u_px,
                  b.v_px, b.radius_px, b.score, countable ? " (ball missed)" : "");
    }
    return;
  }
  if (countable) {
    ++s.found;
    s.centre_err.push_back(best);
  }
}

float Percentile(std::vector<float> v, float q) {
  if (v.empty()) return 0.0f;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * static_cast<float>(v.size())))];
}

void PrintScore(const std::string& label, const Score& s) {
  std::printf(
      "  %-24s images %4d  found %4d / %4d (%5.1f %%)  false %3d (%4.1f %%)  centre err "
      "median %.1f p90 %.1f px\n",
      label.c_str(), s.images, s.found, s.countable,
      s.countable ? 100.0 * s.found / s.countable : 0.0, s.false_images,
      s.images ? 100.0 * s.false_images / s.images : 0.0, Percentile(s.centre_err, 0.5f),
      Percentile(s.centre_err, 0.9f));
}

nlohmann::json ScoreJson(const Score& s) {
  return {{"images", s.images},
          {"countable", s.countable},
          {"found", s.found},
          {"false_images", s.false_images},
          {"recall", s.countable ? static_cast<double>(s.found) / s.countable : 0.0},
          {"false_rate", s.images ? static_cast<double>(s.false_images) / s.images : 0.0},
          {"centre_err_median_px", Percentile(s.centre_err, 0.5f)},
          {"centre_err_p90_px", Percentile(s.centre_err, 0.9f)}};
}

struct EvalContext {
  std::string boxes;
  const BallClassifier* classifier = nullptr;
  bool verbose = false;
  SafeOutput* candidates = nullptr;  // --candidates: every candidate of every test image
  std::string label;                 // protocol and split, for the candidate rows
};

// Detects on `test` with `lut` (and `profile`), scoring into `s`.
bool RunTest(const EvalContext& ctx, const ColorLut& lut, const FloorBallProfile& profile,
             const std::vector<AnnotatedImage>& test, Score& s, std::string& error) {
  DetectSetup setup;
  setup.lut = &lut;
  setup.profile = profile;
  setup.classifier = ctx.classifier;
  setup.finder = StillFinderConfig();
  StillDetector detector;
  if (!detector.Init(setup, error)) return false;
  for (const AnnotatedImage& im : test) {
    Still still;
    StillResult r;
    if (!LoadStill(im.path, still, error) ||
        !CheckBoxesInside(ctx.boxes, im, still.width, still.height, error) ||
        !detector.Detect(still.image, r, ctx.candidates != nullptr, error)) {
      return false;
    }
    ScoreImage(im, still.width, still.height, r, s, ctx.verbose);
    if (ctx.candidates != nullptr) {
      const bool countable = std::any_of(im.boxes.begin(), im.boxes.end(), Countable);
      for (const StillCandidate& c : r.candidates) {
        // -2: a ball matched only beyond the image border that cuts it (its look is not judged
        // where its place is known, BallCheck::Evaluate).
        bool beyond = false;
        int box =
            MatchBox(im, still.width, still.height, c.shape.u_px, c.shape.v_px, nullptr, &beyond);
        if (box >= 0 && beyond) box = -2;
        char buf[160];
        std::snprintf(buf, sizeof buf, "%s,%s,%d,%d,", ctx.label.c_str(), im.name.c_str(),
                      countable ? 1 : 0, box);
        *ctx.candidates << buf;
        StillResult one;
        one.candidates.push_back(c);
        CandidateRows(*ctx.candidates, "", one);
      }
    }
  }
  return true;
}

// Teaches from `train` (lut teach --boxes); on a refusal every test image is scored with no ball
// (said).
bool TeachAndTest(const EvalContext& ctx, const std::string& label,
                  const std::vector<AnnotatedImage>& train, const std::vector<AnnotatedImage>& test,
                  Score& s, std::string& error) {
  BoxTeach t;
  std::string why;
  if (!TeachFromBoxes(ctx.boxes, train, BoxTeachOptions{}, t, why)) {
    std::printf("    %s: teach refused (%s): every test image scored without a ball\n",
                label.c_str(), why.c_str());
    for (const AnnotatedImage& im : test) ScoreImage(im, 0, 0, StillResult{}, s, false);
    return true;
  }
  if (ctx.verbose) {
    std::printf(
        "    %s: %d ball cells (blur +-%d) holding %.0f %% of the boxes, %.3f %% of the field "
        "taken; profile %s\n",
        label.c_str(), t.ball_cells, t.smooth, 100.0 * t.ball_coverage, 100.0 * t.field_taken,
        t.profile.valid ? "learned" : t.profile_note.c_str());
  }
  return RunTest(ctx, *t.table, t.profile, test, s, error);
}

// A rendered sequence's persp frames (training data and figures for renders): the ball is
// where truth.csv puts its visible silhouette; a candidate is the ball within max(3 px, its
// radius) of it.
int SimEval(const std::string& dir, const std::string& lut_arg, const std::string& ball,
            const std::string& calib, const BallClassifier& classifier,
            const std::string& candidates_path, bool verbose) {
  std::string error;
  host::Sequence seq;
  std::vector<lut::SimTruth> truth;
  static ColorLut lut;
  FloorBallProfile profile;
  RigCalibration cal;
  if (!host::LoadSequence(dir, seq, error) || !lut::LoadSimTruth(dir, truth, error) ||
      !LoadTable(lut_arg, ball, lut, profile, error) ||
      (!calib.empty() && !LoadCalibrationFile(calib, cal, error))) {
    std::fprintf(stderr, "ballvision detect-eval: %s\n", error.c_str());
    return 1;
  }
  std::map<int64_t, const lut::SimTruth*> by_index;
  for (const lut::SimTruth& t : truth) by_index[t.index] = &t;
  DetectSetup setup;
  setup.lut = &lut;
  setup.profile = profile;
  setup.persp = calib.empty() ? nullptr : &cal.persp;
  setup.classifier = &classifier;
  setup.finder = StillFinderConfig();
  StillDetector detector;
  if (!detector.Init(setup, error)) {
    std::fprintf(stderr, "ballvision detect-eval: %s\n", error.c_str());
    return 1;
  }
  SafeOutput cand;
  if (!candidates_path.empty()) {
    if (!cand.Open(candidates_path, error)) {
      std::fprintf(stderr, "ballvision detect-eval: %s\n", error.c_str());
      return 1;
    }
    cand << "protocol,set,image,countable,box,";
    CandidateHeader(cand);
  }
  int frames = 0, with_ball = 0, found = 0, false_frames = 0;
  std::vector<float> err;
  for (const host::SequenceEntry& e : seq.entries) {
    if (e.persp_path.empty() || !by_index.count(e.index)) continue;
    const lut::SimTruth& t = *by_index[e.index];
    lut::Image img;
    StillResult r;
    if (!lut::LoadImage(e.persp_path, img, error) ||
        !detector.Detect(img, r, cand.is_open(), error)) {
      std::fprintf(stderr, "ballvision detect-eval: %s\n", error.c_str());
      return 1;
    }
    ++frames;
    const bool ball_there = t.visible[1];
    with_ball += ball_there;
    const float tr = std::sqrt(std::max(t.area[1], 1.0f) / 3.14159265f);
    auto on_ball = [&](float u, float v, float* d = nullptr) {
      const float dist = std::hypot(u - t.cu[1], v - t.cv[1]);
      if (d != nullptr) *d = dist;
      return t.visible[1] && dist <= std::max(3.0f, tr);
    };
    if (!r.balls.empty()) {
      float d = 0;
      if (on_ball(r.balls[0].u_px, r.balls[0].v_px, &d)) {
        ++found;
        err.push_back(d);
      } else {
        ++false_frames;
        if (verbose) {
          std::printf("    %lld: FALSE at (%.0f, %.0f) r %.1f\n", static_cast<long long>(e.index),
                      r.balls[0].u_px, r.balls[0].v_px, r.balls[0].radius_px);
        }
      }
    }
    if (cand.is_open()) {
      for (const StillCandidate& c : r.candidates) {
        char buf[200];
        std::snprintf(buf, sizeof buf, "sim,%s,%lld,%d,%d,", dir.c_str(),
                      static_cast<long long>(e.index), ball_there ? 1 : 0,
                      on_ball(c.shape.u_px, c.shape.v_px) ? 0 : -1);
        cand << buf;
        StillResult one;
        one.candidates.push_back(c);
        CandidateRows(cand, "", one);
      }
    }
  }
  if (cand.is_open() && !cand.Commit(error)) {
    std::fprintf(stderr, "ballvision detect-eval: %s\n", error.c_str());
    return 1;
  }
  std::printf(
      "%s persp: frames %d, ball visible in %d, found %d (%.1f %%), false %d (%.1f %%), "
      "centre err median %.2f p90 %.2f px\n",
      dir.c_str(), frames, with_ball, found, with_ball ? 100.0 * found / with_ball : 0.0,
      false_frames, frames ? 100.0 * false_frames / frames : 0.0, Percentile(err, 0.5f),
      Percentile(err, 0.9f));
  return 0;
}

using ImageSets = std::map<std::string, std::vector<AnnotatedImage>>;

// The images by set (those whose set name starts with one of `sets_arg`'s prefixes; all when
// empty), each set in name order.
ImageSets GroupSets(const std::vector<AnnotatedImage>& all, const std::string& sets_arg) {
  std::vector<std::string> wanted;
  for (size_t a = 0; a < sets_arg.size();) {
    const size_t b = sets_arg.find(',', a);
    wanted.push_back(sets_arg.substr(a, b == std::string::npos ? std::string::npos : b - a));
    a = b == std::string::npos ? sets_arg.size() : b + 1;
  }
  ImageSets sets;
  for (const AnnotatedImage& im : all) {
    const std::string set = ImageSet(im.name);
    if (wanted.empty() || std::any_of(wanted.begin(), wanted.end(),
                                      [&](const std::string& w) { return set.rfind(w, 0) == 0; })) {
      sets[set].push_back(im);
    }
  }
  for (auto& [name, v] : sets) {
    std::sort(v.begin(), v.end(),
              [](const AnnotatedImage& x, const AnnotatedImage& y) { return x.name < y.name; });
  }
  return sets;
}

// One protocol on one set.
bool RunProtocol(EvalContext& ctx, const std::string& proto, const std::string& name,
                 const std::vector<AnnotatedImage>& images, const ColorLut& builtin, Score& s,
                 std::string& error) {
  ctx.label = proto + "," + name;
  if (proto == "half") {
    const auto even = SplitImages(images, "even"), odd = SplitImages(images, "odd");
    return TeachAndTest(ctx, name + " even->odd", even, odd, s, error) &&
           TeachAndTest(ctx, name + " odd->even", odd, even, s, error);
  }
  if (proto == "first5") {
    std::vector<AnnotatedImage> train, test;
    for (const AnnotatedImage& im : images) {
      (train.size() < 5 && im.BallCount() > 0 ? train : test).push_back(im);
    }
    return TeachAndTest(ctx, name + " first 5", train, test, s, error);
  }
  return RunTest(ctx, builtin, FloorBallProfile{}, images, s, error);
}

struct EvalArgs {
  std::string boxes, images_dir, protocol = "all", ball = "yellow", classifier, sets, json;
  std::string candidates, sim, lut = "builtin", calib, more_boxes;
  bool verbose = false;
};

int BoxEval(const EvalArgs& a) {
  std::string error;
  std::vector<AnnotatedImage> all;
  BallClassifier classifier;
  static ColorLut builtin;
  FloorBallProfile no_profile;
  const bool ok = (a.json.empty() || CheckOutputPath(a.json, error)) &&
                  LoadAnnotations(a.boxes, a.images_dir, all, error) &&
                  (a.more_boxes.empty() || AddAnnotations(a.more_boxes, all, error)) &&
                  LoadClassifier(a.classifier, classifier, error) &&
                  LoadTable("builtin", a.ball, builtin, no_profile, error);
  const ImageSets sets = ok ? GroupSets(all, a.sets) : ImageSets{};
  if (ok && sets.empty()) error = "no image of the sets " + a.sets + " in " + a.boxes;
  if (!ok || sets.empty()) {
    std::fprintf(stderr, "ballvision detect-eval: %s\n", error.c_str());
    return 1;
  }
  InstallInterruptHandlers();
  EvalContext ctx{a.more_boxes.empty() ? a.boxes : a.boxes + " (+ " + a.more_boxes + ")",
                  &classifier, a.verbose};
  SafeOutput cand;
  if (!a.candidates.empty()) {
    if (!cand.Open(a.candidates, error)) {
      std::fprintf(stderr, "ballvision detect-eval: %s\n", error.c_str());
      return 1;
    }
    cand << "protocol,set,image,countable,box,";
    CandidateHeader(cand);
    ctx.candidates = &cand;
  }
  nlohmann::json out = nlohmann::json::object();
  for (const std::string proto : {"half", "first5", "builtin"}) {
    if (a.protocol != "all" && a.protocol != proto) continue;
    std::printf("%s%s:\n", proto.c_str(),
                proto == "builtin" ? (" (" + a.ball + " ball)").c_str() : "");
    Score pooled;
    nlohmann::json per_set = nlohmann::json::object();
    for (const auto& [name, images] : sets) {
      if (InterruptSignal()) {
        ReportInterrupt("ballvision detect-eval");
        return InterruptExitCode();
      }
      Score s;
      if (!RunProtocol(ctx, proto, name, images, builtin, s, error)) {
        std::fprintf(stderr, "ballvision detect-eval: %s\n", error.c_str());
        return 1;
      }
      PrintScore(name, s);
      per_set[name] = ScoreJson(s);
      pooled.Add(s);
    }
    PrintScore("pooled", pooled);
    out[proto] = {{"sets", per_set}, {"pooled", ScoreJson(pooled)}};
  }
  if ((!a.json.empty() && !WriteFileAtomic(a.json, out.dump(1) + "\n", error)) ||
      (cand.is_open() && !cand.Commit(error))) {
    std::fprintf(stderr, "ballvision detect-eval: %s\n", error.c_str());
    return 1;
  }
  return 0;
}

int DetectEval(int argc, char** argv) {
  EvalArgs a;
  ArgParser p("ballvision detect-eval", kEvalUsage);
  p.Text("--boxes", a.boxes)
      .Text("--more-boxes", a.more_boxes)
      .Text("--images", a.images_dir)
      .Text("--protocol", a.protocol)
      .Text("--ball", a.ball)
      .Text("--classifier", a.classifier)
      .Text("--sets", a.sets)
      .Text("--json", a.json)
      .Text("--candidates", a.candidates)
      .Text("--sim", a.sim)
      .Text("--lut", a.lut)
      .Text("--calib", a.calib)
      .Flag("--verbose", a.verbose);
  if (const int rc = p.Parse(argc, argv); rc >= 0) return rc;
  if (!a.sim.empty()) {
    if (!a.boxes.empty() || !a.more_boxes.empty()) {
      return p.UsageError("give --sim SEQ or --boxes FILE --images DIR, not both");
    }
    BallClassifier c;
    std::string err;
    if (!LoadClassifier(a.classifier, c, err)) {
      std::fprintf(stderr, "ballvision detect-eval: %s\n", err.c_str());
      return 1;
    }
    return SimEval(a.sim, a.lut, a.ball, a.calib, c, a.candidates, a.verbose);
  }
  if (a.boxes.empty() || a.images_dir.empty()) {
    return p.UsageError("give --boxes FILE --images DIR (or --sim SEQ)");
  }
  if (a.protocol != "half" && a.protocol != "first5" && a.protocol != "builtin" &&
      a.protocol != "all") {
    return p.UsageError("--protocol: got '" + a.protocol +
                        "', expected half, first5, builtin or all");
  }
  return BoxEval(a);
}

}  // namespace

int CmdDetect(int argc, char** argv) { return Detect(argc, argv); }
int CmdDetectEval(int argc, char** argv) { return DetectEval(argc, argv); }

}  // namespace bv::cli
