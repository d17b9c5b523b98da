#pragma once
// Precomputed scan patterns: the pixels the front end reads. Built once at start-up into a
// fixed-capacity, row-major sample table (one byte a sample plus a 4 KB row index).
//   omni:  radial lines from the image centre, more lines and shorter steps further out where
//          the ball is smaller; the robot body (inner radius) and the strut sectors are skipped.
//   persp: a brick lattice of rows (alternate rows shifted by half a step).
// Spacing follows the smallest ball diameter expected at each radius (or row band): every disc
// of that diameter has the centre of at least one scan pixel inside it (host_tests/scanline_test).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>

#include "core/color_lut/color_lut.h"
#include "core/common/status.h"

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#endif

namespace bv {

/// Smallest ball diameter (px) expected at an image radius (omni) or row (persp), as a
/// piecewise-linear profile; beyond the ends the end values hold.
struct DiameterProfile {
  static constexpr int kMaxPoints = 8;
  float at_px[kMaxPoints] = {};        // radius (omni) or row v (persp), increasing
  float diameter_px[kMaxPoints] = {};  // >= 2
  int count = 0;
  float At(float x) const;
};

struct StrutSector {
  float angle_deg = 0;       // image angle atan2(v - cv, u - cu), degrees, v down
  float half_width_deg = 0;  // lines within this half width are not scanned
};

/// Dense radial lines for the field features (core/field): `rays` lines at equal angles (a power
/// of two, so they coincide with radial lines of the ball pattern), sampled from the inner radius
/// out to `end_radius_px` with a step that grows linearly from `step_inner_px` to `step_outer_px`
/// (rounded to whole pixels). Their samples join the table, so the ball front end and the feature
/// extractor read the same pixels; rays = 0 adds nothing.
struct OmniFeatureRays {
  static constexpr int kMaxRays = 64;
  static constexpr int kMaxRadii = 192;
  int rays = 0;
  float end_radius_px = 0;
  float step_inner_px = 2.0f, step_outer_px = 1.0f;
};

struct OmniScanConfig {
  static constexpr int kMaxStruts = 8;
  float center_u = 0, center_v = 0;  // from OmniCalibration::center_u/v
  float inner_radius_px = 0;         // robot's own body
  float outer_radius_px = 0;         // mirror rim
  StrutSector struts[kMaxStruts];
  int strut_count = 0;
  DiameterProfile diameter;  // default when count == 0: 4 px everywhere
  float margin_px = 0.5f;    // rounding allowance in the spacing rule
  OmniFeatureRays features;
};

/// The sample radii of every feature ray (px from the centre, increasing). Returns the count, or
/// -1 if the ray set is invalid (rays not a power of two <= kMaxRays (64), more than kMaxRadii
/// radii, a centre or end radius beyond 2047 px: the fixed-point walk's range).
int OmniFeatureRadii(const OmniScanConfig& config, float* radii, int capacity);
/// Feature ray i's image angle (radians, v down): 2 pi i / rays, or, when that lies in a mask
/// sector, just outside the sector's edge on its own side: a strut hides a few degrees of the
/// view, not a whole ray's share of it (an obstacle right behind it is still seen beside it).
float OmniFeatureRayAngle(const OmniScanConfig& config, int ray);
/// True if feature ray i cannot be moved out of the mask sectors within half a ray step.
bool OmniFeatureRayBlocked(const OmniScanConfig& config, int ray);
/// Fixed-point walk along feature ray i: pixel of radius r (1/16 px) = floor(centre + 0.5 + r *
/// (cos, sin)), in integers so the table build and every reader get the same pixels, and the
/// per-sample cost is two multiply-adds (the feature pass's hot loop).
struct OmniRayQ {
  int32_t u0_q18 = 0, v0_q18 = 0;  // centre + 0.5, Q18
  int32_t cs_q14 = 0, sn_q14 = 0;  // direction, Q14
};
OmniRayQ MakeOmniRay(const OmniScanConfig& config, int ray);
inline void OmniRayPixel(const OmniRayQ& q, int32_t r_q4, int& u, int& v) {
  u = (q.u0_q18 + r_q4 * q.cs_q14) >> 18;  // arithmetic shift: floor for negative values too
  v = (q.v0_q18 + r_q4 * q.sn_q14) >> 18;
}
inline int32_t RadiusQ4(float r) { return static_cast<int32_t>(std::lround(r * 16.0f)); }

struct PerspScanConfig {
  DiameterProfile diameter;          // over image rows; default when count == 0: 8 px everywhere
  int first_row = 0, last_row = -1;  // -1: last image row
};

/// Reference-rig defaults (render/README.md; rig.json): mirror circle, body radius and struts
/// measured on omni_selfmask.png, ball diameters from the rendered truth. The centre must still
/// come from the calibration when one exists.
OmniScanConfig ReferenceOmniScanConfig(float center_u, float center_v);
PerspScanConfig ReferencePerspScanConfig();

class ScanlineTableBase {
 public:
  static constexpr int kMaxRows = 1024;

