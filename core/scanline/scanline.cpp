#include "core/scanline/scanline.h"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace bv {
namespace {

constexpr float kPi = 3.14159265358979f;
constexpr float kSqrt2 = 1.41421356f;
constexpr float kRadialResolutionPx = 0.5f;  // radius grid for level starts and step changes
constexpr int kMaxRadialLines = 4096;
// Along-line steps are quantised to these values so a line splits into few segments.
constexpr float kSteps[] = {1.0f, 1.5f, 2.0f, 2.5f,  3.0f,  4.0f,
                            5.0f, 6.0f, 8.0f, 10.0f, 12.0f, 16.0f};

bool ValidProfile(const DiameterProfile& p) {
  if (p.count < 0 || p.count > DiameterProfile::kMaxPoints) return false;
  for (int i = 0; i < p.count; ++i) {
    if (!std::isfinite(p.at_px[i]) || !std::isfinite(p.diameter_px[i]) || p.diameter_px[i] < 2.0f) {
      return false;
    }
    if (i > 0 && !(p.at_px[i] > p.at_px[i - 1])) return false;
  }
  return true;
}

float QuantiseStep(float gap_px) {
  float best = kSteps[0];
  for (float s : kSteps) {
    if (s <= gap_px) best = s;
  }
  return best;
}

float AngleDiffDeg(float a, float b) {
  float d = std::fmod(std::fabs(a - b), 360.0f);
  return d > 180.0f ? 360.0f - d : d;
}

}  // namespace

int OmniFeatureRadii(const OmniScanConfig& c, float* radii, int capacity) {
  const OmniFeatureRays& f = c.features;
  if (f.rays == 0) return 0;
  if (f.rays < 0 || f.rays > OmniFeatureRays::kMaxRays || (f.rays & (f.rays - 1)) != 0 ||
      !(f.step_inner_px >= 1.0f) || !(f.step_outer_px >= 1.0f) ||
      !(f.end_radius_px > c.inner_radius_px) || !(f.end_radius_px <= c.outer_radius_px) ||
      f.end_radius_px > 2047.0f || !(c.center_u >= 0.0f && c.center_u <= 2047.0f) ||
      !(c.center_v >= 0.0f && c.center_v <= 2047.0f)) {
    return -1;
  }
  int n = 0;
  const float span = f.end_radius_px - c.inner_radius_px;
  for (float r = c.inner_radius_px; r <= f.end_radius_px + 1e-4f;) {
    if (n >= capacity || n >= OmniFeatureRays::kMaxRadii) return -1;
    radii[n++] = r;
    const float t = (r - c.inner_radius_px) / span;
    r += std::max(1.0f, std::round(f.step_inner_px + t * (f.step_outer_px - f.step_inner_px)));
  }
  return n;
}

namespace {
constexpr float kRayClearDeg = 0.5f;  // a moved feature ray's distance from the sector's edge

// Feature ray i's angle in degrees, if moved out of a sector (`moved`); `clear` false when it
// stays in a sector or moved more than half a step.
float FeatureRayDeg(const OmniScanConfig& c, int ray, bool& clear, bool& moved) {
  const float step = 360.0f / static_cast<float>(c.features.rays);
  const float nominal = step * static_cast<float>(ray);
  float a = nominal;
  moved = false;
  for (int s = 0; s < c.strut_count; ++s) {
    const float d = std::remainder(nominal - c.struts[s].angle_deg, 360.0f);
    if (std::fabs(d) <= c.struts[s].half_width_deg) {
      a = c.struts[s].angle_deg +
          std::copysign(c.struts[s].half_width_deg + kRayClearDeg, d == 0.0f ? 1.0f : d);
      moved = true;
      break;
    }
  }
  clear = AngleDiffDeg(a, nominal) <= 0.5f * step;
  for (int s = 0; s < c.strut_count && clear; ++s) {
    clear = AngleDiffDeg(a, c.struts[s].angle_deg) > c.struts[s].half_width_deg;
  }
  return a;
}
}  // namespace

