#include "core/contour/contour.h"

#include "core/common/circle_fit.h"

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
  protected_ = 0;
  replaced_ = 0;
}

size_t RegionSetBase::Weakest() const {
  size_t weakest = size_;
  for (size_t i = protected_; i < size_; ++i) {
    if (!regions_[i].hole &&
        (weakest == size_ || ShapeEvidence(regions_[i]) < ShapeEvidence(regions_[weakest]))) {
      weakest = i;
    }
  }
  return weakest;
}

bool RegionSetBase::OnContour(Region& r, int u, int v) {
  if (u < r.u_min || u > r.u_max || v < r.v_min || v > r.v_max) return false;
  // A closed contour visits the same pixels wherever its walk starts: start where the last hit on
  // it was, as the next seed in scan order usually lies a few steps further along (down its left
  // side). Same answer as a walk from the start pixel, a fraction of the steps on a large region
  // that many scanline rows cross.
  const int32_t target = PackedPixel(u, v);
  int32_t pos = r.walk_pos;
  if (pos == target) return true;
  const uint8_t* codes = chain_ + r.chain_offset;
  const uint32_t len = r.chain_length, from = r.walk_index;
  // Codes [from, len) end at the start pixel, [0, from) back where the walk began.
  auto walk = [&](uint32_t first, uint32_t end) {
    for (uint32_t i = first; i < end; ++i) {
      pos += kChainDp[codes[i]];
      if (pos == target) {
        r.walk_index = static_cast<uint16_t>(i + 1 < len ? i + 1 : 0);
        r.walk_pos = pos;
        return true;
      }
    }
    return false;
  };
  return walk(from, len) || walk(0, from);
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
    // Along a straight run a projection is linear: its extremes are at the run's ends (the corners,
    // and the start, which lo/hi = 0 already hold). Same result, a fraction of the work.
    if (i + 1 < len && codes[i + 1] == codes[i]) continue;
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
  out.chain_offset = static_cast<uint16_t>(chain_used_);
  out.walk_pos = PackedPixel(u0, v0);
  // Locals, not members: the chain is written through a uint8_t pointer, which may alias any
  // member, and every member read in the loop would be reloaded after each write.
  const YuyvImage image = img;
  uint8_t* const codes = chain_ + chain_used_;
  const size_t room = chain_capacity_ - chain_used_;
  uint32_t reads = 0;
  int u_min = u0, u_max = u0, v_min = v0, v_max = v0;
  // Moments of the boundary-pixel-centre polygon, relative to the start pixel (exact integers:
  // each step's terms fit 32 bits for images up to 4096 px, their sums need 64).
  int64_t a2 = 0, mx6 = 0, my6 = 0;
  int32_t sum_x = 0, sum_y = 0;
  int n_odd = 0, n_corner = 0;
  int x = 0, y = 0;  // position relative to the start
  int u = u0, v = v0;
  int search = 4;  // the left neighbour of the start pixel is outside the region
  int first_dir = -1, prev_dir = -1;
  uint32_t len = 0;
  for (;;) {
    int dir = -1;
    for (int k = 0; k < 8; ++k) {
      const int d = (search + k) & 7;
      ++reads;
      if (ClassAt(image, lut, u + kChainDu[d], v + kChainDv[d]) == cls) {
        dir = d;
        break;
      }
    }
    if (dir < 0) break;  // isolated pixel
    if (len > 0 && u == u0 && v == v0 && dir == first_dir) break;
    if (first_dir < 0) first_dir = dir;
    if (len >= room) {
      pixels_read_ += reads;
      return false;
    }
    codes[len++] = static_cast<uint8_t>(dir);
    const int du = kChainDu[dir], dv = kChainDv[dir];
    const int32_t cross = x * dv - du * y;  // x * (y + dv) - (x + du) * y
    a2 += cross;
    mx6 += (2 * x + du) * cross;
    my6 += (2 * y + dv) * cross;
    sum_x += x;
    sum_y += y;
    x += du;
    y += dv;
    u += du;
    v += dv;
    u_min = std::min(u_min, u);
    u_max = std::max(u_max, u);
    v_min = std::min(v_min, v);
    v_max = std::max(v_max, v);
    n_odd += dir & 1;
    if (prev_dir >= 0 && prev_dir != dir) ++n_corner;
    prev_dir = dir;
    // Next search starts at the background pixel beside the one we came from.
    search = (dir & 1) ? (dir + 6) & 7 : (dir + 7) & 7;
  }
  pixels_read_ += reads;
  const int n_even = static_cast<int>(len) - n_odd;
  chain_used_ += len;
  out.chain_length = static_cast<uint16_t>(len);
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
    {
      const bool full = size_ >= capacity_;
      if (full) {
        if (!regions_exhausted_) ++overflows_;
        regions_exhausted_ = true;
      }
      if (chain_exhausted_) return SeedOutcome::kChainFull;
      // When full, the trace goes to a scratch record: it replaces the weakest region or is let go.
      Region scratch;
      Region& r = full ? scratch : regions_[size_];
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
      if (full) {
        const size_t weakest = Weakest();
        // A trace let go keeps its codes used: with the pool, they bound the work a frame of
        // clutter can cost, as before the capacity was reached. A hole is crossed all the same.
        if (r.hole || weakest >= size_ || ShapeEvidence(r) <= ShapeEvidence(regions_[weakest])) {
          if (!r.hole) return SeedOutcome::kRegionsFull;
        } else {
          regions_[weakest] = r;  // its chain codes stay used until Clear
          ++replaced_;
          return SeedOutcome::kReplaced;
        }
      } else {
        ++size_;
        if (!r.hole) return SeedOutcome::kNewRegion;
      }
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

namespace {
constexpr int kCircleSamples = 48;

// fn(j, x, y) for each of the outline's points in chain order, relative to the start pixel.
template <typename Fn>
void ForEachOutlinePoint(const uint8_t* codes, uint32_t len, Fn&& fn) {
  int x = 0, y = 0;
  for (uint32_t j = 0; j < len; ++j) {
    fn(j, x, y);
    x += kChainDu[codes[j]];
    y += kChainDv[codes[j]];
  }
}

// Circle through three points; false when they are (nearly) collinear.
bool Circumcircle(float ax, float ay, float bx, float by, float cx, float cy, float& ox, float& oy,
                  float& r2) {
  bx -= ax;
  by -= ay;
  cx -= ax;
  cy -= ay;
  const float d = 2.0f * (bx * cy - by * cx);
  if (std::fabs(d) < 1.0f) return false;
  const float b2 = bx * bx + by * by, c2 = cx * cx + cy * cy;
  const float ux = (cy * b2 - by * c2) / d, uy = (bx * c2 - cx * b2) / d;
  ox = ax + ux;
  oy = ay + uy;
  r2 = ux * ux + uy * uy;
  return true;
}

// Sector 0..15 of the direction (dx, dy) by its diamond angle (monotonic in the angle, no trig).
int Sector(float dx, float dy) {
  const float s = std::fabs(dx) + std::fabs(dy);
  if (!(s > 0.0f)) return 0;
  const float a = dy >= 0.0f ? (dx >= 0.0f ? dy / s : 1.0f - dx / s)
                             : (dx < 0.0f ? 2.0f - dy / s : 3.0f + dx / s);
  return std::min(kCircleSectors - 1, static_cast<int>(a * 4.0f));
}

// Longest run of set bits in a 16-bit circular mask: an arc is one run; the outline of a square
// meets its inscribed circle in four short ones.
int LongestRun(uint32_t mask) {
  if (mask == 0xFFFFu) return kCircleSectors;
  const uint32_t twice = mask | (mask << kCircleSectors);
  int best = 0, run = 0;
  for (int k = 0; k < 2 * kCircleSectors; ++k) {
    run = (twice >> k) & 1u ? run + 1 : 0;
    best = std::max(best, run);
  }
  return best;
}

// Boundary pixel centres lie within about 0.7 px of a digital disc's circle; blur and partial
// classification add a little with the size.
float CircleTolerance(float r) { return 0.9f + 0.06f * r; }

// The outline points that count as on the circle of radius r: squared distances from its centre
// within the tolerance band.
struct Ring {
  float lo2, hi2;
  bool Holds(float z) const { return z >= lo2 && z <= hi2; }
};
Ring RingOf(float r) {
  const float tol = CircleTolerance(r), lo = std::max(0.0f, r - tol);
  return {lo * lo, (r + tol) * (r + tol)};
}

// Outline points on the image border (relative to the region's start pixel) are where the image
// cut the region, not its edge: no circle is fitted to them.
struct ImageBorder {
  bool known = false;
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  bool Holds(int x, int y) const { return known && (x <= x0 || y <= y0 || x >= x1 || y >= y1); }
};
ImageBorder BorderOf(const Region& reg, int image_width, int image_height) {
  ImageBorder b;
  if (image_width <= 0 || image_height <= 0) return b;
  b.known = true;
  b.x0 = -reg.start_u;
  b.y0 = -reg.start_v;
  b.x1 = image_width - 1 - reg.start_u;
  b.y1 = image_height - 1 - reg.start_v;
  return b;
}

// The outline's points (relative to the start pixel) near the circle (ox, oy, r): Kasa's
// algebraic fit over them. Coordinates relative to the old centre keep the sums well scaled.
bool RefineCircle(const uint8_t* codes, uint32_t len, const ImageBorder& border, float& ox,
                  float& oy, float& r) {
  const Ring ring = RingOf(r);
  CircleSums sums;
  ForEachOutlinePoint(codes, len, [&](uint32_t, int x, int y) {
    if (border.Holds(x, y)) return;
    const float px = static_cast<float>(x) - ox, py = static_cast<float>(y) - oy;
    if (!ring.Holds(px * px + py * py)) return;
    sums.Add(px, py);
  });
  double cx = 0, cy = 0, cr = 0;
  if (sums.n < 6.0f || !sums.Solve(cx, cy, cr)) return false;
  ox += static_cast<float>(cx);
  oy += static_cast<float>(cy);
  r = static_cast<float>(cr);
  return std::isfinite(ox) && std::isfinite(oy) && std::isfinite(r);
}

// Evenly spaced outline samples, relative to the start pixel.
struct OutlineSamples {
  int16_t x[kCircleSamples], y[kCircleSamples];
  int n = 0;
  int spaced = 0;  // samples drawn, border ones included (the sampling density)
};
void SampleOutline(const uint8_t* codes, uint32_t len, const ImageBorder& border,
                   OutlineSamples& s) {
  const int n = static_cast<int>(std::min<uint32_t>(len, kCircleSamples));
  int taken = 0, kept = 0;
  ForEachOutlinePoint(codes, len, [&](uint32_t j, int x, int y) {
    if (taken < n &&
        static_cast<uint64_t>(j) * static_cast<uint32_t>(n) >= static_cast<uint64_t>(taken) * len) {
      ++taken;
      if (border.Holds(x, y)) return;
      s.x[kept] = static_cast<int16_t>(x);
      s.y[kept] = static_cast<int16_t>(y);
      ++kept;
    }
  });
  s.n = kept;
  s.spaced = taken;
}

// Which circles a search allows, relative to the region's start pixel: the radius range of the
// boundary pixel centres and the centre constraint.
struct CircleWindow {
  float c_min, c_max;
  bool near;
  float near_u, near_v, near2, reach;
  bool TooFar(float ox, float oy) const {
    return near && (ox - near_u) * (ox - near_u) + (oy - near_v) * (oy - near_v) > near2;
  }
  // A sample on an allowed circle lies within reach of the predicted centre.
  bool OutOfReach(int16_t x, int16_t y) const {
    const float du = static_cast<float>(x) - near_u, dv = static_cast<float>(y) - near_v;
    return near && du * du + dv * dv > reach * reach;
  }
};
CircleWindow WindowOf(const Region& reg, const CircleSearch& search) {
  CircleWindow w;
  // Boundary pixel centres lie half a pixel inside the ball's edge. No circle is wider than the
  // region is long (a straight edge is an arc of a huge circle).
  w.c_min = search.r_min_px - 0.5f;
  w.c_max = std::min(search.r_max_px - 0.5f,
                     static_cast<float>(std::max(reg.u_max - reg.u_min, reg.v_max - reg.v_min)));
  w.near = search.max_centre_px > 0.0f;
  w.near_u = search.cu_px - static_cast<float>(reg.start_u);
  w.near_v = search.cv_px - static_cast<float>(reg.start_v);
  w.near2 = search.max_centre_px * search.max_centre_px;
  // The rest of a long merged outline starts no hypothesis.
  w.reach = search.max_centre_px + w.c_max + CircleTolerance(w.c_max);
  return w;
}

// Spacing of the three samples of a hypothesis: about 70 deg of the expected circle (every
// start), or a sixth and a third of the outline (16 starts; points a sixth apart still lie on a
// ball that is a third of a merged outline).
struct Spacing {
  int spans[2], steps[2];
};
Spacing HypothesisSpacing(const CircleSearch& search, uint32_t len, int n) {
  Spacing sp;
  if (search.expected_radius_px > 0.0f) {
    const float codes_per_sample = static_cast<float>(len) / static_cast<float>(n);
    sp.spans[0] =
        std::clamp(static_cast<int>(0.6f * search.expected_radius_px / codes_per_sample + 0.5f), 1,
                   std::max(1, n / 6));
    sp.spans[1] = std::min(2 * sp.spans[0], std::max(1, n / 3));
    sp.steps[0] = 1;
    sp.steps[1] = 2;
  } else {
    sp.spans[0] = std::max(2, n / 12);
    sp.spans[1] = std::max(3, n / 6);
    sp.steps[0] = sp.steps[1] = std::max(1, n / 16);
  }
  return sp;
}

// Score: the longest run of consecutive samples on the circle (round the closed outline). An arc
// is one run; a large circle through scattered outline points collects short ones.
inline int LongestArc(const OutlineSamples& s, float ox, float oy, const Ring& ring) {
  const int n = s.n;
  int run = 0, lead = -1, count = 0;
  for (int k = 0; k < n; ++k) {
    const float dx = static_cast<float>(s.x[k]) - ox, dy = static_cast<float>(s.y[k]) - oy;
    const float z = dx * dx + dy * dy;
    if (ring.Holds(z)) {
      count = std::max(count, ++run);
    } else {
      if (lead < 0) lead = run;
      run = 0;
    }
  }
  return lead < 0 ? n : std::max(count, lead + run);  // n: every sample on it
}

// The best of the circles through three samples the window allows, by LongestArc.
struct ScoredCircle {
  int score = 0;
  float x = 0, y = 0, r = 0;
};
ScoredCircle BestThreePointCircle(const OutlineSamples& s, const CircleWindow& w,
                                  const Spacing& sp) {
  const int n = s.n;
  ScoredCircle best;
  for (int h = 0; h < 2; ++h) {
    const int span = sp.spans[h];
    for (int j = 0; j < n; j += sp.steps[h]) {
      const int b = (j + span) % n, c = (j + 2 * span) % n;
      if (w.OutOfReach(s.x[j], s.y[j]) || w.OutOfReach(s.x[c], s.y[c])) continue;
      float ox, oy, r2;
      if (!Circumcircle(s.x[j], s.y[j], s.x[b], s.y[b], s.x[c], s.y[c], ox, oy, r2)) continue;
      const float r = std::sqrt(r2);
      if (r < w.c_min || r > w.c_max || w.TooFar(ox, oy)) continue;
      const int count = LongestArc(s, ox, oy, RingOf(r));
      if (count > best.score) {
        best.score = count;
        best.x = ox;
        best.y = oy;
        best.r = r;
      }
    }
  }
  return best;
}

// Support of the circle (bx, by, br): the sectors around the centre that hold outline points on
// it (mask), and how many points do (on).
uint32_t SupportSectors(const uint8_t* codes, uint32_t len, const ImageBorder& border, float bx,
                        float by, float br, uint32_t& on) {
  const Ring ring = RingOf(br);
  uint32_t mask = 0;
  on = 0;
  ForEachOutlinePoint(codes, len, [&](uint32_t, int x, int y) {
    if (border.Holds(x, y)) return;
    const float dx = static_cast<float>(x) - bx, dy = static_cast<float>(y) - by;
    if (!ring.Holds(dx * dx + dy * dy)) return;
    mask |= 1u << Sector(dx, dy);
    ++on;
  });
  return mask;
}

// The sectors whose middle lies inside the image (a margin of one pixel), for a circle in image
// coordinates; all of them when the image is unknown. The middle direction inverts Sector's
// diamond angle.
int SectorsInside(const CircleSearch& search, float cu, float cv, float r) {
  if (search.image_width <= 0 || search.image_height <= 0) return kCircleSectors;
  const float w = static_cast<float>(search.image_width) - 1.5f;
  const float h = static_cast<float>(search.image_height) - 1.5f;
  int inside = 0;
  for (int k = 0; k < kCircleSectors; ++k) {
    const float a = (static_cast<float>(k) + 0.5f) * 4.0f / static_cast<float>(kCircleSectors);
    const int q = static_cast<int>(a);
    const float f = a - static_cast<float>(q);
    const float dx = q == 0 ? 1.0f - f : q == 1 ? -f : q == 2 ? f - 1.0f : f;
    const float dy = q == 0 ? f : q == 1 ? 1.0f - f : q == 2 ? -f : f - 1.0f;
    const float n = std::hypot(dx, dy);
    const float u = cu + r * dx / n, v = cv + r * dy / n;
    inside += u >= 0.5f && v >= 0.5f && u <= w && v <= h;
  }
  return inside;
}

// The arc a fit must span, given the sectors inside the image (SectorsInside): min_sectors, or
// for a circle cut by the image border those inside but one (at least kMinCutSectors).
int NeededSectors(const CircleSearch& search, int inside) {
  if (inside >= kCircleSectors) return search.min_sectors;
  return std::min(search.min_sectors, std::max(kMinCutSectors, inside - 1));
}
}  // namespace

bool RegionSetBase::FitCircle(size_t i, const CircleSearch& search, CircleFit& out) const {
  out = CircleFit{};
  if (i >= size_) return false;
  const Region& reg = regions_[i];
  const uint32_t len = reg.chain_length;
  if (reg.hole || len < 12) return false;
  const uint8_t* codes = chain_ + reg.chain_offset;
  const ImageBorder border = BorderOf(reg, search.image_width, search.image_height);
  OutlineSamples samples;
  SampleOutline(codes, len, border, samples);
  const int n = samples.n;
  const CircleWindow window = WindowOf(reg, search);
  const ScoredCircle best =
      BestThreePointCircle(samples, window, HypothesisSpacing(search, len, n));
  float bx = best.x, by = best.y, br = best.r;
  const float su = static_cast<float>(reg.start_u), sv = static_cast<float>(reg.start_v);
  // The best run must be most of the samples the arc needed would hold (a chain step is ~1.1 px);
  // otherwise no refinement is spent on it.
  const int needed = NeededSectors(search, SectorsInside(search, su + bx, sv + by, br));
  const float arc_samples = 6.2832f * br * static_cast<float>(needed) /
                            static_cast<float>(kCircleSectors) *
                            static_cast<float>(samples.spaced) / (1.1f * static_cast<float>(len));
  if (best.score < 4 || static_cast<float>(best.score) < 0.6f * arc_samples) return false;
  for (int it = 0; it < 2; ++it) {
    if (!RefineCircle(codes, len, border, bx, by, br)) return false;
  }
  if (br < window.c_min || br > window.c_max || window.TooFar(bx, by)) return false;
  uint32_t on = 0;
  const uint32_t mask = SupportSectors(codes, len, border, bx, by, br, on);
  out.cu_px = su + bx;
  out.cv_px = sv + by;
  out.radius_px = br + 0.5f;
  out.sectors = LongestRun(mask);
  const int inside = SectorsInside(search, out.cu_px, out.cv_px, br);
  out.border_sectors = kCircleSectors - inside;
  out.on_circle = static_cast<float>(on) / static_cast<float>(len);
  // A short arc is no evidence of a circle: any ragged speck curves like one over ten pixels.
  return out.sectors >= NeededSectors(search, inside) && on >= kMinArcPoints;
}

size_t RegionSetBase::CirclePoints(size_t i, int image_width, int image_height,
                                   std::span<int16_t> u, std::span<int16_t> v) const {
  if (i >= size_ || regions_[i].arc_sectors == 0 || u.size() != v.size() || u.empty()) return 0;
  const Region& reg = regions_[i];
  const ImageBorder border = BorderOf(reg, image_width, image_height);
  const float br = std::sqrt(reg.area_px / 3.14159265f) - 0.5f;  // boundary pixel centres
  const float bx = reg.cu_px - static_cast<float>(reg.start_u);
  const float by = reg.cv_px - static_cast<float>(reg.start_v);
  const Ring ring = RingOf(br);
  const uint32_t len = reg.chain_length;
  const uint32_t stride = std::max<uint32_t>(1, len / static_cast<uint32_t>(u.size()));
  size_t n = 0;
  ForEachOutlinePoint(chain_ + reg.chain_offset, len, [&](uint32_t j, int x, int y) {
    if (n >= u.size() || j % stride != 0 || border.Holds(x, y)) return;
    const float dx = static_cast<float>(x) - bx, dy = static_cast<float>(y) - by;
    if (!ring.Holds(dx * dx + dy * dy)) return;
    u[n] = static_cast<int16_t>(reg.start_u + x);
    v[n] = static_cast<int16_t>(reg.start_v + y);
    ++n;
  });
  return n;
}

void RegionSetBase::SetCircle(size_t i, const CircleFit& fit) {
  if (i >= size_) return;
  Region& r = regions_[i];
  r.cu_px = fit.cu_px;
  r.cv_px = fit.cv_px;
  r.area_px = 3.14159265f * fit.radius_px * fit.radius_px;
  r.arc_sectors = static_cast<uint8_t>(std::min(kCircleSectors, fit.sectors + fit.border_sectors));
}

}  // namespace bv