  /// Errors: kInvalidArgument (bad geometry/profile),
  /// kResourceExhausted (more samples than the capacity; the table is left empty).
  Status BuildOmni(const OmniScanConfig& config, int width, int height);
  Status BuildPersp(const PerspScanConfig& config, int width, int height);

  uint32_t pixel_count() const { return pixels_; }
  int width() const { return width_; }
  int height() const { return height_; }
  bool built() const { return pixels_ > 0; }
  size_t capacity() const { return capacity_; }

  /// Every sample, top to bottom: row(v) once per row with samples, then sample(u, restart) for
  /// each of its samples left to right; `restart` is true for a row's first sample and after a gap
  /// of more than 255 px.
  template <typename RowFn, typename SampleFn>
  void ForEachSample(RowFn&& row, SampleFn&& sample) const {
    for (int v = 0; v < height_; ++v) {
      if (row_start_[v] == row_start_[v + 1]) continue;
      row(v);
      const uint8_t* prev = nullptr;
      ForEachInRow(v, [&](int u, const uint8_t* after) {
        sample(u, prev != after - 1);
        prev = after;
      });
    }
  }

  /// Where a resumable read of the table stands (ReadSamples); a default one is at the start.
  struct Cursor {
    int v = 0;           // row of the next sample
    uint32_t entry = 0;  // table entry past the next sample's (valid while in_row)
    int u = 0;           // column of the next sample (valid while in_row)
    bool in_row = false;
  };
  /// Up to `max` samples from `cursor` on, in ForEachSample order (row-major): fn(u, v) each;
  /// returns how many (0 at the end). Lets a reader walk the table piecewise (a capture streams
  /// it chunk by chunk) without starting over.
  template <typename Fn>
  size_t ReadSamples(Cursor& c, size_t max, Fn&& fn) const {
    size_t n = 0;
    while (n < max && c.v < height_) {
      if (!c.in_row) {
        if (row_start_[c.v] == row_start_[c.v + 1]) {
          ++c.v;
          continue;
        }
        c.entry = row_start_[c.v] + 1u;
        c.u = row_first_u_[c.v];
        c.in_row = true;
      }
      fn(c.u, c.v);
      ++n;
      if (c.entry == row_start_[c.v + 1]) {  // the row's last sample (decoded as ForEachInRow)
        c.in_row = false;
        ++c.v;
        continue;
      }
      c.u += StepAt(c.entry);
    }
    return n;
  }

