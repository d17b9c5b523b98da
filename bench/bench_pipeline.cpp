// The whole pipeline per frame pair, stage by stage (PipelineStage), on
// ../shared/data/sim/bounce and clutter, set up as `ballvision run` sets it up (reference
// calibration, the committed sim LUT, the built-in classifier); side by side in the same run with
// the OpenCV full-frame finder on both images of each pair. Thread CPU time: the machine may be
// shared. Also the memory floor: reading one byte of every cache line the scan tables' samples
// lie in. Prints figures; asserts nothing.
//   bench_pipeline [--reps N] [--warm] [SEQ_DIR...]
#include <time.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "bench/opencv_reference.h"
#include "core/pipeline.h"
#include "hal/host/sequence.h"
#include "tools/ballvision/calib_io.h"
#include "tools/ballvision/run_common.h"
#include "tools/ballvision/stats.h"

namespace {

using namespace bv;
using cli::Median;

uint64_t ThreadNs() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<uint64_t>(ts.tv_sec) * 1000000000u + static_cast<uint64_t>(ts.tv_nsec);
}
uint32_t StageNs() { return static_cast<uint32_t>(ThreadNs()); }

struct Pair {
  std::vector<uint8_t> omni, persp;
  int w = 0, h = 0, pw = 0, ph = 0;
  uint64_t t_us = 0;
};

double Mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0 : s / v.size();
}

// Reads a frame through, into the caches (--warm: as `ballvision run` has it after loading its
// file; without, each pair is cold, as a DMA'd frame is on the device).
void Touch(const std::vector<uint8_t>& frame) {
  uint32_t sum = 0;
  for (size_t k = 0; k < frame.size(); k += 64) sum += frame[k];
  asm volatile("" : : "r"(sum));
}

bool Load(const std::string& dir, std::vector<Pair>& pairs, std::string& err) {
  host::Sequence seq;
  if (!host::LoadSequence(dir, seq, err)) return false;
  for (const host::SequenceEntry& e : seq.entries) {
    Pair p;
    p.t_us = e.t_us;
    if (!host::LoadYuyv(e.omni_path, p.omni, p.w, p.h, err) ||
        !host::LoadYuyv(e.persp_path, p.persp, p.pw, p.ph, err)) {
      return false;
    }
    pairs.push_back(std::move(p));
  }
  return !pairs.empty();
}

