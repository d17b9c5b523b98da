#include "tools/ballvision/run_pipeline.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include <algorithm>
#include <memory>

#include "tools/ballvision/annotate_frontend.h"
#include "tools/ballvision/safe_write.h"
#include "tools/ballvision/signals.h"

namespace bv::cli {
namespace {

// DIR/lines.csv (index,x,y) and DIR/obstacles.csv (index,x,y,radius), robot frame, metres.
class FeatureWriter {
 public:
  bool Open(const std::string& dir, std::string& error) {
    if (!cli::MakeOutputDirectory(dir, error)) return false;
    lines_ = std::fopen((dir + "/lines.csv").c_str(), "w");
    obstacles_ = std::fopen((dir + "/obstacles.csv").c_str(), "w");
    if (!lines_ || !obstacles_) {
      error = dir + ": cannot write lines.csv / obstacles.csv";
      return false;
    }
    std::fputs("index,x,y\n", lines_);
    std::fputs("index,x,y,radius\n", obstacles_);
    return true;
  }
  bool Add(int64_t index, const FieldFeatures& f, std::string& error) {
    for (int i = 0; i < f.line_count; ++i) {
      std::fprintf(lines_, "%lld,%.4f,%.4f\n", static_cast<long long>(index), f.lines[i].x_m,
                   f.lines[i].y_m);
    }
    for (int i = 0; i < f.obstacle_count; ++i) {
      const Obstacle& o = f.obstacles[i];
      std::fprintf(obstacles_, "%lld,%.4f,%.4f,%.4f\n", static_cast<long long>(index), o.x_m, o.y_m,
                   o.radius_m);
    }
    if (std::ferror(lines_) || std::ferror(obstacles_)) {
      error = "writing lines.csv / obstacles.csv failed";
      return false;
    }
    return true;
  }
  ~FeatureWriter() {
    if (lines_) std::fclose(lines_);
    if (obstacles_) std::fclose(obstacles_);
  }

 private:
  std::FILE* lines_ = nullptr;
  std::FILE* obstacles_ = nullptr;
};

}  // namespace

namespace {

// Line points, obstacles and the field model (through the estimated pose) in omni pixels.
FieldOverlay MakeFieldOverlay(const Pipeline& pipeline, const OmniCalibration& cal) {
  FieldOverlay o;
  const FieldFeatures& f = pipeline.features();
  float u, v;
  for (int i = 0; i < f.line_count; ++i) {
    if (OmniGroundToPixel(cal, f.lines[i].x_m, f.lines[i].y_m, u, v).ok()) {
      o.line_points.push_back({u, v});
    }
  }
  for (int i = 0; i < f.obstacle_count; ++i) {
    const Obstacle& ob = f.obstacles[i];
    float u2, v2;
    const float d = std::hypot(ob.x_m, ob.y_m);
    if (d > 0.01f && OmniGroundToPixel(cal, ob.x_m, ob.y_m, u, v).ok() &&
        OmniGroundToPixel(cal, ob.x_m - ob.y_m / d * ob.radius_m, ob.y_m + ob.x_m / d * ob.radius_m,
                          u2, v2)
            .ok()) {
      o.obstacles.push_back({{u, v}, std::hypot(u2 - u, v2 - v)});
    }
  }
  o.self_mask = &cal.self_mask;
  o.center_u = cal.center_u;
  o.center_v = cal.center_v;
  const PoseEstimate& p = pipeline.localisation();
  char text[160];
  std::snprintf(text, sizeof text,
                "pose %s (%.2f, %.2f, %.1f deg) q %.2f%s, %d lines, %d obstacles%s",
                p.usable() ? "" : "unknown", p.x_m, p.y_m, p.heading_rad * 57.2958f, p.quality,
                p.ambiguous ? " ambiguous" : "", f.line_count, f.obstacle_count,
                cal.self_mask.known ? "" : ", no self-mask (reference rig)");
  o.caption = text;
  if (!p.usable()) return o;
  constexpr int kModelPoints = 4096;
  const std::unique_ptr<float[][2]> pts(new float[kModelPoints][2]);
  const int n = pipeline.field_model().LinePoints(0.05f, pts.get(), kModelPoints);
  const float s = std::sin(p.heading_rad), c = std::cos(p.heading_rad);
  for (int i = 0; i < n; ++i) {
    const float dx = pts[i][0] - p.x_m, dy = pts[i][1] - p.y_m;
    const float rx = dx * s - dy * c, ry = dx * c + dy * s;  // field -> robot frame
    if (OmniGroundToPixel(cal, rx, ry, u, v).ok()) o.model.push_back({u, v});
  }
  return o;
}

}  // namespace

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
    FieldOverlay field;
    const bool with_field = c == 0 && pipeline.features_enabled() && pipeline.calibration();
    if (with_field) field = MakeFieldOverlay(pipeline, pipeline.omni_model());
    if (!AnnotateFrontEnd(*imgs[c], *pipeline.lut(), *scans[c], *finders[c],
                          preds[c]->valid ? &p : nullptr, *dets[c], dir + name, &error, 1,
                          with_field ? &field : nullptr)) {
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
  if (!settings.annotate_dir.empty() && !cli::MakeOutputDirectory(settings.annotate_dir, error)) {
    return false;
  }
  std::unique_ptr<FeatureWriter> features;
  if (!settings.features_dir.empty()) {
    features = std::make_unique<FeatureWriter>();
    if (!features->Open(settings.features_dir, error)) return false;
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
    rec.pose = pipeline.localisation();
    rec.field_features = pipeline.field_model().ready() && pipeline.features_enabled();
    if (features && !features->Add(e.index, pipeline.features(), error)) return false;
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