  /// The front end's hot loop over a YUYV frame: for every sample, the 4 bytes of its pixel pair
  /// (Y0 U Y1 V, read as one little-endian word) go to keep(word); for the kept ones
  /// hit(u, v, word, follows) is called, `follows` being true when the sample before it in the same
  /// row (no escape between) was kept too. No per-sample state is written for the samples that are
  /// not kept (most of them), which is what makes this loop cheap. Each sample also hints the cache
  /// at its column about kPrefetchSampledRows sampled rows below (a cold frame; a hint never
  /// faults, and the address is formed as an integer): rows a sparse table skips are not fetched.
  template <typename KeepFn, typename HitFn>
  void ForEachKeptPair(const uint8_t* data, int stride, KeepFn&& keep, HitFn&& hit) const {
    static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "pair word is read little-endian");
    const uintptr_t ahead = static_cast<uintptr_t>(lead_rows_) * static_cast<uintptr_t>(stride);
    for (int v = 0; v < height_; ++v) {
      const uint8_t* const row = data + static_cast<ptrdiff_t>(v) * stride;
      const uintptr_t row_ahead = reinterpret_cast<uintptr_t>(row) + ahead;
      const uint8_t* kept = nullptr;  // `after` of the last kept sample of this row
      ForEachInRow(v, [&](int u, const uint8_t* after) {
        const auto offset = static_cast<uintptr_t>(u >> 1) * 4u;
        __builtin_prefetch(reinterpret_cast<const void*>(row_ahead + offset));
        uint32_t word;
        std::memcpy(&word, row + offset, sizeof word);
        if (__builtin_expect(keep(word), 0)) {
          hit(u, v, word, kept == after - 1);
          kept = after;
        }
      });
    }
  }

  /// ForEachKeptPair keeping the words inside `box` (PairChromaTest::Holds): the same calls in the
  /// same order. On x86-64 hosts with AVX2, 16 samples a step (KeptPairsAvx2): the host spent
  /// most of the front end's time decoding, hinting and branching sample by sample. Elsewhere (the
  /// M7 tests a word in two instructions already) it is the loop above.
  template <typename HitFn>
  void ForEachKeptPair(const uint8_t* data, int stride, const PairChromaTest& box,
                       HitFn&& hit) const {
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
    if (HostHasAvx2()) {
      KeptPairsAvx2(data, stride, box, hit);
      return;
    }
#endif
    ForEachKeptPair(
        data, stride, [&box](uint32_t w) { return box.Holds(w); }, hit);
  }

  /// Sampled rows ahead at which ForEachKeptPair hints the cache.
  static constexpr int kPrefetchSampledRows = 8;

 protected:
  // `words` holds `capacity` bytes of table (as uint16_t, so that the build can use the unwritten
  // tail as its row buffer; the table itself is written through a byte pointer, which may alias
  // it).
  ScanlineTableBase(uint16_t* words, size_t capacity)
      : delta_(reinterpret_cast<uint8_t*>(words)),
        words_(words),
        capacity_(capacity),
        word_count_(capacity / 2) {}