float OmniFeatureRayAngle(const OmniScanConfig& c, int ray) {
  bool clear = false, moved = false;
  const float deg = FeatureRayDeg(c, ray, clear, moved);
  return moved ? deg * (kPi / 180.0f)
               : 2 * kPi * static_cast<float>(ray) / static_cast<float>(c.features.rays);
}

OmniRayQ MakeOmniRay(const OmniScanConfig& c, int ray) {
  const float a = OmniFeatureRayAngle(c, ray);
  OmniRayQ q;
  q.u0_q18 = static_cast<int32_t>(std::lround((c.center_u + 0.5f) * 262144.0f));
  q.v0_q18 = static_cast<int32_t>(std::lround((c.center_v + 0.5f) * 262144.0f));
  q.cs_q14 = static_cast<int32_t>(std::lround(std::cos(a) * 16384.0f));
  q.sn_q14 = static_cast<int32_t>(std::lround(std::sin(a) * 16384.0f));
  return q;
}

bool OmniFeatureRayBlocked(const OmniScanConfig& c, int ray) {
  bool clear = false, moved = false;
  FeatureRayDeg(c, ray, clear, moved);
  return !clear;
}

float DiameterProfile::At(float x) const {
  if (count <= 0) return 0.0f;
  if (x <= at_px[0]) return diameter_px[0];
  for (int i = 1; i < count; ++i) {
    if (x <= at_px[i]) {
      const float t = (x - at_px[i - 1]) / (at_px[i] - at_px[i - 1]);
      return diameter_px[i - 1] + t * (diameter_px[i] - diameter_px[i - 1]);
    }
  }
  return diameter_px[count - 1];
}

OmniScanConfig ReferenceOmniScanConfig(float center_u, float center_v) {
  OmniScanConfig c;
  c.center_u = center_u;
  c.center_v = center_v;
  c.inner_radius_px = 54.0f;   // own body / mirror holder end at r ~ 52 px
  c.outer_radius_px = 219.0f;  // mirror rim: the self mask closes at r ~ 220 px
  // Strut wedges at image angles ~14.5, ~134.8, ~256.5 deg, about 4 deg wide.
  c.struts[0] = {14.5f, 2.5f};
  c.struts[1] = {134.8f, 2.5f};
  c.struts[2] = {256.5f, 2.5f};
  c.strut_count = 3;
  c.margin_px = 0.4f;

  // Smallest ball diameter by radius (ground ball; a raised ball at the same radius is
  // closer and larger): 24 px at 107, 12 at 162, 8 at 177, 7.4 at 180 (5.5 m), 4 px at the rim.
  const float at[] = {100.0f, 150.0f, 165.0f, 178.0f, 192.0f, 205.0f};
  const float dia[] = {20.0f, 14.0f, 10.0f, 7.0f, 5.0f, 4.0f};
  for (int i = 0; i < 6; ++i) {
    c.diameter.at_px[i] = at[i];
    c.diameter.diameter_px[i] = dia[i];
  }
  c.diameter.count = 6;
  return c;
}

PerspScanConfig ReferencePerspScanConfig() {
  PerspScanConfig c;
  c.diameter.at_px[0] = 0.0f;
  c.diameter.diameter_px[0] = 8.0f;  // ~11 m away with fx = 378 px
  c.diameter.count = 1;
  return c;
}

void ScanlineTableBase::Reset(int width, int height) {
  pixels_ = 0;
  used_ = 0;
  width_ = width;
  height_ = height;
  for (uint16_t& s : row_start_) s = 0;
  for (uint16_t& f : row_first_u_) f = 0;
  lead_rows_ = 0;
}

