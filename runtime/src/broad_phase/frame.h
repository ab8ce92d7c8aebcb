// Private: one frame of the self-collision broad phase (broad_phase.h has the contract): the
// job's inputs, the context's state (broad_phase/context_state.h), and the steps of a frame, each
// part in the file named beside it. broad_phase_job.cc runs them:
//   1. values: every centre and radius finite, within ±kMaxMagnitude, radii >= 0; centres summed;
//   2. a space of several characters runs by character (character_groups.cc);
//   3. the candidate cache's check (candidate_cache.cc: CacheHolds);
//   4. otherwise a build (candidate_cache.cc: Build; sweep.cc above kAllPairsMax spheres), with the
//      lookahead adapted to the counted work (lookahead.cc), or, when no cache fits or pays, all
//      sphere pairs straight into the output (direct.cc);
//   5. the exact sphere test on the candidates (TestCache): the sphere pairs come out sorted.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>

#include "broad_phase/context_state.h"
#include "broad_phase/kernels.h"
#include "simd/float4.h"
#include "skinspheres/runtime/broad_phase/broad_phase.h"

namespace skinspheres::runtime::broad_phase {

inline constexpr size_t kAllPairsMax = BroadPhaseContext::kAllPairsMax;
inline constexpr size_t kPad = kernels::kMaxWidth;
inline constexpr size_t kStage = 512;                          // sphere pairs staged before the output
inline constexpr float kGrow = 1.0f + 1.0f / 65536.0f;         // grown radius factor of a build
inline constexpr float kAllowFactor = 1.0f - 1.0f / 65536.0f;  // of the skin, for the cache check
inline constexpr float kSlackRelative = 1.0f / 1048576.0f;     // 2^-20 of |shift|_inf
inline constexpr float kPadRelative = 1.0f / 262144.0f;        // 2^-18: sweep interval pad
inline constexpr float kPadAbsolute = 0x1p-60f;                // spheres closer than ~2^-75 touch whatever
                                                               // their radii (the squares underflow)
inline constexpr float kSkinMin = 0x1p-60f;                    // skins^2 stay normal floats
inline constexpr float kSkinFloorRelative = 1.0f / 64.0f;      // of the radius: the skin of a still sphere
// The lookahead ladder (skin = lookahead x speed per frame; rung 0: no cache, all pairs straight
// into the output) and the work units of its cost model,
// roughly nanoseconds x 2 on a current x86 core: per sphere for the cache check, per candidate
// for its exact test, per sphere for a build's set-up (all pairs / sweep), per pair test of a
// build, per pair a build keeps.
inline constexpr int kRungs = 8;
inline constexpr float kLookahead[kRungs] = {0.0f, 0.0f, 1.25f, 2.0f, 3.0f, 4.5f, 7.0f, 11.0f};  // rung 0: no cache
inline constexpr double kRungFadePerFrame = 0.99;
inline constexpr double kCheckWork = 5.0;
inline constexpr double kTestWork = 1.5;
inline constexpr double kAllPairsSphereWork = 10.0;
inline constexpr double kSweepSphereWork = 40.0;
inline constexpr double kPairTestWork = 0.3;
inline constexpr double kPairWork = 6.0;
inline constexpr double kCellMargin = 1.0 + 1.0 / 256.0;  // strips are (2 max grown r)(1 + 2^-8) wide
inline constexpr double kSweepCallCost = 48.0;            // one sweep call, in interval tests
inline constexpr size_t kGroupsCrossMax = 16;             // pairs between characters per sphere, at most
inline constexpr uint32_t kGroupsPause = 64;              // frames as one set when they were more
// Per-sphere float arrays of the build (BuildScratch::soa): 0..3 x, y, z, grown radius and
// 4..5 interval start and end, in the order the kernel reads (index or sweep order); then, in
// index order, the grown radii and the interval starts.
inline constexpr int kGrown = 6;
inline constexpr int kStartByIndex = 7;
inline constexpr int kSoaFields = 8;

inline kernels::FilterView View(const PairFilter& f) {
  kernels::FilterView v;
  v.row_begin = f.row_begin();
  v.partners = f.partners();
  v.groups = f.groups();
  v.parts = f.parts().data();
  v.within = f.pairs_within_groups();
  v.between = f.pairs_between_groups();
  return v;
}

// Words per bit row of the listed exclusions for the all-pairs kernels (FilterView::row_bits): bits
// up to n + kMaxWidth readable.
inline size_t AllPairsRowWords(size_t n) { return (n + kernels::kMaxWidth) / 64 + 1; }

inline bool NoPairAllowed(const PairFilter& f) {
  return !f.pairs_within_groups() && (f.groups() == nullptr || !f.pairs_between_groups());
}

// Order-preserving bits of a float (not NaN): unsigned order of the result = float order.
inline uint32_t OrderBits(float f) {
  const uint32_t u = std::bit_cast<uint32_t>(f);
  return (u & 0x80000000u) != 0 ? ~u : (u | 0x80000000u);
}

inline bool ByPair(const SpherePair& p, const SpherePair& q) {
  return p.sphere_i != q.sphere_i ? p.sphere_i < q.sphere_i : p.sphere_j < q.sphere_j;
}

// A sphere's interval on the sweep axis is padded by this (relative and absolute), so that two
// spheres the exact test finds touching have overlapping intervals.
inline float IntervalPad(float c, float r) { return (std::fabs(c) + r) * kPadRelative + kPadAbsolute; }

// The sweep's layout for one build (sweep.cc, PlanSweep): the axis, the strips across the next
// axis (count 1: none), and whether the previous build's order can be resorted.
struct SweepLayout {
  int axis = 0;
  int strip_axis = 1;
  int64_t count = 1;
  double inv_cell = 0.0;
  double base = 0.0;
  bool keep_order = false;
};

class Frame {
 public:
  Frame(const BroadPhaseJob& j, const kernels::Kernels& kernels);
  // The frame (steps above). False when a value is refused (out stays empty).
  bool Run();

