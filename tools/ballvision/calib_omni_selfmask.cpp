#include "tools/ballvision/calib_omni_selfmask.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <opencv2/imgproc.hpp>

namespace bv::cli::omni {
namespace {

constexpr int kMinFrames = 8;
constexpr int kChangeDn = 10;     // a chroma change between consecutive frames (noise ~1 DN)
constexpr int kWorldChanges = 2;  // a pixel that changed this often is the world's
constexpr double kMaxUnchanged = 0.5;
constexpr int kSectorBins = 720;  // 0.5 deg
constexpr double kSectorMarginDeg = 1.0;

bool Self(const cv::Mat1b& self, double u, double v) {
  const int iu = static_cast<int>(std::lround(u)), iv = static_cast<int>(std::lround(v));
  if (iu < 0 || iv < 0 || iu >= self.cols || iv >= self.rows) return true;  // off the image
  return self(iv, iu) != 0;
}

// 255 where the pixel's chroma changed fewer than kWorldChanges times between consecutive
// frames. Chroma, not brightness: the sun stays put in the hall while the robot turns, so the
// shading on its own body moves with the world; grey parts stay grey.
cv::Mat1b UnchangedPixels(const std::vector<Frame>& frames) {
  const cv::Size size = frames[0].bgr.size();
  cv::Mat1w changes(size, 0);
  cv::Mat yuv, prev, diff, changed;
  std::vector<cv::Mat> ch;
  for (size_t t = 0; t < frames.size(); ++t) {
    cv::cvtColor(frames[t].bgr, yuv, cv::COLOR_BGR2YUV);
    if (t > 0) {
      cv::absdiff(yuv, prev, diff);
      cv::split(diff, ch);
      cv::compare(cv::max(ch[1], ch[2]), kChangeDn, changed, cv::CMP_GT);
      cv::add(changes, 1, changes, changed);
    }
    std::swap(yuv, prev);
  }
  cv::Mat1b self;
  cv::compare(changes, kWorldChanges, self, cv::CMP_LT);
  // Single noisy pixels either way are not the robot's shape.
  const cv::Mat k = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(3, 3));
  cv::morphologyEx(self, self, cv::MORPH_OPEN, k);
  cv::morphologyEx(self, self, cv::MORPH_CLOSE, k);
  return self;
}

double UnchangedFraction(const cv::Mat1b& self, const RimFit& rim) {
  long in = 0, unchanged = 0;
  for (int v = 0; v < self.rows; ++v) {
    for (int u = 0; u < self.cols; ++u) {
      const double r = std::hypot(u - rim.cu, v - rim.cv);
      if (r < 0.3 * rim.radius || r > 0.95 * rim.radius) continue;
      ++in;
      unchanged += self(v, u) != 0;
    }
  }
  return in > 0 ? static_cast<double>(unchanged) / static_cast<double>(in) : 1.0;
}

// First radius along the ray where the world begins (4 world samples in a row); the rim if never.
double BodyEnd(const cv::Mat1b& self, const RimFit& rim, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  int run = 0;
  for (int r = 2; r < rim.radius; ++r) {
    run = Self(self, rim.cu + r * c, rim.cv + r * s) ? 0 : run + 1;
    if (run == 4) return r - 3;
  }
  return rim.radius;
}

// The body outline per direction (the lower third of 7 rays across the direction, so that a
// strut inside it does not stretch it), and the radius the scan starts at (its 90th percentile,
// so that the struts' few directions do not).
void BodyOutline(const cv::Mat1b& self, const RimFit& rim, OmniSelfMask& m) {
  std::vector<double> ends;
  const double step = 2 * M_PI / OmniSelfMask::kOutlineDirections;
  for (int i = 0; i < OmniSelfMask::kOutlineDirections; ++i) {
    double e[7];
    for (int k = 0; k < 7; ++k) e[k] = BodyEnd(self, rim, (i + (k + 0.5) / 7.0) * step);
    std::sort(e, e + 7);
    m.body_px[i] = static_cast<uint8_t>(std::clamp(std::ceil(e[2]), 0.0, 255.0));
    ends.push_back(e[2]);
  }
  std::sort(ends.begin(), ends.end());
  m.inner_radius_px = static_cast<float>(std::ceil(ends[ends.size() * 9 / 10]) + 1.0);
}

// The usable circle: inside the rim, and inside where the world ends in most directions (a
// holder that covers the rim's edge).
void OuterRadius(const cv::Mat1b& self, const RimFit& rim, OmniSelfMask& m) {
  std::vector<double> last;
  for (int i = 0; i < 360; ++i) {
    const double a = (i + 0.5) * M_PI / 180.0, c = std::cos(a), s = std::sin(a);
    int r = static_cast<int>(rim.radius) + 4;
    while (r > m.inner_radius_px && Self(self, rim.cu + r * c, rim.cv + r * s)) --r;
    last.push_back(r);
  }
  std::sort(last.begin(), last.end());
  m.outer_radius_px =
      static_cast<float>(std::floor(std::min(rim.radius - 1.0, last[last.size() / 10] + 2.0)));
}

// Directions whose ray is the robot's over most of the ring between body and rim: struts.
bool Sectors(const cv::Mat1b& self, const RimFit& rim, OmniSelfMask& m, std::string& error) {
  std::vector<bool> masked(kSectorBins);
  const double r0 = m.inner_radius_px + 4.0, r1 = m.outer_radius_px - 4.0;
  for (int b = 0; b < kSectorBins; ++b) {
    const double a = (b + 0.5) * 2 * M_PI / kSectorBins, c = std::cos(a), s = std::sin(a);
    int n = 0, in = 0;
    for (double r = r0; r <= r1; r += 1.0, ++n) in += Self(self, rim.cu + r * c, rim.cv + r * s);
    masked[b] = n > 0 && 2 * in > n;
  }
  int start = 0;  // a bin where a run begins (so that no run wraps past it)
  while (start < kSectorBins && masked[start]) ++start;
  if (start == kSectorBins) {
    error = "self-mask: every direction is masked";
    return false;
  }
  m.sector_count = 0;
  for (int k = 1; k <= kSectorBins; ++k) {
    const int b = (start + k) % kSectorBins;
    if (!masked[b]) continue;
    int len = 0;
    while (masked[(b + len) % kSectorBins]) ++len;
    k += len;
    const double half = len * 180.0 / kSectorBins + kSectorMarginDeg;
    if (m.sector_count == OmniSelfMask::kMaxSectors) {
      error = "self-mask: more than 8 masked sectors (struts or cables)";
      return false;
    }
    const double centre = std::fmod((b + 0.5 * len) * 360.0 / kSectorBins, 360.0);
    m.sectors[m.sector_count++] = {static_cast<float>(centre), static_cast<float>(half)};
  }
  return true;  // their total is ValidateSelfMask's
}

}  // namespace

bool LearnSelfMask(const std::vector<Frame>& frames, const RimFit& rim, SelfMaskResult& out,
                   std::string& error) {
  if (frames.size() < static_cast<size_t>(kMinFrames)) {
    error = "self-mask: needs at least 8 frames of the turning run";
    return false;
  }
  out = SelfMaskResult{};
  out.self = UnchangedPixels(frames);
  out.unchanged_fraction = UnchangedFraction(out.self, rim);
  if (out.unchanged_fraction > kMaxUnchanged) {
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "self-mask: %.0f %% of the mirror image never changed over %zu frames: did the "
                  "robot turn? (the self-mask cannot be learned; nothing written)",
                  100.0 * out.unchanged_fraction, frames.size());
    error = buf;
    return false;
  }
  OmniSelfMask& m = out.mask;
  m.known = true;
  BodyOutline(out.self, rim, m);
  OuterRadius(out.self, rim, m);
  if (!Sectors(out.self, rim, m, error)) return false;
  const Status valid = ValidateSelfMask(m);
  if (!valid.ok()) {
    error = valid.message();
    return false;
  }
  return true;
}

}  // namespace bv::cli::omni
