// Private: what a BroadPhaseContext (broad_phase.h) holds between frames, in named parts. Sized by
// Resize; per frame nothing here is allocated. The frame runner (broad_phase/frame.h) reads and
// writes them; each part's code lives in the file named beside it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "skinspheres/runtime/broad_phase/broad_phase.h"
#include "skinspheres/runtime/broad_phase/pair_filter.h"

namespace skinspheres::runtime::broad_phase {

// The candidate cache (candidate_cache.cc): the allowed pairs whose spheres, grown by their
// skins, touched at the build, and what the per-frame check compares with.
struct CandidateCache {
  bool valid = false;
  size_t sphere_count = 0;       // sphere count it was built for
  uint64_t filter = 0;           // PairFilter::id() it was built with
  uint32_t age = 0;              // frames since the build
  float ref_sum[3] = {0, 0, 0};  // sum of the centres at the build
  double build_cost = 0.0;       // work of the build (counted)
  size_t count = 0;              // candidates
  std::vector<uint32_t> i, j;    // max_candidates + pad: candidate pairs, sorted by (i, j)
  std::vector<float> ref;        // 4 x (max_spheres + pad): x, y, z, r at the build
  std::vector<float> allow;      // max_spheres + pad: skin (1 - 2^-16)
  std::vector<float> motion;     // max_spheres + pad: motion since the build
  std::vector<float> speed;      // max_spheres: motion per frame, as used by the last build
};

// The lookahead controller (lookahead.cc): skin = lookahead x speed, the lookahead a rung of a
// ladder adapted to the cheapest counted work per frame.
struct Lookahead {
  int rung = 2;
  double rung_cost[8] = {};  // per rung, the recent work per frame of its caches
  float last = 0.0f;         // lookahead of the latest build
};

// One entry of the sweep order: column << 32 | interval start (order-preserving bits).
struct SortItem {
  uint64_t key;
  uint32_t sphere;  // index into the job's spheres
  uint32_t from;    // while sorting: the column at the previous build
};
struct ColumnRun {
  uint32_t column, begin, end;
};

// The builds' scratch (candidate_cache.cc, sweep.cc) and the sweep order kept between builds.
struct BuildScratch {
  std::vector<float> soa;                  // 8 x (max_spheres + pad): frame.h, kSoaFields
  std::vector<uint32_t> sphere;            // max_spheres + pad: sphere at each sweep position
  std::vector<SortItem> order;             // max_spheres: sweep order (kept between builds)
  std::vector<SortItem> order_by_strip;    // max_spheres: counting sort scratch
  std::vector<ColumnRun> runs;             // max_spheres: columns in sweep order
  std::vector<uint32_t> pairs_i, pairs_j;  // max_candidates + pad (above kAllPairsMax): unsorted pairs
  std::vector<uint32_t> row;               // max_spheres + 1: counting sort
  size_t order_count = 0;                  // sphere count the order is for (0: none)
  bool order_columns = false;              // whether the order has grid columns
  int axis = -1;                           // sweep axis of the latest sweep build
  double cell = 0.0;                       // grid column size of the latest sweep build
};

// The filter's listed exclusions as bits (listed_pairs.cc): the sweep's rows around each sphere,
// or the all-pairs kernels' rows; made once per filter.
struct ListedPairBits {
  std::vector<uint64_t> bits;
  std::vector<uint8_t> far;  // max_spheres (above kAllPairsMax): has listed partners past the bits
  uint64_t filter = 0;       // PairFilter::id() the bits were made from
  size_t sphere_count = 0;   // and its size (0: not made)
};

// A space of several characters run by character (character_groups.cc): one context and filter
// per character, made on the first frame with the space's filter.
struct CharacterGroups {
  std::vector<BroadPhaseContext> contexts;
  std::vector<PairFilter> filters;
  uint64_t filter = 0;                       // PairFilter::id() they were made from (0: none)
  uint32_t pause = 0;                        // frames left to run the space as one set
  std::vector<SpherePair> out;               // one character's sphere pairs (room: its cache's)
  std::vector<SpherePair> cross;             // room for n: sphere pairs between characters, sorted by (i, j)
  std::vector<float> box;                    // 8 per character: low x, y, z, -, high x, y, z, -
  std::vector<uint32_t> order;               // characters by low x (kept between frames)
  std::vector<uint32_t> inside_a, inside_b;  // spheres of g (of h) inside the other's box
};

// Diagnostics of the last run (BroadPhaseContext's accessors).
struct LastRun {
  BroadPhaseMethod method = BroadPhaseMethod::kNone;
  size_t candidates = 0;
  size_t build_tests = 0;
  bool full_sort = false;
  uint64_t builds = 0;  // since Resize
};

}  // namespace skinspheres::runtime::broad_phase

namespace skinspheres::runtime {

struct BroadPhaseContext::State {
  size_t max_spheres = 0;
  size_t max_candidates = 0;
  broad_phase::CandidateCache cache;
  broad_phase::Lookahead lookahead;
  broad_phase::BuildScratch scratch;
  broad_phase::ListedPairBits listed;
  broad_phase::CharacterGroups groups;
  broad_phase::LastRun last;
  std::vector<SpherePair> stage;  // kStage + pad: sphere pairs before they go to the output
};

}  // namespace skinspheres::runtime
