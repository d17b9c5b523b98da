#include "core/contour/contour.h"

#include <algorithm>
#include <cmath>

namespace bv {

void RegionSetBase::Clear() {
  size_ = 0;
  chain_used_ = 0;
  pixels_read_ = 0;
  overflows_ = 0;
  dropped_small_ = 0;
  chain_exhausted_ = false;
  regions_exhausted_ = false;
}

bool RegionSetBase::OnContour(const Region& r, int u, int v) const {
  if (u < r.u_min || u > r.u_max || v < r.v_min || v > r.v_max) return false;
  int pu = r.start_u, pv = r.start_v;
  if (pu == u && pv == v) return true;
  const uint8_t* codes = chain_ + r.chain_offset;
  for (uint32_t i = 0; i < r.chain_length; ++i) {
    pu += kChainDu[codes[i]];
    pv += kChainDv[codes[i]];
    if (pu == u && pv == v) return true;
  }
  return false;
}

namespace {
// Unit vectors at k * 22.5 deg, k = 0..7, Q12; the other 8 directions are their negatives.
constexpr int32_t kDirCos[8] = {4096, 3784, 2896, 1567, 0, -1567, -2896, -3784};
constexpr int32_t kDirSin[8] = {0, 1567, 2896, 3784, 4096, 3784, 2896, 1567};

// Circumscribed 16-gon of the chain's boundary-pixel centres, grown by half a pixel (the pixels'
// outer edge, as area_px counts whole pixels). Its perimeter is 2 tan(pi/16) times the sum of the
// 16 support values (Cauchy; exact while every side is present, a slight overestimate otherwise).
void HullShape(const uint8_t* codes, uint32_t len, Region& r) {
  int32_t lo[8] = {}, hi[8] = {};
  int32_t x = 0, y = 0;
  for (uint32_t i = 0; i < len; ++i) {
    x += kChainDu[codes[i]];
    y += kChainDv[codes[i]];
    for (int k = 0; k < 8; ++k) {
      const int32_t p = x * kDirCos[k] + y * kDirSin[k];
      lo[k] = p < lo[k] ? p : lo[k];
      hi[k] = p > hi[k] ? p : hi[k];
    }
  }
  int64_t sum = 0;
  int32_t w_min = INT32_MAX, w_max = 0;
  for (int k = 0; k < 8; ++k) {
    const int32_t w = hi[k] - lo[k];
    sum += w;
    w_min = w < w_min ? w : w_min;
    w_max = w > w_max ? w : w_max;
  }
  constexpr float kQ = 1.0f / 4096.0f;
  const float perimeter = 0.39782473f * (static_cast<float>(sum) * kQ + 8.0f);  // +8: 16 x 0.5 px
  r.hull_roundness = std::min(1.0f, 4.0f * 3.14159265f * r.area_px / (perimeter * perimeter));
  r.width_ratio = (static_cast<float>(w_min) * kQ + 1.0f) / (static_cast<float>(w_max) * kQ + 1.0f);
}
}  // namespace

bool RegionSetBase::Trace(const YuyvImage& img, const ColorLut& lut, ColorClass cls, int u0, int v0,
                          Region& out) {
  out = Region{};
  out.start_u = static_cast<int16_t>(u0);
  out.start_v = static_cast<int16_t>(v0);
  out.chain_offset = static_cast<uint32_t>(chain_used_);
  int u_min = u0, u_max = u0, v_min = v0, v_max = v0;
  // Moments of the boundary-pixel-centre polygon, relative to the start pixel (exact integers).
  int64_t a2 = 0, mx6 = 0, my6 = 0;
  int64_t sum_x = 0, sum_y = 0;
  int n_even = 0, n_odd = 0, n_corner = 0;
  int x = 0, y = 0;  // position relative to the start
  int u = u0, v = v0;
  int search = 4;  // the left neighbour of the start pixel is outside the region
  int first_dir = -1, prev_dir = -1;
  uint32_t len = 0;
  for (;;) {
    int dir = -1;
    for (int k = 0; k < 8; ++k) {
      const int d = (search + k) & 7;
      ++pixels_read_;
      if (ClassAt(img, lut, u + kChainDu[d], v + kChainDv[d]) == cls) {
        dir = d;
        break;
      }
    }
    if (dir < 0) break;  // isolated pixel
    if (len > 0 && u == u0 && v == v0 && dir == first_dir) break;
    if (first_dir < 0) first_dir = dir;
    if (chain_used_ + len >= chain_capacity_) return false;
    chain_[chain_used_ + len] = static_cast<uint8_t>(dir);
    ++len;
    const int nx = x + kChainDu[dir], ny = y + kChainDv[dir];
    const int64_t cross = int64_t{x} * ny - int64_t{nx} * y;
    a2 += cross;
    mx6 += (x + nx) * cross;
    my6 += (y + ny) * cross;
    sum_x += x;
    sum_y += y;
    x = nx;
    y = ny;
    u += kChainDu[dir];
    v += kChainDv[dir];
    u_min = std::min(u_min, u);
    u_max = std::max(u_max, u);
    v_min = std::min(v_min, v);
    v_max = std::max(v_max, v);
    (dir & 1) ? ++n_odd : ++n_even;
    if (prev_dir >= 0 && prev_dir != dir) ++n_corner;
    prev_dir = dir;
    // Next search starts at the background pixel beside the one we came from.
    search = (dir & 1) ? (dir + 6) & 7 : (dir + 7) & 7;
  }
  chain_used_ += len;
  out.chain_length = len;
  out.u_min = static_cast<int16_t>(u_min);
  out.u_max = static_cast<int16_t>(u_max);
  out.v_min = static_cast<int16_t>(v_min);
  out.v_max = static_cast<int16_t>(v_max);
  // v grows downwards, so an outer contour (traversed down the left side) has a2 < 0.
  out.hole = a2 > 0;
  const float area = std::fabs(static_cast<float>(a2)) * 0.5f;
  out.polygon_area_px = area;
  out.area_px = area + static_cast<float>(len) * 0.5f + 1.0f;
  if (len > 0 && prev_dir != first_dir) ++n_corner;
  out.perimeter_px = 0.980f * static_cast<float>(n_even) + 1.406f * static_cast<float>(n_odd) -
                     0.091f * static_cast<float>(n_corner);
  if (a2 != 0) {
    out.cu_px = static_cast<float>(u0) + static_cast<float>(mx6) / (3.0f * static_cast<float>(a2));
    out.cv_px = static_cast<float>(v0) + static_cast<float>(my6) / (3.0f * static_cast<float>(a2));
  } else {
    const float n = static_cast<float>(std::max<uint32_t>(len, 1));
    out.cu_px = static_cast<float>(u0) + static_cast<float>(sum_x) / n;
    out.cv_px = static_cast<float>(v0) + static_cast<float>(sum_y) / n;
  }
  out.roundness =
      out.perimeter_px > 0.0f
          ? std::min(1.0f, 4.0f * 3.14159265f * area / (out.perimeter_px * out.perimeter_px))
          : 0.0f;
  if (!out.hole && out.area_px >= kHullMinArea) HullShape(chain_ + out.chain_offset, len, out);
  return true;
}

SeedOutcome RegionSetBase::TraceSeed(const YuyvImage& img, const ColorLut& lut, ColorClass cls,
                                     int u, int v) {
  ++pixels_read_;
  if (ClassAt(img, lut, u, v) != cls) return SeedOutcome::kNotInClass;
  // Cheap rejection first: a seed strictly inside the bbox of a region is walked left to its
  // boundary and checked against the stored contours before anything is traced.
  for (int hop = 0; hop <= kMaxHoleHops; ++hop) {
    while (true) {
      ++pixels_read_;
      if (ClassAt(img, lut, u - 1, v) != cls) break;
      --u;
    }
    for (size_t i = 0; i < size_; ++i) {
      if (OnContour(regions_[i], u, v)) {
        // On an outer contour: done. On a hole: the region around the hole is what we want.
        if (!regions_[i].hole) return SeedOutcome::kAlreadyTraced;
        goto cross_hole;
      }
    }
    if (regions_exhausted_ || size_ >= capacity_) {
      if (!regions_exhausted_) ++overflows_;
      regions_exhausted_ = true;
      return SeedOutcome::kRegionsFull;
    }
    if (chain_exhausted_) return SeedOutcome::kChainFull;
    {
      Region& r = regions_[size_];
      const size_t chain_before = chain_used_;
      if (!Trace(img, lut, cls, u, v, r)) {
        chain_used_ = chain_before;
        chain_exhausted_ = true;
        ++overflows_;
        return SeedOutcome::kChainFull;
      }
      if (!r.hole && r.area_px < min_keep_area_) {
        chain_used_ = chain_before;
        ++dropped_small_;
        return SeedOutcome::kTooSmall;
      }
      ++size_;
      if (!r.hole) return SeedOutcome::kNewRegion;
    }
  cross_hole:
    // Walk left through the hole to the next pixel of the class, then on to its boundary.
    do {
      --u;
      ++pixels_read_;
      if (u < 0) return SeedOutcome::kTooManyHoles;  // cannot happen for a closed hole
    } while (ClassAt(img, lut, u, v) != cls);
  }
  return SeedOutcome::kTooManyHoles;
}

}  // namespace bv