void ScanlineTableBase::SetPrefetchLead() {
  int first = -1, last = -1, rows = 0;
  for (int v = 0; v < height_; ++v) {
    if (row_start_[v] == row_start_[v + 1]) continue;
    if (first < 0) first = v;
    last = v;
    ++rows;
  }
  // The mean spacing of the sampled rows: a table's rows are evenly spaced (persp lattice) or
  // adjacent (omni), and one distance per table keeps the hot loop free of a per-row lookup.
  lead_rows_ =
      rows > 1 ? std::clamp((last - first) * kPrefetchSampledRows / (rows - 1), 1, 255) : 0;
}

namespace {
// Escape entries a row can need: its width (<= 4096) over 255.
constexpr int kMaxEscapesPerRow = 4096 / 255 + 1;
}  // namespace

uint16_t* ScanlineTableBase::RowBuffer(int& room) const {
  const size_t first = (used_ + 1) / 2;  // the first word wholly past the written entries
  room = first < word_count_ ? static_cast<int>(word_count_ - first) : 0;
  return words_ + first;
}

Status ScanlineTableBase::AppendBufferedRow(int v, int m) {
  int room = 0;
  uint16_t* row = RowBuffer(room);
  uint16_t* const end = words_ + (word_count_ - static_cast<size_t>(m));
  // The row's entries (m samples and its escapes) are written from used_ on: they must stay below
  // the columns still to be read.
  if (m > room || used_ + static_cast<size_t>(m + kMaxEscapesPerRow) >
                      2 * (word_count_ - static_cast<size_t>(m))) {
    return Status(StatusCode::kResourceExhausted, "scanlines: more samples than the capacity");
  }
  std::memmove(end, row, static_cast<size_t>(m) * sizeof(uint16_t));
  return AppendRow(v, end, m);
}

Status ScanlineTableBase::AppendRow(int v, const uint16_t* us, int n) {
  row_start_[v] = static_cast<uint16_t>(used_);
  row_first_u_[v] = n > 0 ? us[0] : 0;
  for (int k = 0; k < n; ++k) {
    int d = k == 0 ? 0 : us[k] - us[k - 1];
    // A gap wider than a byte is bridged by escape entries (0 = advance 255, read nothing);
    // rare: sparse rows near the robot.
    while (true) {
      if (used_ >= capacity_) {
        return Status(StatusCode::kResourceExhausted, "scanlines: more samples than the capacity");
      }
      if (d <= 255) break;
      delta_[used_++] = 0;
      d -= 255;
    }
    delta_[used_++] = static_cast<uint8_t>(d);
    ++pixels_;
  }
  row_start_[v + 1] = static_cast<uint16_t>(used_);
  return Status::Ok();
}

namespace {

// Sorts (insertion; rows hold a few dozen samples) and removes duplicates; returns the count.
int SortUnique(uint16_t* us, int n) {
  for (int i = 1; i < n; ++i) {
    const uint16_t x = us[i];
    int j = i - 1;
    for (; j >= 0 && us[j] > x; --j) us[j + 1] = us[j];
    us[j + 1] = x;
  }
  int m = 0;
  for (int i = 0; i < n; ++i) {
    if (m == 0 || us[m - 1] != us[i]) us[m++] = us[i];
  }
  return m;
}

struct Band {
  float from, to, step;
};

float g_feature_radii[OmniFeatureRays::kMaxRadii];  // start-up only

Status CheckOmniConfig(const OmniScanConfig& c, int width, int height) {
  if (!std::isfinite(c.center_u) || !std::isfinite(c.center_v) || c.center_u < 0 ||
      c.center_v < 0 || c.center_u > width - 1 || c.center_v > height - 1) {
    return Status(StatusCode::kInvalidArgument, "BuildOmni: centre outside the image");
  }
  if (!(c.inner_radius_px >= 1.0f) || !(c.outer_radius_px > c.inner_radius_px) ||
      c.outer_radius_px > 4000.0f) {
    return Status(StatusCode::kInvalidArgument, "BuildOmni: need 1 <= inner radius < outer radius");
  }
  if (!ValidProfile(c.diameter) || c.strut_count < 0 ||
      c.strut_count > OmniScanConfig::kMaxStruts || !(c.margin_px >= 0.0f)) {
    return Status(StatusCode::kInvalidArgument,
                  "BuildOmni: bad diameter profile, struts or margin");
  }
  return Status::Ok();
}

// The omni table's radial lines: their count doubles at each level, a level starting where the
// previous one's arc spacing gets too wide; along a line the step follows radial bands.
class OmniLines {
 public:
  OmniLines(const OmniScanConfig& c, int width, int height)
      : c_(c), width_(width), height_(height) {}