 private:
  // The one decoder of the table: fn(u, after) for each sample of row v, left to right, `after`
  // pointing past the sample's entry (two samples are neighbours exactly when the later one's is
  // the earlier one's + 1; an escape between breaks that). Storage: per row the first u, then one
  // byte per sample, the step from the previous one; a 0 step after the first is an escape
  // (advance 255, read nothing), always followed by a sample (AppendRow).
  template <typename Fn>
  void ForEachInRow(int v, Fn&& fn) const {
    const uint8_t* p = delta_ + row_start_[v];
    const uint8_t* const end = delta_ + row_start_[v + 1];
    if (p == end) return;
    int u = row_first_u_[v];
    for (++p;;) {
      fn(u, static_cast<const uint8_t*>(p));
      if (p == end) break;
      uint32_t step = *p++;
      if (__builtin_expect(step == 0, 0)) {
        do {
          u += 255;
          step = *p++;
        } while (step == 0);
      }
      u += static_cast<int>(step);
    }
  }
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
  static bool HostHasAvx2() {
    static const bool has = __builtin_cpu_supports("avx2");
    return has;
  }
  // The vector form of ForEachKeptPair. Where a row has 16 more samples with no escape between,
  // their columns are the prefix sums of 15 step bytes (one load), their pair words are gathered
  // and tested 8 at a time, and the cache is hinted at 4 of them (a line holds several); the rest
  // go one by one as in ForEachInRow.
  template <typename HitFn>
  __attribute__((target("avx2"))) void KeptPairsAvx2(const uint8_t* data, int stride,
                                                     const PairChromaTest& box, HitFn& hit) const {
    const __m256i lo = _mm256_set1_epi32(static_cast<int>(box.lo()));
    const __m256i hi = _mm256_set1_epi32(static_cast<int>(box.hi()));
    const __m256i zero = _mm256_setzero_si256();
    const __m128i not_first =
        _mm_set_epi8(-1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, 0);
    const __m256i pair_mask = _mm256_set1_epi32(~1);
    const __m256i last_of_low =
        _mm256_set_epi8(15, 14, 15, 14, 15, 14, 15, 14, 15, 14, 15, 14, 15, 14, 15, 14, 15, 14, 15,
                        14, 15, 14, 15, 14, 15, 14, 15, 14, 15, 14, 15, 14);
    const uintptr_t ahead = static_cast<uintptr_t>(lead_rows_) * static_cast<uintptr_t>(stride);
    alignas(32) int32_t offset[16];
    alignas(32) uint16_t column[16];
    for (int v = 0; v < height_; ++v) {
      uint32_t p = row_start_[v];  // `after` of the next sample (as in ForEachInRow)
      const uint32_t end = row_start_[v + 1];
      if (p == end) continue;
      const uint8_t* const row = data + static_cast<ptrdiff_t>(v) * stride;
      const uintptr_t row_ahead = reinterpret_cast<uintptr_t>(row) + ahead;
      uint32_t kept = ~0u;  // `after` of the last kept sample of this row
      int u = row_first_u_[v];
      ++p;
      for (;;) {
        bool block = false;
        if (p + 15 <= end) {
          // Byte i (1..15) is the step to sample i of the block; byte 0 is not ours.
          const __m128i steps = _mm_and_si128(
              _mm_loadu_si128(reinterpret_cast<const __m128i*>(delta_ + p - 1)), not_first);
          const auto escapes =
              static_cast<uint32_t>(_mm_movemask_epi8(_mm_cmpeq_epi8(steps, _mm_setzero_si128())));
          if (escapes == 1u) {
            __m256i x = _mm256_cvtepu8_epi16(steps);  // prefix sums, 16-bit lanes
            x = _mm256_add_epi16(x, _mm256_slli_si256(x, 2));
            x = _mm256_add_epi16(x, _mm256_slli_si256(x, 4));
            x = _mm256_add_epi16(x, _mm256_slli_si256(x, 8));
            const __m256i carry = _mm256_shuffle_epi8(x, last_of_low);  // lane 7, per half
            x = _mm256_add_epi16(x, _mm256_permute2x128_si256(carry, carry, 0x08));
            x = _mm256_add_epi16(x, _mm256_set1_epi16(static_cast<int16_t>(u)));
            const __m256i u0 = _mm256_cvtepu16_epi32(_mm256_castsi256_si128(x));
            const __m256i u1 = _mm256_cvtepu16_epi32(_mm256_extracti128_si256(x, 1));
            const __m256i at0 = _mm256_slli_epi32(_mm256_and_si256(u0, pair_mask), 1);
            const __m256i at1 = _mm256_slli_epi32(_mm256_and_si256(u1, pair_mask), 1);
            _mm256_store_si256(reinterpret_cast<__m256i*>(offset), at0);
            _mm256_store_si256(reinterpret_cast<__m256i*>(offset + 8), at1);
            for (int k = 0; k < 16; k += 5) {
              __builtin_prefetch(reinterpret_cast<const void*>(row_ahead + offset[k]));
            }
            const int* const base = reinterpret_cast<const int*>(row);
            const __m256i w0 = _mm256_i32gather_epi32(base, at0, 1);
            const __m256i w1 = _mm256_i32gather_epi32(base, at1, 1);
            const __m256i out0 =
                _mm256_or_si256(_mm256_subs_epu8(lo, w0), _mm256_subs_epu8(w0, hi));
            const __m256i out1 =
                _mm256_or_si256(_mm256_subs_epu8(lo, w1), _mm256_subs_epu8(w1, hi));
            uint32_t mask =
                static_cast<uint32_t>(
                    _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(out0, zero)))) |
                static_cast<uint32_t>(
                    _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(out1, zero))))
                    << 8;
            _mm256_store_si256(reinterpret_cast<__m256i*>(column), x);
            while (__builtin_expect(mask != 0, 0)) {
              const int k = __builtin_ctz(mask);
              mask &= mask - 1u;
              uint32_t word;
              std::memcpy(&word, row + offset[k], sizeof word);
              hit(static_cast<int>(column[k]), v, word, kept == p + static_cast<uint32_t>(k) - 1u);
              kept = p + static_cast<uint32_t>(k);
            }
            p += 15;  // the block's last sample
            u = column[15];
            block = true;
          }
        }
        if (!block) {
          const auto at = static_cast<uintptr_t>(u >> 1) * 4u;
          __builtin_prefetch(reinterpret_cast<const void*>(row_ahead + at));
          uint32_t word;
          std::memcpy(&word, row + at, sizeof word);
          if (__builtin_expect(box.Holds(word), 0)) {
            hit(u, v, word, kept == p - 1u);
            kept = p;
          }
        }
        if (p == end) break;
        u += StepAt(p);
      }
    }
  }
