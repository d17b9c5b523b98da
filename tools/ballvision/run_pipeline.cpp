#include "tools/ballvision/run_pipeline.h"

#include <chrono>
#include <cstdio>
#include <filesystem>

#include <algorithm>

#include "tools/ballvision/annotate_frontend.h"
#include "tools/ballvision/signals.h"

namespace bv::cli {

bool AnnotateFrame(const std::string& dir, int64_t index, const FrameInput& in,
                   const Pipeline& pipeline, const BallState& s, std::string& error) {
  // The front end's debug picture (scanlines, contours, attention samples, prediction, ball).
  const YuyvImage* imgs[2] = {&in.omni, &in.persp};
  const BallDetection* dets[2] = {&s.omni, &s.persp};
  const ImagePrediction* preds[2] = {&pipeline.omni_prediction(), &pipeline.persp_prediction()};
  const ScanlineTableBase* scans[2] = {&pipeline.omni_scan(), &pipeline.persp_scan()};
  const BallFinder* finders[2] = {&pipeline.omni_finder(), &pipeline.persp_finder()};
  const char* names[2] = {"omni", "persp"};
  for (int c = 0; c < 2; ++c) {
    if (!imgs[c]->valid() || !scans[c]->built() || !pipeline.lut()) continue;
    Prediction p;
    p.u_px = preds[c]->u_px;
    p.v_px = preds[c]->v_px;
    p.sigma_px = std::max(2.f * preds[c]->radius_px, 6.f);
    char name[64];
    std::snprintf(name, sizeof name, "/%s_%06lld.png", names[c], static_cast<long long>(index));
    if (!AnnotateFrontEnd(*imgs[c], *pipeline.lut(), *scans[c], *finders[c],
                          preds[c]->valid ? &p : nullptr, *dets[c], dir + name, &error)) {
      return false;
    }
  }
  return true;
}

namespace {

// Every image of a camera must have the sequence's size (its first image's), and persp images
// the calibration's size: a frame of another size would be measured with the wrong geometry.
bool CheckFrameSize(const std::string& path, int w, int h, int& want_w, int& want_h,
                    const char* source, std::string& error) {
  if (want_w == 0) {
    want_w = w;
    want_h = h;
    return true;
  }
  if (w == want_w && h == want_h) return true;
  error = path + ": image is " + std::to_string(w) + "x" + std::to_string(h) + ", expected " +
          std::to_string(want_w) + "x" + std::to_string(want_h) + " (" + source + ")";
  return false;
}

}  // namespace

bool RunSequence(const host::Sequence& seq, Pipeline& pipeline, const RunSettings& settings,
                 std::vector<FrameRecord>& records, std::string& error) {
  records.clear();
  records.reserve(seq.entries.size());
  if (!settings.annotate_dir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(settings.annotate_dir, ec);
  }
  std::vector<uint8_t> omni, persp;
  int omni_w = 0, omni_h = 0, persp_w = 0, persp_h = 0;
  const char* persp_source = "the sequence's first persp image";
  if (pipeline.calibration() && pipeline.calibration()->persp.valid) {
    persp_w = pipeline.calibration()->persp.width_px;
    persp_h = pipeline.calibration()->persp.height_px;
    persp_source = "the calibration's persp image size";
  }
  const size_t n = seq.entries.size();
  for (size_t i = 0; i < n; ++i) {
    if (InterruptSignal()) break;  // the caller reports and writes what was processed
    const host::SequenceEntry& e = seq.entries[i];
    FrameInput in;
    in.t_us = e.t_us;
    int w = 0, h = 0;
    std::string err;
    if (!e.omni_path.empty()) {
      if (!host::LoadYuyv(e.omni_path, omni, w, h, err) ||
          !CheckFrameSize(e.omni_path, w, h, omni_w, omni_h, "the sequence's first omni image",
                          err)) {
        error = err;
        return false;
      }
      in.omni = MakeYuyvImage(omni.data(), w, h);
    }
    if (!e.persp_path.empty()) {
      if (!host::LoadYuyv(e.persp_path, persp, w, h, err) ||
          !CheckFrameSize(e.persp_path, w, h, persp_w, persp_h, persp_source, err)) {
        error = err;
        return false;
      }
      in.persp = MakeYuyvImage(persp.data(), w, h);
    }
    if (settings.reset_each_frame) pipeline.ResetTrack();
    FrameRecord rec;
    rec.index = e.index;
    const auto t0 = std::chrono::steady_clock::now();
    const Status st = pipeline.Process(in, rec.state);
    const auto t1 = std::chrono::steady_clock::now();
    if (!st.ok()) {
      error = std::string("frame ") + std::to_string(e.index) + ": " + st.message();
      return false;
    }
    rec.state.proc_us = static_cast<uint32_t>(
        std::chrono::duration_cast<std::chrono::microseconds>(t1 - t0).count());
    rec.meas = pipeline.last_measurement();
    uint64_t tc[8];
    float xs[8], ys[8];
    const int nc = pipeline.filter().ContactsAfter(e.t_us, tc, xs, ys, 8);
    if (rec.state.found) rec.contacts_us.assign(tc, tc + nc);
    if (!settings.annotate_dir.empty() &&
        !AnnotateFrame(settings.annotate_dir, e.index, in, pipeline, rec.state, error)) {
      return false;
    }
    if (settings.on_frame) settings.on_frame(pipeline, rec);
    records.push_back(std::move(rec));
    if (settings.progress && (i + 1 == n || i % 5 == 0)) {
      const int width = 40;
      const int done = static_cast<int>((i + 1) * width / n);
      std::fprintf(stderr, "\r[%.*s%*s] %zu/%zu frames", done,
                   "########################################", width - done, "", i + 1, n);
      if (i + 1 == n) std::fprintf(stderr, "\n");
    }
  }
  return true;
}

}  // namespace bv::cli
