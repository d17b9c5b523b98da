#pragma once
// Regions of one colour class, found from seed pixels by 8-connected contour following (Freeman
// chain code through the boundary pixel centres) on the classified image. Pixels are classified
// on the fly through the LUT: only the boundary and the short walk from a seed to it are read.
// Region descriptors come from the chain code alone (Green's theorem): area, perimeter, bbox,
// sub-pixel centroid, roundness. Holes (e.g. a specular highlight inside the ball) are traced
// once, kept as hole records so later seeds skip them, and are filled in the outer region's
// area and centroid.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>

#include "core/color_lut/color_lut.h"
#include "core/common/image.h"

namespace bv {

struct Region {
  int16_t start_u = 0, start_v = 0;  // first contour pixel (its left neighbour is not in class)
  int16_t u_min = 0, v_min = 0, u_max = 0, v_max = 0;  // bbox, inclusive
  bool hole = false;                                   // contour of a hole inside another region
  // 0: centre, area and radius are the region's own. Otherwise they are the circle fitted to the
  // region's outline (SetCircle), supported in this many of 16 sectors around its centre, those
  // beyond the image border counted (a cut ball's outline ends there).
  uint8_t arc_sectors = 0;
  uint16_t chain_offset = 0;  // codes in the set's chain pool
  uint16_t chain_length = 0;
  // Where the last seed check found a pixel on this contour (code index, packed position): the
  // next check starts there (RegionSetBase::OnContour).
  uint16_t walk_index = 0;
  int32_t walk_pos = 0;
  float polygon_area_px = 0;   // area enclosed by the boundary-pixel-centre polygon
  float area_px = 0;           // pixel count incl. holes: polygon + length/2 + 1 (Pick)
  float perimeter_px = 0;      // Vossepoel-Smeulders length estimate of the chain
  float cu_px = 0, cv_px = 0;  // centroid of the polygon
  float roundness = 0;         // 4*pi*polygon_area / perimeter^2, 1 for a disc, 0 for a line
  // From the boundary's support in 16 directions (circumscribed 16-gon, ~ convex hull):
  // 4*pi*area_px / hull_perimeter^2 and the narrowest / widest extent. Unlike `roundness` they
  // barely move when the outline is ragged (blur, noise, a badly trained colour class); a line
  // or an arc still scores low. Computed for outer regions of at least kHullMinArea pixels.
  float hull_roundness = 0;
  float width_ratio = 0;
};

inline constexpr float kHullMinArea = 8.0f;

/// How much a region alone says "ball": its radius (a speck is noise; beyond that, size says
/// little, a far ball is small), discounted hard for a shape that is not round (a yellow shirt of
/// hull roundness 0.68 and 2.5x the ball's area must not outweigh the ball at 0.91).
inline float ShapeEvidence(const Region& r) {
  return std::sqrt(r.area_px) * r.hull_roundness * r.hull_roundness;
}

/// The dominant circular arc of a region's outline: a ball merged with a same-coloured object
/// behind it, or partly hidden, keeps most of its own outline, whose circle gives its true centre
/// and radius where the region's centroid does not.
struct CircleFit {
  float cu_px = 0, cv_px = 0;
  float radius_px = 0;     // of the ball's pixels (boundary pixel centres + 0.5)
  int sectors = 0;         // longest run of the 16 sectors around it with outline points on it
  int border_sectors = 0;  // sectors beyond the image border (a cut ball has no outline there)
  float on_circle = 0;     // fraction of the outline's points on the circle
};
inline constexpr int kCircleSectors = 16;
inline constexpr uint32_t kMinArcPoints = 16;  // outline points on a fitted circle, at least
struct CircleSearch {
  float r_min_px = 2, r_max_px = 1000;
  // The radius expected (0: unknown). Hypotheses then span a fixed arc of that circle, wherever
  // it lies on a long merged outline; otherwise a sixth and a third of the outline.
  float expected_radius_px = 0;
  int min_sectors = 8;
  // When max_centre_px > 0: only circles centred within it of (cu_px, cv_px), the predicted ball
  // (a ball merged with a cone also has the cone's outline, which some circle fits too).
  float cu_px = 0, cv_px = 0, max_centre_px = 0;
  // The image (0: unknown). A circle cut by its border has no outline beyond it: the arc then
  // needs to span only the sectors inside (at least kMinCutSectors), not min_sectors.
  int image_width = 0, image_height = 0;
};
inline constexpr int kMinCutSectors = 4;

/// Freeman directions: 0 = +u, 2 = -v (up), 4 = -u, 6 = +v; odd codes are diagonals.
inline constexpr int kChainDu[8] = {1, 1, 0, -1, -1, -1, 0, 1};
inline constexpr int kChainDv[8] = {0, -1, -1, -1, 0, 1, 1, 1};
/// A pixel as one integer, v * kPackedRow + u (u < 4096), and the directions' steps in it.
inline constexpr int32_t kPackedRow = 8192;
inline constexpr int32_t PackedPixel(int u, int v) { return v * kPackedRow + u; }
inline constexpr int32_t kChainDp[8] = {
    PackedPixel(kChainDu[0], kChainDv[0]), PackedPixel(kChainDu[1], kChainDv[1]),
    PackedPixel(kChainDu[2], kChainDv[2]), PackedPixel(kChainDu[3], kChainDv[3]),
    PackedPixel(kChainDu[4], kChainDv[4]), PackedPixel(kChainDu[5], kChainDv[5]),
    PackedPixel(kChainDu[6], kChainDv[6]), PackedPixel(kChainDu[7], kChainDv[7])};

enum class SeedOutcome : uint8_t {
  kNewRegion,      // traced a new outer contour (regions().back())
  kAlreadyTraced,  // the seed's region was traced before: nothing traced
  kNotInClass,     // the seed pixel is not of the class (or outside the image)
  kReplaced,       // capacity reached; the new outer region replaced the weakest unprotected one
  kRegionsFull,    // capacity reached and the new region is no stronger, or no tries left
  kChainFull,      // chain-code pool exhausted (counted in overflows())
  kTooManyHoles,   // gave up after kMaxHoleHops holes between seed and outer contour
  kTooSmall,       // traced, below min_keep_area: not kept (counted in dropped_small())
};

class RegionSetBase {
 public:
  static constexpr int kMaxHoleHops = 4;