  Status Plan() {
    const Status st = PlanBands();
    return st.ok() ? PlanLevels() : st;
  }

  // Calls fn(cs, sn, r_start, r_end) for every radial line outside the strut wedges.
  template <typename Fn>
  void ForEachLine(Fn&& fn) const {
    for (int i = 0; i < n_lines_; ++i) {
      int level = 0;
      if (i % (n_lines_ / n0_) != 0) {
        level = levels_ - 1;
        for (int k = 1; k < levels_; ++k) {
          if (i % (n_lines_ / (n0_ << k)) == 0) {
            level = k;
            break;
          }
        }
      }
      const float angle = 2 * kPi * static_cast<float>(i) / static_cast<float>(n_lines_);
      const float angle_deg = angle * (180.0f / kPi);
      bool in_strut = false;
      for (int s = 0; s < c_.strut_count; ++s) {
        in_strut |= AngleDiffDeg(angle_deg, c_.struts[s].angle_deg) <= c_.struts[s].half_width_deg;
      }
      if (in_strut) continue;
      const float cs = std::cos(angle), sn = std::sin(angle);
      float r_end = c_.outer_radius_px;  // clipped to the image (pixel centres 0..size-1)
      if (cs > 1e-6f) r_end = std::min(r_end, (width_ - 0.51f - c_.center_u) / cs);
      if (cs < -1e-6f) r_end = std::min(r_end, (-0.49f - c_.center_u) / cs);
      if (sn > 1e-6f) r_end = std::min(r_end, (height_ - 0.51f - c_.center_v) / sn);
      if (sn < -1e-6f) r_end = std::min(r_end, (-0.49f - c_.center_v) / sn);
      if (r_end >= level_start_[level]) fn(cs, sn, level_start_[level], r_end);
    }
  }

  // Samples of one line: r_start, then the band steps; between bands the step shrinks at once.
  // fn(r) returns false to stop.
  template <typename Fn>
  void ForEachSample(float r_start, float r_end, Fn&& fn) const {
    float last = -1.0f;
    for (int b = 0; b < band_count_; ++b) {
      if (last < 0 && r_start > bands_[b].to) continue;
      float r = last < 0 ? r_start : last + bands_[b].step;
      const float end = std::min(bands_[b].to, r_end);
      for (; r <= end + 1e-4f; r += bands_[b].step) {
        last = r;
        if (!fn(r)) return;
      }
      if (last >= r_end) return;
    }
  }

 private:
  static constexpr int kMaxBands = 32;
  static constexpr int kMaxLevels = 16;

  float Gap(float r) const {
    const float d = c_.diameter.count > 0 ? c_.diameter.At(r) : 4.0f;
    return std::max(1.0f, (d * 0.5f - c_.margin_px) * kSqrt2);
  }

  // Radial bands of constant (quantised) step along a line.
  Status PlanBands() {
    const float r_in = c_.inner_radius_px, r_out = c_.outer_radius_px;
    float from = r_in;
    float step = QuantiseStep(Gap(r_in));
    for (float r = r_in + kRadialResolutionPx; r <= r_out + kRadialResolutionPx;
         r += kRadialResolutionPx) {
      const float s = r > r_out ? -1.0f : QuantiseStep(Gap(r));
      if (s == step) continue;
      if (band_count_ >= kMaxBands) {
        return Status(StatusCode::kInvalidArgument,
                      "BuildOmni: profile needs more than 32 step bands");
      }
      bands_[band_count_++] = Band{from, std::min(r - kRadialResolutionPx, r_out), step};
      from = r;
      step = s;
    }
    return Status::Ok();
  }

