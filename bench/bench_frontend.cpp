// Image front end on rendered 640x480 frames (../shared/data/sim/clutter + bounce): per stage,
// pixels read, and side by side with an OpenCV full-frame pipeline doing the same job
// (YUYV->BGR->HSV, inRange, findContours, moments, pick the roundest large contour).
// Prints figures; asserts nothing.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "bench/opencv_reference.h"
#include "core/color_lut/color_lut.h"
#include "core/detect/detect.h"
#include "core/pipeline.h"
#include "core/scanline/scanline.h"
#include "hal/host/sequence.h"
#include "tools/ballvision/calib_io.h"

namespace {

// As the pipeline configures it: the LUT's ball chroma box lets the scanlines skip lookups.
bv::BallFinderConfig FinderConfig(const bv::ColorLut& lut) {
  bv::BallFinderConfig c;
  c.ball_box = lut.Bounds(bv::ColorClass::kBall);
  return c;
}

using namespace bv;
using bench::CvResult;
using bench::OpenCvFind;

struct Data {
  std::vector<std::vector<uint8_t>> omni, persp;
  std::unique_ptr<ColorLut> lut = std::make_unique<ColorLut>();
  std::unique_ptr<ScanlineTable<kOmniScanPixels>> omni_scan =
      std::make_unique<ScanlineTable<kOmniScanPixels>>();
  std::unique_ptr<ScanlineTable<kPerspScanPixels>> persp_scan =
      std::make_unique<ScanlineTable<kPerspScanPixels>>();
  bool ok = false;
};

Data& D() {
  static Data d = [] {
    Data x;
    const std::string src = __FILE__;
    const std::string lut_path =
        src.substr(0, src.rfind('/')) + "/../host_tests/data/luts/sim_orange.lut";
    std::ifstream in(lut_path, std::ios::binary);
    std::vector<uint8_t> blob((std::istreambuf_iterator<char>(in)), {});
    if (!ParseLut(blob, *x.lut).ok()) {
      std::fprintf(stderr, "bench_frontend: cannot load %s\n", lut_path.c_str());
      return x;
    }
    for (const char* seq : {"clutter", "bounce"}) {
      host::Sequence s;
      std::string err;
      if (!host::LoadSequence(std::string(BV_SHARED_DATA_DIR) + "/sim/" + seq, s, err)) {
        std::fprintf(stderr, "bench_frontend: %s\n", err.c_str());
        return x;
      }
      for (size_t i = 0; i < s.entries.size(); i += 3) {
        std::vector<uint8_t> buf;
        int w, h;
        if (host::LoadYuyv(s.entries[i].omni_path, buf, w, h, err)) x.omni.push_back(buf);
        if (host::LoadYuyv(s.entries[i].persp_path, buf, w, h, err)) x.persp.push_back(buf);
      }
    }
    // The omni pattern the pipeline uses on the reference rig: ball profile + field-feature rays.
    RigCalibration cal;
    std::string cal_err;
    if (!cli::LoadCalibrationFile(BV_TEST_DATA_DIR "/reference_rig_calib.json", cal, cal_err)) {
      std::fprintf(stderr, "bench_frontend: %s\n", cal_err.c_str());
      return x;
    }
    x.ok = x.omni_scan
               ->BuildOmni(PipelineOmniScan(cal.omni, PipelineConfig{}), kFrameWidth, kFrameHeight)
               .ok() &&
           x.persp_scan->BuildPersp(ReferencePerspScanConfig(), kFrameWidth, kFrameHeight).ok() &&
           !x.omni.empty() && !x.persp.empty();
    return x;
  }();
  return d;
}

YuyvImage View(const std::vector<uint8_t>& f) {
  return MakeYuyvImage(f.data(), kFrameWidth, kFrameHeight);
}

void BM_ScanlineBuildOmni(benchmark::State& st) {
  auto t = std::make_unique<ScanlineTable<kOmniScanPixels>>();
  for (auto _ : st)
    benchmark::DoNotOptimize(t->BuildOmni(ReferenceOmniScanConfig(314.2f, 244.1f), 640, 480));
}
BENCHMARK(BM_ScanlineBuildOmni)->Unit(benchmark::kMicrosecond);

// Stage 1 alone: classify every scanline pixel through the LUT.
void BM_ScanClassify(benchmark::State& st, bool omni, bool warm) {
  Data& d = D();
  if (!d.ok) return st.SkipWithError("no data");
  const std::vector<std::vector<uint8_t>> one(1, (omni ? d.omni : d.persp)[0]);
  const auto& frames = warm ? one : omni ? d.omni : d.persp;
  const ScanlineTableBase& scan =
      omni ? static_cast<const ScanlineTableBase&>(*d.omni_scan) : *d.persp_scan;
  size_t i = 0;
  uint32_t ball = 0;
  for (auto _ : st) {
    const YuyvImage img = View(frames[i++ % frames.size()]);
    const uint8_t* row = img.data;
    scan.ForEachSample([&](int v) { row = img.data + v * img.stride_bytes; },
                       [&](int u, bool) {
                         const uint8_t* p = row + (u & ~1) * 2;
                         ball += d.lut->Classify(p[(u & 1) * 2], p[1], p[3]) == ColorClass::kBall;
                       });
    benchmark::DoNotOptimize(ball);
  }
  st.counters["pixels_read_pct"] = 100.0 * scan.pixel_count() / (kFrameWidth * kFrameHeight);
}
// Frames cycle through 21 MB (cold in cache, like a fresh DMA frame); "warm": one frame.
BENCHMARK_CAPTURE(BM_ScanClassify, omni, true, false)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_ScanClassify, omni_warm, true, true)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_ScanClassify, persp, false, false)->Unit(benchmark::kMicrosecond);

