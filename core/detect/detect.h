#pragma once
// Ball finding in one camera image (paper IV-A): LUT classification along the precomputed
// scanlines plus Monte-Carlo attention samples around the predicted position give ball-coloured
// seeds; each seed's region is traced once (core/contour); the ball is chosen by minimum
// roundness, "inside the field" (optional caller predicate) and closeness to the prediction.
// One BallFinder per camera, statically allocated; Find() never allocates.
#include <cstddef>
#include <cstdint>
#include <span>

#include "core/ball_check/ball_check.h"
#include "core/color_lut/color_lut.h"
#include "core/common/ball_state.h"
#include "core/common/image.h"
#include "core/common/status.h"
#include "core/contour/contour.h"
#include "core/scanline/scanline.h"

namespace bv {

/// Predicted image position of the ball (from the filter through the calibration).
struct Prediction {
  float u_px = 0, v_px = 0;
  float sigma_px = 8;   // 1-sigma spread of the attention samples
  float radius_px = 0;  // the ball's apparent radius there; 0 when unknown
};

/// Per-image counters of the front end.
struct FrontEndStats {
  uint32_t pixels_read = 0;  // LUT lookups: scanlines + attention + contour following
  uint32_t scan_pixels = 0;
  uint32_t attention_samples = 0;  // samples inside the image
  uint32_t seeds = 0;              // ball-coloured seeds handed to the contour stage
  uint32_t regions = 0;            // outer contours traced
  uint32_t holes = 0;              // hole contours traced
  uint32_t small = 0;              // outer contours traced but below min_area_px (not kept)
  uint32_t candidates = 0;         // regions passing area and roundness
  uint32_t overflows = 0;          // region or chain capacity reached (regions were skipped)
  uint32_t outside_field = 0;      // candidates refused as outside the field (reject mode)
  uint32_t refused_place = 0;      // candidates the size-and-place check refused
  uint32_t refused_look = 0;       // candidates the appearance classifier refused
};

/// Tells whether an image region lies inside the playing field. Supplied by the caller, who has
/// the calibration and the robot's field pose; `radius_px` (the region's equivalent radius) lets
/// it tell a ball in the air, whose ray meets the floor far beyond it, from one on the floor.
/// True when it cannot tell.
class FieldPredicate {
 public:
  virtual bool Inside(float u_px, float v_px, float radius_px) const = 0;

 protected:
  ~FieldPredicate() = default;
};

struct BallFinderConfig {
  // Shape test, either of two (core/contour): a clean outline with chain-code roundness >=
  // min_roundness (the paper's test; a ball 65 % hidden behind a robot keeps ~0.6), or a compact
  // blob with a ragged outline (motion blur, a colour class that only partly covers the ball):
  // hull_roundness >= min_hull_roundness and width_ratio >= min_width_ratio. A disc scores
  // ~0.97 / 1, half a disc 0.73 / 0.5, a 3:1 bar 0.59 / 0.33.
  float min_roundness = 0.35f;
  float min_hull_roundness = 0.6f;
  float min_width_ratio = 0.5f;
  float min_area_px = 10.0f;  // a 4 px disc covers ~12 px; smaller regions are not kept
  // A region cut by the image border must show at least a whole smallest ball (8 px across, the
  // persp scan's): below that, its shape cannot be judged (a lens-corner speck, a lamp's edge).
  float min_cut_area_px = 50.0f;
  int attention_samples = 64;  // N <= kMaxAttentionSamples
  uint32_t prng_seed = 0x2545F491u;
  const FieldPredicate* field = nullptr;  // optional; must outlive the finder
  // Circles from outlines (perspective images, where a ball is a disc): a region that is not a
  // clean disc (merged with a same-coloured object behind it, partly hidden) is described by the
  // circle of its outline when one spans at least min_arc_sectors of 16 sectors (fewer,
  // min_arc_sectors_sized, when the prediction gives the radius: the arc then only has to fix the
  // centre); such a region passes the shape test. At most kMaxCircleFits regions a frame, the
  // prediction's first.
  bool fit_circles = false;
  int min_arc_sectors = 8;
  int min_arc_sectors_sized = 5;
  // ColorLut::Bounds(kBall) of the LUT passed to Find: scanline pixels outside it are rejected
  // without a table lookup. The default box rejects nothing.
  ChromaBox ball_box;
  // The chosen ball's centre from its pixels weighted by how much of each is ball (SoftCentroid),
  // not from the binary region: a ball in the air loses its edge pixels against the green field
  // below and keeps them against the grey hall above, which moved the centroid 0.2-0.5 px up.
  bool soft_centroid = true;
  // Size, place and look (core/ball_check): a candidate either check refuses is not the ball;
  // without a prediction the others are ranked by its score. Optional; must outlive the finder.
  const BallCheck* check = nullptr;
  // Added to the classifier's logit of a candidate within 3 sigma of the prediction: the track is
  // evidence the look alone does not have, and a tracked ball half hidden behind a robot (its
  // circle fitted across the robot) or deep in shade must keep its track. The classifier decides
  // acquisition; the place check still applies.
  float tracked_logit_bonus = 1000.0f;
};

class BallFinder {
 public:
  static constexpr int kMaxAttentionSamples = 256;
  static constexpr size_t kMaxRegions = 48;
  static constexpr size_t kMaxChainCodes = 8192;
  static constexpr int kMaxCircleFits = 3;
  // SoftCentroid's window (the region's box and 2 px around it), at most this wide and high.
  static constexpr int kSoftWindow = 32;