  // Lines needed at radius r: 2*pi*r / gap(r). Level 0 serves the inner radius; each further
  // level doubles the count and starts where the previous level's arc spacing gets too wide.
  Status PlanLevels() {
    const float r_in = c_.inner_radius_px, r_out = c_.outer_radius_px;
    n0_ = 8;
    while (2 * kPi * r_in / n0_ > Gap(r_in) && n0_ < kMaxRadialLines) n0_ *= 2;
    level_start_[0] = r_in;
    levels_ = 1;
    for (float r = r_in; r <= r_out; r += kRadialResolutionPx) {
      while (2 * kPi * r / (n0_ << (levels_ - 1)) > Gap(r)) {
        if ((n0_ << levels_) > kMaxRadialLines || levels_ >= kMaxLevels) {
          return Status(StatusCode::kInvalidArgument,
                        "BuildOmni: profile needs > 4096 radial lines");
        }
        level_start_[levels_++] = r;
      }
    }
    n_lines_ = n0_ << (levels_ - 1);
    return Status::Ok();
  }

  const OmniScanConfig& c_;
  int width_, height_;
  Band bands_[kMaxBands] = {};
  int band_count_ = 0;
  int n0_ = 8, levels_ = 1, n_lines_ = 0;
  float level_start_[kMaxLevels] = {};
};

// The feature rays' samples (the same rounding as core/field's reader), row by row.
class FeatureRaySamples {
 public:
  Status Init(const OmniScanConfig& c, int width) {
    width_ = width;
    n_radii_ = OmniFeatureRadii(c, g_feature_radii, OmniFeatureRays::kMaxRadii);
    if (n_radii_ < 0) {
      return Status(StatusCode::kInvalidArgument,
                    "BuildOmni: feature rays not a power of two <= 64 or bad radii/steps");
    }
    for (int i = 0; i < c.features.rays; ++i) {
      if (!OmniFeatureRayBlocked(c, i)) rays_[n_rays_++] = MakeOmniRay(c, i);
    }
    return Status::Ok();
  }

  // Appends row v's samples to row[n..room); overflow when they do not fit.
  void AddRow(int v, uint16_t* row, int room, int& n, bool& overflow) const {
    for (int i = 0; i < n_rays_ && !overflow; ++i) {
      const OmniRayQ& q = rays_[i];
      for (int k = 0; k < n_radii_; ++k) {
        int su, sv;
        OmniRayPixel(q, RadiusQ4(g_feature_radii[k]), su, sv);
        if (sv != v || su < 0 || su >= width_) continue;
        if (n >= room) {
          overflow = true;
          return;
        }
        row[n++] = static_cast<uint16_t>(su);
      }
    }
  }

 private:
  OmniRayQ rays_[OmniFeatureRays::kMaxRays] = {};
  int n_rays_ = 0, n_radii_ = 0, width_ = 0;
};

}  // namespace