// Whole front end per camera: scanlines + attention + contours + choice.
void BM_Find(benchmark::State& st, bool omni, bool attention) {
  Data& d = D();
  if (!d.ok) return st.SkipWithError("no data");
  const auto& frames = omni ? d.omni : d.persp;
  const ScanlineTableBase& scan =
      omni ? static_cast<const ScanlineTableBase&>(*d.omni_scan) : *d.persp_scan;
  auto finder = std::make_unique<BallFinder>();
  if (!finder->Init(scan, FinderConfig(*d.lut)).ok()) return st.SkipWithError("init");
  // Predictions from a first pass (what the filter would supply).
  std::vector<BallDetection> first(frames.size());
  FrontEndStats fs;
  for (size_t k = 0; k < frames.size(); ++k)
    (void)finder->Find(View(frames[k]), *d.lut, nullptr, first[k], fs).ok();
  size_t i = 0;
  double pixels = 0, regions = 0;
  for (auto _ : st) {
    const size_t k = i++ % frames.size();
    Prediction p{first[k].u_px, first[k].v_px, std::max(4.0f, first[k].radius_px)};
    BallDetection det;
    (void)finder->Find(View(frames[k]), *d.lut, attention && first[k].found ? &p : nullptr, det, fs)
        .ok();
    pixels += fs.pixels_read;
    regions += fs.regions;
    benchmark::DoNotOptimize(det);
  }
  st.counters["pixels_read_pct"] =
      100.0 * pixels / static_cast<double>(i) / (kFrameWidth * kFrameHeight);
  st.counters["regions"] = regions / static_cast<double>(i);
}
BENCHMARK_CAPTURE(BM_Find, omni, true, false)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Find, omni_attention, true, true)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Find, persp, false, false)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Find, persp_attention, false, true)->Unit(benchmark::kMicrosecond);

void BM_OpenCvFullFrame(benchmark::State& st, bool omni) {
  Data& d = D();
  if (!d.ok) return st.SkipWithError("no data");
  const auto& frames = omni ? d.omni : d.persp;
  cv::Mat bgr, hsv, mask;
  size_t i = 0;
  for (auto _ : st)
    benchmark::DoNotOptimize(OpenCvFind(frames[i++ % frames.size()], bgr, hsv, mask));
}
BENCHMARK_CAPTURE(BM_OpenCvFullFrame, omni, true)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_OpenCvFullFrame, persp, false)->Unit(benchmark::kMicrosecond);