 private:
  const BroadPhaseJob& job;
  BroadPhaseContext::State& st;
  const kernels::Kernels& k;
  const PairFilter& filter;
  const kernels::FilterView view;
  const size_t n;
  const float* spheres;  // n x (x, y, z, r)
  size_t padded;         // n + kPad: stride of the per-sphere arrays of this frame

  const Vec4f& Sphere(size_t s) const { return job.spheres[s]; }
  float* Soa(int field) { return st.scratch.soa.data() + static_cast<size_t>(field) * padded; }

  // ---- the candidate cache (candidate_cache.cc)

  bool CacheHolds(const float sum[3]);

  // Skins for the next cache: lookahead x speed, within [floor, cap]. A sphere's speed is its
  // motion per frame since the last build, or half its previous speed if that is more (a limb
  // at the turn of a swing is about to move again); no sphere counts as slower than half the
  // set's mean (the slowest sphere would otherwise end every cache). Writes the grown radii
  // (index order) into Soa(kGrown) and the allowances.
  void Skins(bool have_motion, float lookahead);

  void CopyCentres();

  // NaN centres past the end: padding lanes of the all-pairs kernels never touch anything.
  void PadIndexOrder();

  // All pairs of grown spheres into the cache (index order: already sorted). False if it does not fit.
  bool AllPairsBuild();

  // The unsorted pairs (pi_, pj_)[0, m) into the cache, sorted by (i, j) (two counting-sort
  // passes: by j, then stably by i; the arrays then swap roles). The sweep left out every pair the
  // filter excludes.
  void SortPairsIntoCache(size_t m);

  // Pads the cache's pair arrays with valid indices for the vector reads past its end.
  void PadCache();

  // Builds the cache. False when it does not fit even without skins.
  bool Build(bool have_motion, const float sum[3]);

  void TestCache();

  // ---- the listed exclusions as bits (listed_pairs.cc)

  // The filter's listed exclusions as bit rows for the all-pairs kernels (in st.listed.bits, sized by
  // Resize for sets of up to kAllPairsMax spheres), made once per filter: the kernels then mask a
  // vector's listed pairs at once instead of walking the partner list at every vector that hits.
  kernels::FilterView AllPairsView();

  // The filter's listed exclusions as bits for the sweep (st.listed.bits, st.listed.far), made once per
  // filter: a set whose spheres overlap their listed neighbours (a fitted character) would
  // otherwise send mostly listed pairs through the sort (96% of them for a crowd of CesiumMan).
  kernels::FilterView SweepView();