Status ScanlineTableBase::BuildOmni(const OmniScanConfig& c, int width, int height) {
  Reset(0, 0);
  if (width <= 0 || height <= 0 || width > 4096 || height > kMaxRows) {
    return Status(StatusCode::kInvalidArgument, "BuildOmni: image size out of range");
  }
  BV_TRY(CheckOmniConfig(c, width, height));
  OmniLines lines(c, width, height);
  BV_TRY(lines.Plan());
  FeatureRaySamples features;
  BV_TRY(features.Init(c, width));

  width_ = width;
  height_ = height;
  for (int v = 0; v < height; ++v) {
    int n = 0, room = 0;
    bool overflow = false;
    uint16_t* const row = RowBuffer(room);
    features.AddRow(v, row, room, n, overflow);
    lines.ForEachLine([&](float cs, float sn, float r_start, float r_end) {
      const float va = c.center_v + r_start * sn, vb = c.center_v + r_end * sn;
      if (v < std::min(va, vb) - 1.0f || v > std::max(va, vb) + 1.0f) return;
      lines.ForEachSample(r_start, r_end, [&](float r) {
        const int sv = static_cast<int>(std::floor(c.center_v + 0.5f + r * sn));
        if (sv == v) {
          if (n >= room) {
            overflow = true;
            return false;
          }
          row[n++] = static_cast<uint16_t>(std::floor(c.center_u + 0.5f + r * cs));
        }
        return !((sn > 0 && sv > v) || (sn < 0 && sv < v));
      });
    });
    if (overflow) {
      Reset(0, 0);
      return Status(StatusCode::kResourceExhausted, "BuildOmni: more samples than the capacity");
    }
    const Status st = AppendBufferedRow(v, SortUnique(row, n));
    if (!st.ok()) {
      Reset(0, 0);
      return st;
    }
  }
  SetPrefetchLead();
  return Status::Ok();
}

namespace {
// Largest distance from any point of a brick lattice (row step s, row spacing h, alternate rows
// shifted by k) to its nearest lattice point: the larger circumradius of its two triangles.
float BrickCoverRadius(int s, int h, int k) {
  const auto circ = [](float ax, float ay, float bx, float by, float cx, float cy) {
    const float a = std::hypot(bx - cx, by - cy), b = std::hypot(ax - cx, ay - cy),
                c = std::hypot(ax - bx, ay - by);
    const float area2 = std::fabs((bx - ax) * (cy - ay) - (cx - ax) * (by - ay));
    return a * b * c / (2.0f * area2);
  };
  const float fs = static_cast<float>(s), fh = static_cast<float>(h), fk = static_cast<float>(k);
  return std::max(circ(0, 0, fs, 0, fk, fh), circ(fk, fh, fk + fs, fh, fs, 0));
}
}  // namespace

Status ScanlineTableBase::BuildPersp(const PerspScanConfig& c, int width, int height) {
  Reset(0, 0);
  if (width <= 0 || height <= 0 || width > 4096 || height > kMaxRows) {
    return Status(StatusCode::kInvalidArgument, "BuildPersp: image size out of range");
  }
  if (!ValidProfile(c.diameter))
    return Status(StatusCode::kInvalidArgument, "BuildPersp: bad profile");
  const int last = c.last_row < 0 ? height - 1 : c.last_row;
  if (c.first_row < 0 || last >= height || last < c.first_row) {
    return Status(StatusCode::kInvalidArgument, "BuildPersp: row range outside the image");
  }
  width_ = width;
  height_ = height;
  int lattice_row = 0;
  int next = c.first_row;
  for (int v = 0; v < height; ++v) {
    int n = 0, room = 0;
    uint16_t* const columns = RowBuffer(room);
    if (v == next && v <= last) {
      const float d = c.diameter.count > 0 ? c.diameter.At(static_cast<float>(v)) : 8.0f;
      int s = std::min(255, std::max(1, static_cast<int>(d * 0.8660f)));
      int h = 1;
      for (; s > 1; --s) {
        h = std::max(1, static_cast<int>(std::lround(s * 0.866f)));
        if (BrickCoverRadius(s, h, s / 2) < d * 0.5f - 0.05f) break;
      }
      if (s == 1) h = 1;
      for (int u = (lattice_row & 1) ? s / 2 : 0; u < width; u += s) {
        if (n >= room) {
          Reset(0, 0);
          return Status(StatusCode::kResourceExhausted,
                        "BuildPersp: more samples than the capacity");
        }
        columns[n++] = static_cast<uint16_t>(u);
      }
      ++lattice_row;
      next = v + h;
    }
    const Status st = AppendBufferedRow(v, n);
    if (!st.ok()) {
      Reset(0, 0);
      return st;
    }
  }
  SetPrefetchLead();
  return Status::Ok();
}

}  // namespace bv