  /// `scanlines` must outlive the finder. Errors: kFailedPrecondition (table not built),
  /// kInvalidArgument (bad config).
  Status Init(const ScanlineTableBase& scanlines, const BallFinderConfig& config);
  /// Finds at most one ball. `prediction` may be null. Always fills `out` and `stats`.
  /// Errors: kFailedPrecondition (not initialised), kInvalidArgument (frame size differs from the
  /// scanline table, null data, short stride). Overflows are counted in stats, not errors.
  Status Find(const YuyvImage& image, const ColorLut& lut, const Prediction* prediction,
              BallDetection& out, FrontEndStats& stats);

  // Debug views of the last Find (annotate, tests).
  const RegionSetBase& regions() const { return regions_; }
  int attention_count() const { return attention_count_; }
  int16_t attention_u(int i) const { return attention_u_[i]; }
  int16_t attention_v(int i) const { return attention_v_[i]; }
  int chosen_region() const { return chosen_; }  // index into regions(), -1 if none
  /// The other balls the last Find could have chosen (regions that pass the shape test, the
  /// checks and, in reject mode, the field test), largest first, at most out.size(); reads no
  /// pixels. For a choice across both cameras (core/pipeline). Confidence is the region's
  /// roundness.
  size_t Candidates(std::span<BallDetection> out) const;
  /// The balls of the last Find in the order the finder ranks them: the chosen one first, then
  /// the other candidates by their check score (by ShapeEvidence without checks), at most
  /// out.size(). Confidence is the score. Returns the count.
  size_t Ranked(std::span<BallDetection> out) const;
  /// A region as the checks see it (core/ball_check).
  static CandidateShape ShapeOf(const Region& r);
  /// Why region i of regions() was not a candidate in the last Find.
  enum class Refusal : uint8_t { kNone, kShapeOrField, kPlace, kLook };
  Refusal refusal(size_t i) const { return static_cast<Refusal>(refused_[i]); }
  /// Region i's ranking key in the last Find (the check's score, else ShapeEvidence x field
  /// context); < 0 when it was no candidate.
  float rank_key(size_t i) const { return rank_key_[i]; }
  /// While on, a candidate the in-field predicate calls outside is refused, not just disfavoured
  /// (the caller turns it on only while it trusts its field pose).
  void set_reject_outside(bool on) { reject_outside_ = on; }
  /// The LUT's ball chroma box changed (an adapted table): scanline pre-rejection follows it.
  void set_ball_box(const ChromaBox& box) { config_.ball_box = box; }

 private:
  bool Passes(const Region& r, bool& in_field) const;
  void FitCircles(const Prediction* prediction, int image_width, int image_height);
  uint32_t NextRandom();
  void Seed(const YuyvImage& image, const ColorLut& lut, int u, int v, FrontEndStats& stats);
  // Find()'s steps, in its order.
  struct Choice {  // the ball choice over the regions
    int best = -1;
    float key = 0;  // -(distance to the prediction)^2, else ShapeEvidence x field context
    bool in_field = false;
    uint32_t candidates = 0, holes = 0;
  };
  bool InsideTracedBox(int u, int v) const;
  uint32_t Attend(const YuyvImage& image, const ColorLut& lut, const Prediction* prediction,
                  FrontEndStats& stats);
  Choice ChooseBall(const YuyvImage& image, const ColorLut& lut, const Prediction* prediction,
                    FrontEndStats& stats);
  void Report(const Region& r, const Choice& choice, const Prediction* prediction,
              BallDetection& out) const;
  void SoftCentroid(const YuyvImage& image, const ColorLut& lut, const Region& r,
                    BallDetection& out) const;

  const ScanlineTableBase* scan_ = nullptr;
  BallFinderConfig config_;
  uint32_t rng_ = 1;
  RegionSet<kMaxRegions, kMaxChainCodes> regions_;
  int16_t attention_u_[kMaxAttentionSamples] = {};
  int16_t attention_v_[kMaxAttentionSamples] = {};
  int attention_count_ = 0;
  int chosen_ = -1;
  bool reject_outside_ = false;
  float rank_key_[kMaxRegions] = {};   // Ranked()'s order; < 0: not a candidate
  uint8_t refused_[kMaxRegions] = {};  // Refusal
  float chosen_u_ = 0, chosen_v_ = 0;  // the chosen ball's reported centre
};

}  // namespace bv