  // ---- the sweep (sweep.cc)

  // Sweep order of the spheres with radii Soa(kGrown): sorted by (strip, interval start), the
  // strips cutting the axis of second largest spread (when `strips` and the cost model below
  // prefers them), gathered into Soa(0..5) and st.scratch.sphere; the strips as runs of that order.
  // Returns the run count.
  size_t Order(bool strips);
  // Its steps, in that order.
  SweepLayout PlanSweep(bool strips);
  void IntervalStarts(int axis);  // Soa(kStartByIndex)
  uint64_t SortKey(const SweepLayout& l, size_t s);
  bool SortStripRun(SortItem* src, size_t b, size_t e, size_t* moves, size_t budget);
  void SortSweepOrder(const SweepLayout& l);
  void GatherSweepOrder(int axis);
  size_t ColumnRuns();

  // Longest interval of a run of the sweep order.
  float RunLength(const ColumnRun& run);

  kernels::SoaSpheres SweepSoa();

  // Sort and sweep in strips of the spheres with radii Soa(kGrown): the pairs whose balls touch
  // and the filter allows (listed exclusions included) into (pi_, pj_). False when they do not fit.
  bool SweepBuild(size_t* pair_count);

  // The direct path's sweep (one axis, no columns: a fallback for sets too dense for any cache):
  // every touching pair the filter allows into the output, unsorted (FlushDirect leaves out the
  // listed exclusions, so the output never holds more than the frame's sphere pairs).
  void SweepDirect();

  // ---- no cache fits: sphere pairs straight into the output (direct.cc)

  // Streams the unsorted pairs (pi_, pj_)[0, m) as sphere pairs into the output (direct sweep), less
  // the listed exclusions (the sweep's view has no bits for them).
  void FlushDirect(size_t m);

  // No cache fits: sphere pairs straight into the output.
  void Direct();

  // ---- the lookahead (lookahead.cc)

  // Rung 0 (no cache: all pairs straight into the output) only for sets the all-pairs kernels take.
  int MinRung() const { return n <= kAllPairsMax ? 0 : 1; }

  // Adapts the lookahead (a rung of kLookahead) from the cost per frame of what the current rung
  // just did, in counted work (not time: the choice is deterministic). Each rung keeps a moving
  // average of its cost; the next frames take the cheapest of this rung and its two neighbours, a
  // neighbour never tried counting as a little cheaper (so it gets tried) and a neighbour's
  // memory fading towards cheap (so it is tried again when the motion changes).
  void AdaptLookahead(double cost, uint32_t frames);

  // Cost per frame of the cache that just expired.
  double ExpiredCacheCost() const;

  // ---- a space of several characters (character_groups.cc)

  // Whether the space is worth splitting: several groups of 16 or more spheres on average, and
  // more spheres than one all-pairs build takes.
  bool UseGroups() const;

  // The per-group filters and contexts, made once per filter. False if a group's filter cannot
  // be made (it can: Combine made the same rows; then the space runs as one set).
  bool SetUpGroups();

  // A sphere's box, padded as the sweep pads its intervals (two spheres that the exact test finds
  // touching have overlapping padded boxes on every axis).
  static void PaddedBox(const float* sphere, simd::native::Float4* lo, simd::native::Float4* hi);

  static bool BoxesOverlap(const float* a, const float* b);  // 8 floats each (low, high)

  // The sphere pairs between characters into st.groups.cross (sorted by (i, j)), or, with `to_out`, appended
  // to the output unsorted. Returns the candidates tested, or SIZE_MAX when st.groups.cross (room for n
  // sphere pairs, never grown) cannot hold them.
  size_t CrossGroups(bool to_out);
  // Its first steps: each character's padded box (st.groups.box), then the characters by the low
  // end of their boxes along the axis of largest spread of those ends (an insertion sort from last
  // frame's order, std::sort past 4G moves); returns that axis.
  void GroupBoxes();
  int SortGroupsByLow();

  // The whole space by groups (UseGroups, SetUpGroups done): each character's own sphere pairs, the
  // sphere pairs between characters merged in by (i, j).
  void RunGroups();
};

}  // namespace skinspheres::runtime::broad_phase