  /// Forgets all regions (start of a frame). Counters are reset too.
  void Clear();
  /// The regions traced so far are never replaced (those the prediction's attention found).
  void ProtectTraced() { protected_ = size_; }
  /// Outer regions smaller than this (area_px) are forgotten right after tracing, so clutter
  /// specks do not use up the capacity; a later seed in one traces it again (a short contour).
  void set_min_keep_area(float area_px) { min_keep_area_ = area_px; }
  /// Finds the region of `cls` containing pixel (u, v) and traces its outer contour unless it was
  /// traced before. Never reads a pixel twice per boundary step more than the 8 neighbours.
  SeedOutcome TraceSeed(const YuyvImage& img, const ColorLut& lut, ColorClass cls, int u, int v);

  std::span<const Region> regions() const { return {regions_, size_}; }
  std::span<const uint8_t> chain(const Region& r) const {
    return {chain_ + r.chain_offset, r.chain_length};
  }
  /// The circle of region `i`'s outline that `search` allows, with outline points in at least
  /// `search.min_sectors` of 16 sectors around it; false when there is none. Reads no pixels: the
  /// chain is walked a few times, at most 72 three-point hypotheses are scored on 48 samples.
  bool FitCircle(size_t i, const CircleSearch& search, CircleFit& out) const;
  /// Region `i` is described by `fit` from now on (centre, area of the disc, arc_sectors).
  void SetCircle(size_t i, const CircleFit& fit);
  /// Region `i`'s outline points (image pixels) on its circle (cu_px, cv_px, radius_px as
  /// SetCircle left it) and not on the image border, spread evenly along the outline, at most
  /// `u.size()` (= `v.size()`); returns the count. For a camera model to refine the circle.
  size_t CirclePoints(size_t i, int image_width, int image_height, std::span<int16_t> u,
                      std::span<int16_t> v) const;
  uint32_t pixels_read() const { return pixels_read_; }
  uint32_t overflows() const { return overflows_; }
  uint32_t dropped_small() const { return dropped_small_; }
  uint32_t replaced() const { return replaced_; }
  size_t capacity() const { return capacity_; }

 protected:
  RegionSetBase(Region* regions, size_t capacity, uint8_t* chain, size_t chain_capacity)
      : regions_(regions), capacity_(capacity), chain_(chain), chain_capacity_(chain_capacity) {}

 private:
  bool OnContour(Region& r, int u, int v);
  size_t Weakest() const;  // size_ when every region is protected or a hole
  // Traces from a boundary pixel; false when the chain pool overflows.
  bool Trace(const YuyvImage& img, const ColorLut& lut, ColorClass cls, int u, int v, Region& out);

  Region* regions_;
  size_t capacity_;
  uint8_t* chain_;
  size_t chain_capacity_;
  size_t size_ = 0;
  size_t chain_used_ = 0;
  uint32_t pixels_read_ = 0;
  uint32_t overflows_ = 0;
  uint32_t dropped_small_ = 0;
  float min_keep_area_ = 0;
  size_t protected_ = 0;
  uint32_t replaced_ = 0;
  bool chain_exhausted_ = false;
  bool regions_exhausted_ = false;
};

template <size_t kMaxRegions, size_t kMaxChainCodes>
class RegionSet : public RegionSetBase {
  static_assert(kMaxRegions > 0 && kMaxChainCodes > 0);
  static_assert(kMaxChainCodes <= 65535, "Region stores chain offsets and lengths in 16 bits");

 public:
  // chain_ is scratch written before it is read (the base tracks its fill); zeroing it per
  // frame would cost more than the tracing.
  // cppcheck-suppress uninitMemberVar
  RegionSet() : RegionSetBase(regions_, kMaxRegions, chain_, kMaxChainCodes) {}
  RegionSet(const RegionSet&) = delete;
  RegionSet& operator=(const RegionSet&) = delete;

 private:
  Region regions_[kMaxRegions];
  uint8_t chain_[kMaxChainCodes];
};

/// Class of pixel (u, v) through the LUT; outside the image counts as kUnknown.
inline ColorClass ClassAt(const YuyvImage& img, const ColorLut& lut, int u, int v) {
  if (static_cast<unsigned>(u) >= static_cast<unsigned>(img.width) ||
      static_cast<unsigned>(v) >= static_cast<unsigned>(img.height)) {
    return ColorClass::kUnknown;
  }
  const uint8_t* pair = img.data + static_cast<ptrdiff_t>(v) * img.stride_bytes + (u & ~1) * 2;
  return lut.Classify(pair[(u & 1) * 2], pair[1], pair[3]);
}

}  // namespace bv
