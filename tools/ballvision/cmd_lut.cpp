// ballvision lut: train, evaluate and inspect colour lookup tables (core/color_lut).
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "tools/ballvision/cli_args.h"
#include "tools/ballvision/commands.h"
#include "tools/ballvision/lut_train.h"
#include "tools/ballvision/safe_write.h"
#include "tools/ballvision/signals.h"

namespace bv::cli {
namespace {

int LutUsage() {
  std::fprintf(
      stderr,
      "usage: ballvision lut train --out LUT.bin [sources] [--ratio R] [--min-weight W]\n"
      "                           [--gauss D2 [--gauss-veto F]]  (chroma-Gaussian ball model)\n"
      "                           [--shade MIN,MAX]  (brightness factors added per ball sample, "
      "0.55,1.30)\n"
      "       ballvision lut eval --lut LUT.bin [sources] [--center U,V] [--no-track] [--verbose]\n"
      "                           [--regions]  (every traced region with its shape measures)\n"
      "                           [--annotate DIR]  (debug pictures of every evaluated frame)\n"
      "       ballvision lut show LUT.bin\n"
      "sources (repeatable):\n"
      "  --sim DIR            rendered sequence with truth.csv (ball silhouettes from the truth)\n"
      "  --camera omni|persp|both   cameras of the following --sim (default both)\n"
      "  --every N --phase P  use frames with index %% N == P (train/test split; default all)\n"
      "  --boxes FILE --images DIR [--split all|even|odd]  annotated boxes (msl format:\n"
      "                       'image class_id class x0 y0 x1 y1'); split by image order\n"
      "  --teach IMG:U,V[:CLASS[:TOL]]  grow a region from one clicked pixel (CLASS ball|field|\n"
      "                       line|obstacle, default ball; TOL shade-normalised chroma, 0.12)\n");
  return 2;
}

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

bool ParseArgs(int argc, char** argv, Args& a) {
  bool omni = true, persp = true;
  int every = 1, phase = 0;
  std::string split = "all";
  float cu = 314.2f, cv = 244.1f;  // reference rig mirror circle (render/README.md)
  std::string pending;             // a source modifier no source has used yet
  std::string e;
  auto Num = [&e](bool ok) {  // a refused number is a usage error with its own message
    if (!ok) std::fprintf(stderr, "ballvision lut: %s\n", e.c_str());
    return ok;
  };
  for (int i = 2; i < argc; ++i) {
    const std::string k = argv[i];
    const bool has = i + 1 < argc;
    const std::string val = has ? argv[i + 1] : "";
    if (k == "--regions") {
      a.setup.dump_regions = true;
      continue;
    }
    if (k == "--verbose") {
      a.verbose = a.setup.verbose = true;
      continue;
    }
    if (k == "--no-track") {
      a.setup.track = false;
      continue;
    }
    if (!has) {
      std::fprintf(stderr, "ballvision lut: %s needs a value\n", k.c_str());
      return false;
    }
    ++i;
    if (k == "--out")
      a.out = val;
    else if (k == "--lut")
      a.lut = val;
    else if (k == "--annotate")
      a.setup.annotate_dir = val;
    else if (k == "--camera") {
      omni = val == "omni" || val == "both";
      persp = val == "persp" || val == "both";
      if (!omni && !persp) return false;
      pending = k;
    } else if (k == "--every") {
      if (!Num(ArgIntAs(k, val, 1, 1000000, every, e))) return false;
      pending = k;
    } else if (k == "--phase") {
      if (!Num(ArgIntAs(k, val, 0, 999999, phase, e))) return false;
      pending = k;
    } else if (k == "--sim") {
      a.sims.push_back({val, omni, persp, every, phase});
      pending.clear();
    } else if (k == "--split") {
      if (val != "all" && val != "even" && val != "odd") return false;
      split = val;
      pending = k;
    } else if (k == "--boxes") {
      a.boxes.push_back({val, "", split});
      pending.clear();
    } else if (k == "--images") {
      if (a.boxes.empty()) return false;
      a.boxes.back().images = val;
      a.boxes.back().split = split;
    } else if (k == "--ratio") {
      if (!Num(ArgNumberAs(k, val, 0, 1e6, a.train.ratio, e))) return false;
    } else if (k == "--shade") {
      double lo = 0, hi = 0;
      if (!Num(ArgNumberPair(k, val, ',', 0.01, 100, lo, hi, e))) return false;
      a.train.shade_min = static_cast<float>(lo);
      a.train.shade_max = static_cast<float>(hi);
    } else if (k == "--gauss") {
      if (!Num(ArgNumberAs(k, val, 0, 1e6, a.train.gauss_d2, e))) return false;
    } else if (k == "--gauss-veto") {
      if (!Num(ArgNumberAs(k, val, 0, 1e6, a.train.gauss_veto, e))) return false;
    } else if (k == "--min-weight") {
      if (!Num(ArgNumberAs(k, val, 0, 1e9, a.train.min_ball_weight, e))) return false;
    } else if (k == "--min-roundness") {
      if (!Num(ArgNumberAs(k, val, 0, 1, a.setup.finder.min_roundness, e))) return false;
    } else if (k == "--center") {
      double u = 0, v = 0;
      if (!Num(ArgNumberPair(k, val, ',', 0, 4096, u, v, e))) return false;
      cu = static_cast<float>(u);
      cv = static_cast<float>(v);
    } else if (k == "--teach") {
      Teach t;
      // IMG:U,V[:CLASS[:TOL]] — parse from the right.
      std::vector<std::string> parts;
      size_t start = 0;
      for (size_t p = val.find(':'); p != std::string::npos; p = val.find(':', start)) {
        parts.push_back(val.substr(start, p - start));
        start = p + 1;
      }
      parts.push_back(val.substr(start));
      int64_t tu = 0, tv = 0;
      if (parts.size() < 2) return false;
      if (!Num(ArgIntPair(k, parts[1], ',', 0, 8191, tu, tv, e))) return false;
      t.u = static_cast<int>(tu);
      t.v = static_cast<int>(tv);
      t.image = parts[0];
      if (parts.size() > 2 && !ParseClass(parts[2], t.cls)) return false;
      if (parts.size() > 3 && !Num(ArgNumberAs(k, parts[3], 0, 10, t.tol, e))) return false;
      a.teach.push_back(t);
    } else {
      std::fprintf(stderr, "ballvision lut: unknown option %s\n", k.c_str());
      return false;
    }
  }
  if (!pending.empty()) {
    // Modifiers apply to the sources that follow them; a trailing one would be silently ignored.
    std::fprintf(stderr, "ballvision lut: %s applies to the --sim/--boxes after it; none follows\n",
                 pending.c_str());
    return false;
  }
  a.setup.omni = ReferenceOmniScanConfig(cu, cv);
  a.setup.persp = ReferencePerspScanConfig();
  return true;
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
  if (a.out.empty()) return LutUsage();
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
  if (a.lut.empty()) return LutUsage();
  if (!LoadLut(a.lut, lut)) return 1;
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
      std::printf(
          "%s %-5s frames %3d  ball>=4px %3d  recall %5.1f%% (%d)  within1px %5.1f%% of ball "
          "frames (%d)  median err %.2f px  false %d  missed %d  pixels read %.2f%%  overflows "
          "%u\n",
          s.dir.c_str(), c == 0 ? "omni" : "persp", e.frames, e.ball_frames,
          e.ball_frames ? 100.0 * e.found_on_ball / e.ball_frames : 0.0, e.found_on_ball,
          e.ball_frames ? 100.0 * e.within_1px / e.ball_frames : 0.0, e.within_1px, median,
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

}  // namespace

int CmdLut(int argc, char** argv) {
  if (argc < 2 || !std::strcmp(argv[1], "--help")) return LutUsage();
  const std::string sub = argv[1];
  if (sub == "show") return argc == 3 ? Show(argv[2]) : LutUsage();
  Args a;
  if (!ParseArgs(argc, argv, a)) return LutUsage();
  if (sub == "train") return Train(a);
  if (sub == "eval") return Eval(a);
  return LutUsage();
}

}  // namespace bv::cli