int RunScene(const std::string& dir, int reps, bool warm) {
  std::string err;
  std::vector<Pair> pairs;
  RigCalibration cal;
  auto lut = std::make_unique<ColorLut>();
  BallClassifier classifier;
  std::string used;
  const std::string calib = BV_TEST_DATA_DIR "/reference_rig_calib.json";
  if (!Load(dir, pairs, err) || !cli::LoadCalibrationFile(calib, cal, err) ||
      !cli::LoadLutOrDefault(BV_TEST_DATA_DIR "/luts/sim_orange.lut", calib, *lut, used, err) ||
      !cli::LoadClassifierArg("builtin", classifier, err)) {
    std::fprintf(stderr, "bench_pipeline: %s: %s\n", dir.c_str(), err.c_str());
    return 1;
  }
  PipelineConfig config;
  config.classifier = &classifier;
  // The memory floor of the scan tables: the distinct cache lines their samples lie in, per
  // frame (the feature rays and the camera watch read samples of the same tables).
  std::vector<uint32_t> omni_lines, persp_lines;
  {
    auto probe = std::make_unique<OwnedPipeline>();
    if (probe->Init(cal, *lut, config).ok() && !pairs.empty()) {
      const auto lines = [](const ScanlineTableBase& t, int stride, std::vector<uint32_t>& out) {
        ForEachScanPixel(t, [&](int u, int v) {
          out.push_back(static_cast<uint32_t>((v * stride + 2 * u) / 64));
        });
        std::sort(out.begin(), out.end());
        out.erase(std::unique(out.begin(), out.end()), out.end());
      };
      lines(probe->omni_scan(), 2 * pairs[0].w, omni_lines);
      lines(probe->persp_scan(), 2 * pairs[0].pw, persp_lines);
    }
  }
  std::vector<double> floor_pair(pairs.size(), 1e30);
  // Per frame: the whole Process() and its stages (best of the repetitions: the least disturbed),
  // and the OpenCV finder on both images.
  const size_t n = pairs.size();
  std::vector<double> total(n, 1e30), cv_pair(n, 1e30);
  std::vector<std::vector<double>> stage(kPipelineStageCount, std::vector<double>(n, 1e30));
  cv::Mat bgr, hsv, mask;
  int found = 0;
  // Each repetition runs the pairs twice: with the stage clock (the stages), and without it (the
  // whole Process(), as `ballvision run` and the device run it: reading the thread clock costs a
  // system call here, ~1 us a stage).
  for (int r = 0; r < 2 * reps; ++r) {
    const bool staged = r % 2 == 0;
    auto pipeline = std::make_unique<OwnedPipeline>();
    if (const Status st = pipeline->Init(cal, *lut, config); !st.ok()) {
      std::fprintf(stderr, "bench_pipeline: %s\n", st.message());
      return 1;
    }
    if (staged) pipeline->SetStageClock(StageNs);
    for (size_t i = 0; i < n; ++i) {
      FrameInput in;
      in.t_us = pairs[i].t_us;
      in.omni = MakeYuyvImage(pairs[i].omni.data(), pairs[i].w, pairs[i].h);
      in.persp = MakeYuyvImage(pairs[i].persp.data(), pairs[i].pw, pairs[i].ph);
      BallState s;
      if (warm) {
        Touch(pairs[i].omni);
        Touch(pairs[i].persp);
      }
      const uint64_t t0 = ThreadNs();
      (void)pipeline->Process(in, s);
      const uint64_t t1 = ThreadNs();
      if (!staged) total[i] = std::min(total[i], (t1 - t0) * 1e-3);
      for (int k = 0; k < kPipelineStageCount && staged; ++k) {
        stage[k][i] = std::min(stage[k][i], pipeline->last_stats().stage_ticks[k] * 1e-3);
      }
      if (r == 1) found += s.found;
    }
    if (staged) continue;
    for (size_t i = 0; i < n; ++i) {  // one byte of each line, in address order
      if (warm) {
        Touch(pairs[i].omni);
        Touch(pairs[i].persp);
      }
      uint32_t sum = 0;
      const uint64_t t0 = ThreadNs();
      for (const uint32_t l : omni_lines) sum += pairs[i].omni[l * 64u];
      for (const uint32_t l : persp_lines) sum += pairs[i].persp[l * 64u];
      asm volatile("" : : "r"(sum));
      floor_pair[i] = std::min(floor_pair[i], (ThreadNs() - t0) * 1e-3);
    }
    for (size_t i = 0; i < n; ++i) {
      const uint64_t t0 = ThreadNs();
      bench::OpenCvFind(pairs[i].omni, bgr, hsv, mask, pairs[i].w, pairs[i].h);
      bench::OpenCvFind(pairs[i].persp, bgr, hsv, mask, pairs[i].pw, pairs[i].ph);
      cv_pair[i] = std::min(cv_pair[i], (ThreadNs() - t0) * 1e-3);
    }
  }
  const std::string name = dir.substr(dir.find_last_of('/') + 1);
  std::printf("%s: %zu frame pairs, best of %d runs each, frames %s, ball found in %d\n",
              name.c_str(), n, reps, warm ? "warm" : "cold", found);
  std::printf("  %-16s %9s %9s %9s\n", "stage", "median", "mean", "max");
  for (int k = 0; k < kPipelineStageCount; ++k) {
    std::printf("  %-16s %7.1f us %7.1f us %7.1f us\n",
                PipelineStageName(static_cast<PipelineStage>(k)), Median(stage[k]), Mean(stage[k]),
                *std::max_element(stage[k].begin(), stage[k].end()));
  }
  std::printf("  %-16s %7.1f us %7.1f us %7.1f us   (without the stage clock)\n", "whole Process()",
              Median(total), Mean(total), *std::max_element(total.begin(), total.end()));
  std::printf("  %-16s %7.1f us %7.1f us\n", "OpenCV, pair", Median(cv_pair), Mean(cv_pair));
  std::printf("  ratio (medians): %.1fx the OpenCV full-frame finder\n",
              Median(cv_pair) / Median(total));
  const size_t frame_lines = (pairs[0].omni.size() + pairs[0].persp.size()) / 64;
  std::printf(
      "  scan tables touch %zu + %zu of the pair's %zu cache lines; one byte of each, in address "
      "order: %.1f us median (%.1fx OpenCV: the most this scan density allows)\n",
      omni_lines.size(), persp_lines.size(), frame_lines, Median(floor_pair),
      Median(cv_pair) / Median(floor_pair));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  cv::setNumThreads(1);  // one core each, like the device
  int reps = 5;
  bool warm = false;
  std::vector<std::string> dirs;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--reps") == 0 && i + 1 < argc) {
      reps = std::max(1, std::atoi(argv[++i]));
    } else if (std::strcmp(argv[i], "--warm") == 0) {
      warm = true;
    } else {
      dirs.emplace_back(argv[i]);
    }
  }
  if (dirs.empty()) {
    for (const char* s : {"bounce", "clutter"})
      dirs.push_back(std::string(BV_SHARED_DATA_DIR) + "/sim/" + s);
  }
  int rc = 0;
  for (const std::string& d : dirs) rc |= RunScene(d, reps, warm);
  return rc;
}