// LUT layouts compared on the same scan pixels: 3D Y4/U6/V6 (chosen), CMVision per-channel
// bitmasks (3 x 256 x u32, class = AND), 2D UV table (4096 B) + per-class Y range.
void BM_LutLayout(benchmark::State& st, int layout) {
  Data& d = D();
  if (!d.ok) return st.SkipWithError("no data");
  static uint32_t ymask[256], umask[256], vmask[256];
  static uint8_t uv[64 * 64], ylo[8], yhi[8];
  for (int i = 0; i < 256; ++i) ymask[i] = umask[i] = vmask[i] = (i * 2654435761u) >> 27;
  for (int i = 0; i < 4096; ++i) uv[i] = static_cast<uint8_t>(i % 5);
  for (int c = 0; c < 8; ++c) ylo[c] = static_cast<uint8_t>(10 * c), yhi[c] = 250;
  size_t i = 0;
  uint32_t acc = 0;
  for (auto _ : st) {
    const YuyvImage img = View(d.omni[i++ % d.omni.size()]);
    const uint8_t* row = img.data;
    d.omni_scan->ForEachSample([&](int v) { row = img.data + v * img.stride_bytes; },
                               [&](int u, bool) {
                                 const uint8_t* p = row + (u & ~1) * 2;
                                 const uint8_t y = p[(u & 1) * 2], cu = p[1], cv = p[3];
                                 if (layout == 0) {
                                   acc += static_cast<uint32_t>(d.lut->Classify(y, cu, cv));
                                 } else if (layout == 1) {
                                   acc += ymask[y] & umask[cu] & vmask[cv];
                                 } else {
                                   const uint8_t c = uv[(cu >> 2) << 6 | (cv >> 2)];
                                   acc += (y >= ylo[c] && y <= yhi[c]) ? c : 0;
                                 }
                               });
    benchmark::DoNotOptimize(acc);
  }
}
BENCHMARK_CAPTURE(BM_LutLayout, lut3d_y4u6v6_64KB, 0)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_LutLayout, cmvision_bitmask_3KB, 1)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_LutLayout, uv2d_plus_yrange_4KB, 2)->Unit(benchmark::kMicrosecond);

// Side by side in one run over the same frames: time per frame, speed ratio, agreement.
void SideBySide() {
  Data& d = D();
  if (!d.ok) return;
  // Thread CPU time: the machine is shared, wall time would count other processes.
  struct Clock {
    static double now() {
      timespec ts;
      clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
      return ts.tv_sec * 1e6 + ts.tv_nsec * 1e-3;
    }
  };
  for (int cam = 0; cam < 2; ++cam) {
    const auto& frames = cam == 0 ? d.omni : d.persp;
    const ScanlineTableBase& scan =
        cam == 0 ? static_cast<const ScanlineTableBase&>(*d.omni_scan) : *d.persp_scan;
    auto finder = std::make_unique<BallFinder>();
    (void)finder->Init(scan, FinderConfig(*d.lut)).ok();
    cv::Mat bgr, hsv, mask;
    constexpr int kReps = 20;
    double pixels = 0;
    int agree = 0, both = 0;
    FrontEndStats fs;
    BallDetection det;
    auto t0 = Clock::now();
    for (int r = 0; r < kReps; ++r)
      for (const auto& f : frames) {
        (void)finder->Find(View(f), *d.lut, nullptr, det, fs).ok();
        pixels += fs.pixels_read;
      }
    const double ours_us = (Clock::now() - t0) / (kReps * frames.size());
    t0 = Clock::now();
    for (int r = 0; r < kReps; ++r)
      for (const auto& f : frames) benchmark::DoNotOptimize(OpenCvFind(f, bgr, hsv, mask));
    const double cv_us = (Clock::now() - t0) / (kReps * frames.size());
    for (const auto& f : frames) {
      (void)finder->Find(View(f), *d.lut, nullptr, det, fs).ok();
      const CvResult c = OpenCvFind(f, bgr, hsv, mask);
      if (det.found && c.found) {
        ++both;
        agree += std::hypot(det.u_px - c.u, det.v_px - c.v) < 2.0;
      }
    }
    // Warm: each frame processed kReps times in a row (frame in cache; compute only).
    t0 = Clock::now();
    for (const auto& f : frames)
      for (int r = 0; r < kReps; ++r) (void)finder->Find(View(f), *d.lut, nullptr, det, fs).ok();
    const double ours_warm_us = (Clock::now() - t0) / (kReps * frames.size());
    t0 = Clock::now();
    for (const auto& f : frames)
      for (int r = 0; r < kReps; ++r) benchmark::DoNotOptimize(OpenCvFind(f, bgr, hsv, mask));
    const double cv_warm_us = (Clock::now() - t0) / (kReps * frames.size());
    std::printf(
        "%-5s %zu frames: front end %.1f us/frame, OpenCV full frame %.1f us/frame, ratio %.1fx "
        "(cold frames); warm cache %.1f vs %.1f us, ratio %.1fx; pixels read %.2f %%; same ball "
        "(< 2 px) in %d of %d frames where both found one\n",
        cam == 0 ? "omni" : "persp", frames.size(), ours_us, cv_us, cv_us / ours_us, ours_warm_us,
        cv_warm_us, cv_warm_us / ours_warm_us,
        100.0 * pixels / (kReps * frames.size()) / (kFrameWidth * kFrameHeight), agree, both);
  }
}

}  // namespace

int main(int argc, char** argv) {
  cv::setNumThreads(1);  // one core each, like the device
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  SideBySide();
  return 0;
}