#endif
  // The column step from the sample whose entry ends at `entry` to the next one, escapes (0, 255
  // more) included; `entry` moves past the next sample's entry (ForEachInRow's decoding, by index).
  int StepAt(uint32_t& entry) const {
    int advance = 0;
    uint32_t step = delta_[entry++];
    while (__builtin_expect(step == 0, 0)) {
      advance += 255;
      step = delta_[entry++];
    }
    return advance + static_cast<int>(step);
  }
  // The build's buffer for one row's sample columns: the table's unwritten tail.
  uint16_t* RowBuffer(int& room) const;
  // lead_rows_ from the finished table.
  void SetPrefetchLead();
  // Moves row v's m sorted, unique columns (in RowBuffer()) to the end of the tail, where the row's
  // own entries cannot reach them, and appends them; kResourceExhausted when the table is full.
  Status AppendBufferedRow(int v, int m);
  // Appends row v from `us` (sorted, unique); kResourceExhausted on overflow.
  Status AppendRow(int v, const uint16_t* us, int n);
  void Reset(int width, int height);

  uint8_t* delta_;
  uint16_t* words_;
  size_t capacity_;
  size_t word_count_;
  uint32_t pixels_ = 0;  // samples read per frame
  uint32_t used_ = 0;    // table entries (samples + escapes)
  uint16_t row_start_[kMaxRows + 1] = {};
  uint16_t row_first_u_[kMaxRows] = {};
  int lead_rows_ = 0;  // rows spanned by kPrefetchSampledRows sampled rows (ForEachKeptPair)
  int width_ = 0, height_ = 0;
};

/// Samples stored row-major (one byte each: the step from the previous sample in the row), so
/// a frame is read top to bottom like a DMA buffer: the cache and prefetcher see a stream,
/// where radial order would touch a new row (and page) at almost every sample.
template <size_t kMaxPixels>
class ScanlineTable : public ScanlineTableBase {
  static_assert(kMaxPixels > 0 && kMaxPixels <= 65535);

 public:
  // storage_ is filled by Build() before any read; the base tracks how much is valid.
  // cppcheck-suppress uninitMemberVar
  ScanlineTable() : ScanlineTableBase(storage_, kMaxPixels) {}
  ScanlineTable(const ScanlineTable&) = delete;
  ScanlineTable& operator=(const ScanlineTable&) = delete;

 private:
  uint16_t storage_[(kMaxPixels + 1) / 2];
};

inline constexpr size_t kOmniScanPixels = 32000;   // 32 KB (+ 4 KB row index), in external RAM
inline constexpr size_t kPerspScanPixels = 16384;  // 16 KB (+ 4 KB row index)
// Earlier names of the two capacities (core/pipeline.h uses them).
inline constexpr size_t kOmniScanSegments = kOmniScanPixels;
inline constexpr size_t kPerspScanSegments = kPerspScanPixels;
inline constexpr size_t kOmniScanLines = kOmniScanPixels;
inline constexpr size_t kPerspScanLines = kPerspScanPixels;

/// Calls fn(u, v) for every sample of the table, row-major.
template <typename Fn>
void ForEachScanPixel(const ScanlineTableBase& t, Fn&& fn) {
  int row_v = 0;
  t.ForEachSample([&row_v](int v) { row_v = v; }, [&](int u, bool) { fn(u, row_v); });
}

}  // namespace bv
