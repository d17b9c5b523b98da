// ballvision lut: train, evaluate and inspect colour lookup tables (core/color_lut).
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "core/color_lut/color_model.h"
#include "tools/ballvision/box_file.h"
#include "tools/ballvision/box_teach.h"
#include "tools/ballvision/cli_args.h"
#include "tools/ballvision/commands.h"
#include "tools/ballvision/lut_teach.h"
#include "tools/ballvision/lut_train.h"
#include "tools/ballvision/run_common.h"
#include "tools/ballvision/safe_write.h"
#include "tools/ballvision/signals.h"

namespace bv::cli {
namespace {

#define BV_LUT_SOURCES                                                                          \
  "sources (repeatable):\n"                                                                     \
  "  --sim DIR            rendered sequence with truth.csv (ball silhouettes from the truth)\n" \
  "  --camera omni|persp|both   cameras of the following --sim (default both)\n"                \
  "  --every N --phase P  use frames with index % N == P (train/test split; default all)\n"     \
  "  --boxes FILE --images DIR [--split all|even|odd]  annotated boxes (msl format:\n"          \
  "                       'image class_id class x0 y0 x1 y1'); --split before or after the\n"   \
  "                       --boxes it applies to, images in name order\n"
constexpr char kTrainUsage[] =
    "usage: ballvision lut train --out LUT.bin [sources] [--ratio R] [--min-weight W]\n"
    "                           [--gauss D2 [--gauss-veto F]]  (chroma-Gaussian ball model)\n"
    "                           [--shade MIN,MAX]  (brightness factors added per ball sample, "
    "0.55,1.30)\n"
    "                           [--smooth N]  (densities blurred over +-N chroma cells)\n"
    "  --teach IMG:U,V[:CLASS[:TOL]]  grow a region from one clicked pixel (CLASS ball|field|\n"
    "                       line|obstacle, default ball; TOL shade-normalised chroma, "
    "0.12)\n" BV_LUT_SOURCES;
constexpr char kEvalUsage[] =
    "usage: ballvision lut eval --lut LUT.bin [sources] [--center U,V] [--no-track] [--verbose]\n"
    "                           [--regions]  (every traced region with its shape measures)\n"
    "                           [--annotate DIR]  (debug pictures of every evaluated frame)\n"
    "                           [--min-roundness R]  (of a ball region, 0..1)\n"
    "                           (--lut builtin: the built-in colour model's "
    "table)\n" BV_LUT_SOURCES;
constexpr char kTeachUsage[] =
    "usage: ballvision lut teach SEQ --out LUT.bin [--click INDEX:omni|persp:U,V]\n"
    "                           [--camera omni|persp|both] [--every N] [--center U,V]\n"
    "                           (fits the ball colour model to the ball across the sequence;\n"
    "                            without --click the ball must be the moving ball-coloured blob)\n"
    "       ballvision lut teach --boxes FILE --images DIR [--split all|even|odd] --out LUT.bin\n"
    "                           (one camera's stills: the ball's colours against the rest, and\n"
    "                            the camera's floor-ball profile, into one teach file)\n";
constexpr char kShowUsage[] = "usage: ballvision lut show LUT.bin\n";
#undef BV_LUT_SOURCES
const std::string kLutUsage = std::string(kTrainUsage) + kEvalUsage + kTeachUsage + kShowUsage;

bool ReadFile(const std::string& path, std::vector<uint8_t>& out) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  out.assign(std::istreambuf_iterator<char>(in), {});
  return true;
}

bool LoadLut(const std::string& path, ColorLut& lut) {
  std::vector<uint8_t> blob;
  if (!ReadFile(path, blob)) {
    std::fprintf(stderr, "ballvision lut: cannot read %s\n", path.c_str());
    return false;
  }
  const Status st = ParseLut(blob, lut);
  if (!st.ok()) {
    std::fprintf(stderr, "ballvision lut: %s: %s\n", path.c_str(), st.message());
    return false;
  }
  return true;
}

struct SimSource {
  std::string dir;
  bool omni = true, persp = true;
  int every = 1, phase = 0;
};
struct BoxSource {
  std::string file, images, split = "all";
  bool split_given = false;  // a --split after this --boxes named its split
};
struct Teach {
  std::string image;
  int u = 0, v = 0;
  ColorClass cls = ColorClass::kBall;
  float tol = 0.12f;
};

struct Args {
  std::string out, lut;
  std::vector<SimSource> sims;
  std::vector<BoxSource> boxes;
  std::vector<Teach> teach;
  lut::TrainOptions train;
  lut::FinderSetup setup;
  bool verbose = false;
};

bool ParseClass(const std::string& s, ColorClass& c) {
  for (int i = 0; i < kColorClassCount; ++i) {
    if (s == ColorClassName(static_cast<ColorClass>(i))) {
      c = static_cast<ColorClass>(i);
      return true;
    }
  }
  return false;
}

// IMG:U,V[:CLASS[:TOL]]
bool ParseTeach(const std::string& val, Teach& t, std::string& error) {
  std::vector<std::string> parts;
  size_t start = 0;
  for (size_t p = val.find(':'); p != std::string::npos; p = val.find(':', start)) {
    parts.push_back(val.substr(start, p - start));
    start = p + 1;
  }
  parts.push_back(val.substr(start));
  int64_t tu = 0, tv = 0;
  if (parts.size() < 2) {
    error = "--teach: got '" + val + "', expected IMG:U,V[:CLASS[:TOL]]";
    return false;
  }
  if (!ArgIntPair("--teach", parts[1], ',', 0, 8191, tu, tv, error)) return false;
  t.u = static_cast<int>(tu);
  t.v = static_cast<int>(tv);
  t.image = parts[0];
  if (parts.size() > 2 && !ParseClass(parts[2], t.cls)) {
    error = "--teach: got class '" + parts[2] + "', expected ball, field, line or obstacle";
    return false;
  }
  return parts.size() <= 3 || ArgNumberAs("--teach", parts[3], 0, 10, t.tol, error);
}

// The table trainer's options (`lut train`; `lut eval` accepts and ignores them).
void AddTrainOptions(ArgParser& p, Args& a) {
  p.Number("--ratio", 0, 1e6, a.train.ratio)
      .Custom("--shade",
              [&a](const std::string& v, std::string& error) {
                double lo = 0, hi = 0;
                if (!ArgNumberPair("--shade", v, ',', 0.01, 100, lo, hi, error)) return false;
                a.train.shade_min = static_cast<float>(lo);
                a.train.shade_max = static_cast<float>(hi);
                return true;
              })
      .Number("--gauss", 0, 1e6, a.train.gauss_d2)
      .Number("--gauss-veto", 0, 1e6, a.train.gauss_veto)
      .Number("--min-weight", 0, 1e9, a.train.min_ball_weight)
      .Int("--smooth", 0, 8, a.train.smooth)
      .Custom("--teach", [&a](const std::string& v, std::string& error) {
        Teach t;
        if (!ParseTeach(v, t, error)) return false;
        a.teach.push_back(t);
        return true;
      });
}

// One option set for train and eval. Source modifiers (--camera, --every, --phase, --split)
// apply to the --sim / --boxes after them: the handlers run in command-line order.
int ParseArgs(int argc, char** argv, const std::string& command, Args& a) {
  bool omni = true, persp = true;
  int every = 1, phase = 0;
  std::string split = "all";
  double cu = 314.2, cv = 244.1;  // reference rig mirror circle (render/README.md)
  std::string pending;            // a source modifier no source has used yet
  bool last_was_boxes = false;    // the last source given was a --boxes
  const auto modifier = [&pending](const char* name, ArgParser::Handler check) {
    return [name, check, &pending](const std::string& v, std::string& error) {
      if (!check(v, error)) return false;
      pending = name;
      return true;
    };
  };
  ArgParser p(command, command == "ballvision lut train" ? kTrainUsage : kEvalUsage);
  p.FlagAction("--regions", [&a] { a.setup.dump_regions = true; })
      .FlagAction("--verbose", [&a] { a.verbose = a.setup.verbose = true; })
      .FlagAction("--no-track", [&a] { a.setup.track = false; })
      .Text("--out", a.out)
      .Text("--lut", a.lut)
      .Text("--annotate", a.setup.annotate_dir)
      .Custom("--camera", modifier("--camera",
                                   [&](const std::string& v, std::string& error) {
                                     omni = v == "omni" || v == "both";
                                     persp = v == "persp" || v == "both";
                                     if (omni || persp) return true;
                                     error =
                                         "--camera: got '" + v + "', expected omni, persp or both";
                                     return false;
                                   }))
      .Custom("--every", modifier("--every",
                                  [&](const std::string& v, std::string& error) {
                                    return ArgIntAs("--every", v, 1, 1000000, every, error);
                                  }))
      .Custom("--phase", modifier("--phase",
                                  [&](const std::string& v, std::string& error) {
                                    return ArgIntAs("--phase", v, 0, 999999, phase, error);
                                  }))
      .Custom("--split",
              [&](const std::string& v, std::string& error) {
                if (v != "all" && v != "even" && v != "odd") {
                  error = "--split: got '" + v + "', expected all, even or odd";
                  return false;
                }
                split = v;
                // After a --boxes (and before the next source) it is that source's split, as
                // before it: `--boxes F --images D --split odd` = `--split odd --boxes F ...`.
                if (!a.boxes.empty() && !a.boxes.back().split_given && last_was_boxes) {
                  a.boxes.back().split = v;
                  a.boxes.back().split_given = true;
                  return true;
                }
                pending = "--split";
                return true;
              })
      .Custom("--sim",
              [&](const std::string& v, std::string&) {
                a.sims.push_back({v, omni, persp, every, phase});
                pending.clear();
                last_was_boxes = false;
                return true;
              })
      .Custom("--boxes",
              [&](const std::string& v, std::string&) {
                a.boxes.push_back({v, "", split, pending == "--split"});
                pending.clear();
                last_was_boxes = true;
                return true;
              })
      .Custom("--images",
              [&](const std::string& v, std::string& error) {
                if (a.boxes.empty()) {
                  error = "--images: applies to the --boxes before it; none given";
                  return false;
                }
                a.boxes.back().images = v;
                return true;
              })
      .Number("--min-roundness", 0, 1, a.setup.finder.min_roundness)
      .Custom("--center", [&](const std::string& v, std::string& error) {
        return ArgNumberPair("--center", v, ',', 0, 4096, cu, cv, error);
      });
  AddTrainOptions(p, a);
  if (const int rc = p.Parse(argc, argv); rc >= 0) return rc;
  if (!pending.empty()) {
    // Modifiers apply to the sources that follow them; a trailing one would be silently ignored.
    return p.UsageError(pending + " applies to the --sim/--boxes after it; none follows");
  }
  a.setup.omni = ReferenceOmniScanConfig(static_cast<float>(cu), static_cast<float>(cv));
  a.setup.persp = ReferencePerspScanConfig();
  return -1;
}

bool SelectBoxes(const BoxSource& b, std::vector<lut::BoxImage>& out) {
  std::vector<lut::BoxImage> all;
  std::string err;
  if (!lut::LoadBoxFile(b.file, b.images, all, err)) {
    std::fprintf(stderr, "ballvision lut: %s\n", err.c_str());
    return false;
  }
  std::sort(all.begin(), all.end(), [](const auto& x, const auto& y) { return x.path < y.path; });
  for (size_t i = 0; i < all.size(); ++i) {
    if (b.split == "all" || (b.split == "even" && i % 2 == 0) || (b.split == "odd" && i % 2 == 1)) {
      out.push_back(all[i]);
    }
  }
  return true;
}

int Train(const Args& a) {
  if (a.out.empty()) {
    std::fprintf(stderr, "ballvision lut train: missing --out\n\n%s", kTrainUsage);
    return 2;
  }
  if (a.sims.empty() && a.boxes.empty() && a.teach.empty()) {
    std::fprintf(stderr,
                 "ballvision lut train: no training source (--sim, --boxes or --teach); "
                 "%s not written\n",
                 a.out.c_str());
    return 2;
  }
  std::string out_err;
  if (!CheckOutputPath(a.out, out_err)) {  // refuse before hours of training, not after
    std::fprintf(stderr, "ballvision lut train: %s\n", out_err.c_str());
    return 1;
  }
  InstallInterruptHandlers();
  lut::Trainer t(a.train);
  std::string err;
  for (const auto& s : a.sims) {
    for (int c = 0; c < 2; ++c) {
      if (!(c == 0 ? s.omni : s.persp)) continue;
      const int n =
          lut::AddSimSequence(t, s.dir, static_cast<lut::Camera>(c), s.every, s.phase, err);
      if (n < 0) {
        std::fprintf(stderr, "ballvision lut: %s\n", err.c_str());
        return 1;
      }
      std::printf("sim %s %s: %d frames\n", s.dir.c_str(), c == 0 ? "omni" : "persp", n);
    }
  }
  for (const auto& b : a.boxes) {
    std::vector<lut::BoxImage> imgs;
    if (!SelectBoxes(b, imgs)) return 1;
    for (const auto& bi : imgs) {
      lut::Image img;
      if (!lut::LoadImage(bi.path, img, err)) {
        std::fprintf(stderr, "ballvision lut: %s\n", err.c_str());
        return 1;
      }
      t.AddBoxes(img, bi.balls);
    }
    std::printf("boxes %s (%s): %zu images\n", b.file.c_str(), b.split.c_str(), imgs.size());
  }
  for (const auto& tc : a.teach) {
    lut::Image img;
    if (!lut::LoadImage(tc.image, img, err)) {
      std::fprintf(stderr, "ballvision lut: %s\n", err.c_str());
      return 1;
    }
    const int n = t.Teach(img, tc.u, tc.v, tc.cls, tc.tol);
    std::printf("teach %s (%d,%d) %s: %d pixels\n", tc.image.c_str(), tc.u, tc.v,
                ColorClassName(tc.cls), n);
  }
  if (InterruptSignal()) {
    ReportInterrupt("ballvision lut train");
    std::fprintf(stderr, "ballvision lut train: a partly trained table is not written\n");
    return InterruptExitCode();
  }
  static ColorLut lut;
  lut = t.Build();
  int ball = 0;
  for (uint32_t i = 0; i < ColorLut::kEntries; ++i) ball += lut.at(i) == ColorClass::kBall;
  if (ball == 0) {
    std::fprintf(stderr,
                 "ballvision lut train: the trained table has no ball cell (%.0f ball "
                 "samples); %s not written\n",
                 t.ball_samples(), a.out.c_str());
    return 1;
  }
  std::vector<uint8_t> blob(kColorLutBlobBytes);
  const Result<size_t> n = SerializeLut(lut, blob);
  if (!n.ok()) {
    std::fprintf(stderr, "ballvision lut: %s\n", n.status().message());
    return 1;
  }
  blob.resize(*n);
  if (!WriteFileAtomic(a.out, blob, err)) {
    std::fprintf(stderr, "ballvision lut: %s\n", err.c_str());
    return 1;
  }
  std::printf("wrote %s: %zu bytes, id 0x%08x, %d ball cells, %.0f ball / %.0f other samples\n",
              a.out.c_str(), *n, lut.Id(), ball, t.ball_samples(), t.other_samples());
  return 0;
}

int Eval(const Args& a) {
  static ColorLut lut;
  if (a.lut.empty()) {
    std::fprintf(stderr, "ballvision lut eval: missing --lut\n\n%s", kEvalUsage);
    return 2;
  }
  if (a.lut == "builtin") {
    FillBuiltInLut(lut);
  } else if (!LoadLut(a.lut, lut)) {
    return 1;
  }
  if (a.sims.empty() && a.boxes.empty()) {
    std::fprintf(stderr, "ballvision lut eval: nothing to evaluate (--sim or --boxes)\n");
    return 2;
  }
  InstallInterruptHandlers();
  std::string err;
  for (const auto& s : a.sims) {
    for (int c = 0; c < 2; ++c) {
      if (!(c == 0 ? s.omni : s.persp)) continue;
      lut::EvalCounts e;
      if (!lut::EvalSim(s.dir, static_cast<lut::Camera>(c), lut, a.setup, s.every, s.phase, e,
                        err)) {
        std::fprintf(stderr, "ballvision lut: %s\n", err.c_str());
        return 1;
      }
      std::vector<float> sorted = e.errors_px;
      std::sort(sorted.begin(), sorted.end());
      const float median = sorted.empty() ? 0.0f : sorted[sorted.size() / 2];
      const float p90 = sorted.empty() ? 0.0f : sorted[sorted.size() * 9 / 10];
      std::printf(
          "%s %-5s frames %3d  ball>=4px %3d  recall %5.1f%% (%d)  within1px %5.1f%% of ball "
          "frames (%d)  err median %.2f p90 %.2f px  false %d  missed %d  pixels read %.2f%%  "
          "overflows %u\n",
          s.dir.c_str(), c == 0 ? "omni" : "persp", e.frames, e.ball_frames,
          e.ball_frames ? 100.0 * e.found_on_ball / e.ball_frames : 0.0, e.found_on_ball,
          e.ball_frames ? 100.0 * e.within_1px / e.ball_frames : 0.0, e.within_1px, median, p90,
          e.false_det, e.missed,
          e.frames ? 100.0 * e.pixels_read_sum / e.frames / (kFrameWidth * kFrameHeight) : 0.0,
          e.overflows);
    }
  }
  for (const auto& b : a.boxes) {
    std::vector<lut::BoxImage> imgs;
    if (!SelectBoxes(b, imgs)) return 1;
    lut::BoxEvalCounts e;
    if (!lut::EvalBoxes(imgs, lut, a.setup, e, err, a.verbose)) {
      std::fprintf(stderr, "ballvision lut: %s\n", err.c_str());
      return 1;
    }
    std::printf("%s (%s): images %d (with ball %d, balls %d)  recall %d/%d  false %d  missed %d\n",
                b.file.c_str(), b.split.c_str(), e.images, e.images_with_ball, e.balls, e.hit,
                e.images_with_ball, e.false_det, e.missed);
  }
  return 0;
}

int Show(const std::string& path) {
  static ColorLut lut;
  if (!LoadLut(path, lut)) return 1;
  int counts[kColorClassCount] = {};
  for (uint32_t i = 0; i < ColorLut::kEntries; ++i) ++counts[static_cast<int>(lut.at(i))];
  std::printf("%s: Y%d/U%d/V%d, %zu cells, id 0x%08x\n", path.c_str(), ColorLut::kYBits,
              ColorLut::kUBits, ColorLut::kVBits, ColorLut::kEntries, lut.Id());
  for (int c = 0; c < kColorClassCount; ++c) {
    std::printf("  %-9s %6d cells\n", ColorClassName(static_cast<ColorClass>(c)), counts[c]);
  }
  return 0;
}

struct TeachArgs {
  std::string seq, out, boxes, images, split = "all";
  double cu = 314.2, cv = 244.1;
  lut::TeachOptions opt;
};

// --click INDEX:CAMERA:U,V into `opt`; false with the usage error.
bool ParseClick(const std::string& click, lut::TeachOptions& opt, std::string& error) {
  const size_t a = click.find(':'), b = click.find(':', a == std::string::npos ? a : a + 1);
  int64_t index = 0;
  double u = 0, v = 0;
  if (a == std::string::npos || b == std::string::npos ||
      !ArgIntAs("--click", click.substr(0, a), 0, INT64_MAX, index, error) ||
      !ArgNumberPair("--click", click.substr(b + 1), ',', 0, 8191, u, v, error)) {
    if (error.empty()) error = "--click: got '" + click + "', expected INDEX:CAMERA:U,V";
    return false;
  }
  const std::string cam = click.substr(a + 1, b - a - 1);
  if (cam != "omni" && cam != "persp") {
    error = "--click: camera '" + cam + "', expected omni or persp";
    return false;
  }
  opt.click = true;
  opt.click_index = index;
  opt.click_camera = cam == "omni" ? lut::Camera::kOmni : lut::Camera::kPersp;
  opt.click_u = static_cast<float>(u);
  opt.click_v = static_cast<float>(v);
  if (!opt.cameras[static_cast<int>(opt.click_camera)]) {
    error = "--click names the " + cam + " camera, which --camera leaves out";
    return false;
  }
  return true;
}

// Returns -1 to go on, else the exit code.
int ParseTeachArgs(int argc, char** argv, TeachArgs& t) {
  std::string click, camera = "both";
  ArgParser p("ballvision lut teach", kTeachUsage);
  p.Positional("SEQ", t.seq, /*required=*/false)
      .Text("--boxes", t.boxes)
      .Text("--images", t.images)
      .Text("--split", t.split)
      .Text("--out", t.out)
      .Required("--out")
      .Text("--click", click)
      .Text("--camera", camera)
      .Int("--every", 1, 1000000, t.opt.every)
      .Custom("--center", [&t](const std::string& v, std::string& error) {
        return ArgNumberPair("--center", v, ',', 0, 4096, t.cu, t.cv, error);
      });
  if (const int rc = p.Parse(argc, argv); rc >= 0) return rc;
  if (t.seq.empty() == t.boxes.empty()) {
    return p.UsageError("give a sequence SEQ or annotated stills --boxes FILE --images DIR");
  }
  if (!t.boxes.empty() && t.images.empty()) return p.UsageError("--boxes needs --images DIR");
  if (t.split != "all" && t.split != "even" && t.split != "odd") {
    return p.UsageError("--split: got '" + t.split + "', expected all, even or odd");
  }
  if (camera != "omni" && camera != "persp" && camera != "both") {
    return p.UsageError("--camera: got '" + camera + "', expected omni, persp or both");
  }
  t.opt.cameras[0] = camera != "persp";
  t.opt.cameras[1] = camera != "omni";
  std::string error;
  if (!click.empty() && !ParseClick(click, t.opt, error)) return p.UsageError(error);
  return -1;
}

bool TeachModel(const TeachArgs& t, lut::TeachReport& r, std::string& err) {
  lut::FinderSetup setup;
  setup.omni = ReferenceOmniScanConfig(static_cast<float>(t.cu), static_cast<float>(t.cv));
  setup.persp = ReferencePerspScanConfig();
  return lut::TeachSequence(t.seq, setup, t.opt, r, err);
}

// After a teach: -1 to go on and write, else the exit code (its failure or an interrupt said).
int TeachOutcome(bool taught, const TeachArgs& t, const std::string& err) {
  if (!taught) {
    std::fprintf(stderr, "ballvision lut teach: %s; %s not written\n", err.c_str(), t.out.c_str());
    return 1;
  }
  if (InterruptSignal()) {
    ReportInterrupt("ballvision lut teach");
    std::fprintf(stderr, "ballvision lut teach: a partly taught table is not written\n");
    return 130;
  }
  return -1;
}

// `lut teach --boxes`: the table and the floor-ball profile into one teach file.
int TeachBoxesCmd(const TeachArgs& t) {
  std::vector<AnnotatedImage> all;
  std::string err;
  if (!LoadAnnotations(t.boxes, t.images, all, err)) {
    std::fprintf(stderr, "ballvision lut teach: %s; %s not written\n", err.c_str(), t.out.c_str());
    return 1;
  }
  std::sort(all.begin(), all.end(),
            [](const AnnotatedImage& x, const AnnotatedImage& y) { return x.name < y.name; });
  const std::vector<AnnotatedImage> images = SplitImages(all, t.split);
  BoxTeach taught;
  if (const int rc =
          TeachOutcome(TeachFromBoxes(t.boxes, images, BoxTeachOptions{}, taught, err), t, err);
      rc >= 0) {
    return rc;
  }
  std::vector<uint8_t> blob(kColorLutBlobBytes);
  const Result<size_t> n = SerializeLut(*taught.table, blob, &taught.profile);
  if (!n.ok() ||
      !WriteFileAtomic(
          t.out, std::string_view(reinterpret_cast<const char*>(blob.data()), n.ok() ? *n : 0),
          err)) {
    std::fprintf(stderr, "ballvision lut teach: %s\n", n.ok() ? err.c_str() : n.status().message());
    return 1;
  }
  std::printf(
      "taught from %zu images (%s), %d with a ball, %dx%d: %d ball cells from %.0f ball / %.0f "
      "other samples, blurred over +-%d cells\n"
      "check on %zu background samples: %.3f %% of field and line pixels taken, %.3f %% of all\n",
      images.size(), t.split.c_str(), taught.ball_images, taught.width, taught.height,
      taught.ball_cells, taught.ball_samples, taught.other_samples, taught.smooth,
      taught.background, 100.0 * taught.field_taken, 100.0 * taught.background_taken);
  if (taught.profile.valid) {
    std::printf(
        "floor-ball profile from %u boxes: horizon at row %.1f, radius %.4f px per row "
        "below it (%+.6f per row^2), scatter %.0f %%\n",
        taught.profile.samples, taught.profile.horizon_v_px, taught.profile.slope,
        taught.profile.curve, 100.0 * taught.profile.spread);
  } else {
    std::printf("no floor-ball profile: %s\n", taught.profile_note.c_str());
  }
  std::printf("wrote %s: id 0x%08x\n", t.out.c_str(), taught.table->Id());
  return 0;
}

bool WriteTaughtLut(const BallColorModel& model, const std::string& out, ColorLut& lut,
                    std::string& err) {
  std::vector<uint8_t> blob(kColorLutBlobBytes);
  if (const Status st = BuildLut(model, lut); !st.ok()) {
    err = st.message();
    return false;
  }
  const Result<size_t> n = SerializeLut(lut, blob);
  if (!n.ok()) {
    err = n.status().message();
    return false;
  }
  return WriteFileAtomic(out, std::string_view(reinterpret_cast<const char*>(blob.data()), *n),
                         err);
}

void PrintTeachReport(const lut::TeachReport& r, const std::string& out, uint32_t lut_id) {
  const BallColorModel& m = r.model;
  std::printf(
      "taught from %d omni + %d persp frames, %zu ball pixels; centres moved up to %lld px\n"
      "model: hue %.1f..%.1f deg, relative chroma >= %.2f (>= %.2f from Y %d on) <= %.2f, "
      "Y >= %d\n"
      "check on %zu background samples: %.3f %% of field and line pixels taken, %.3f %% of "
      "all\n"
      "wrote %s: id 0x%08x\n",
      r.frames[0], r.frames[1], r.ball_pixels, static_cast<long long>(r.first_moves_px),
      m.hue_min_deg, m.hue_max_deg, m.chroma_min, m.chroma_min_bright, m.bright_y_end, m.chroma_max,
      m.y_min, r.background, 100.0 * r.field_taken, 100.0 * r.background_taken, out.c_str(),
      lut_id);
}

int TeachCmd(int argc, char** argv) {
  TeachArgs t;
  if (const int rc = ParseTeachArgs(argc, argv, t); rc >= 0) return rc;
  std::string err;
  if (!CheckOutputPath(t.out, err)) {
    std::fprintf(stderr, "ballvision lut teach: %s\n", err.c_str());
    return 1;
  }
  InstallInterruptHandlers();
  if (!t.boxes.empty()) return TeachBoxesCmd(t);
  lut::TeachReport r;
  if (const int rc = TeachOutcome(TeachModel(t, r, err), t, err); rc >= 0) return rc;
  static ColorLut lut;
  if (!WriteTaughtLut(r.model, t.out, lut, err)) {
    std::fprintf(stderr, "ballvision lut teach: %s\n", err.c_str());
    return 1;
  }
  PrintTeachReport(r, t.out, lut.Id());
  if (!t.opt.click && r.first_moves_px < 10) {
    std::fprintf(stderr,
                 "ballvision lut teach: warning: the blob learnt from hardly moved (%lld px); if "
                 "it is not the ball, teach again with --click\n",
                 static_cast<long long>(r.first_moves_px));
  }
  return 0;
}

}  // namespace

int CmdLut(int argc, char** argv) {
  const auto show = [](int ac, char** av) {
    std::string path;
    ArgParser p("ballvision lut show", kShowUsage);
    p.Positional("LUT", path);
    if (const int rc = p.Parse(ac, av); rc >= 0) return rc;
    return Show(path);
  };
  const auto train_or_eval = [](int ac, char** av) {
    const std::string sub = av[0];
    Args a;
    if (const int rc = ParseArgs(ac, av, "ballvision lut " + sub, a); rc >= 0) return rc;
    return sub == "train" ? Train(a) : Eval(a);
  };
  return RunSubCommand(
      "ballvision lut", kLutUsage, argc, argv,
      {{"train", train_or_eval}, {"eval", train_or_eval}, {"teach", TeachCmd}, {"show", show}});
}

}  // namespace bv::cli
