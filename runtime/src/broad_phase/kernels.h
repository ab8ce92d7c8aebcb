// Private: the broad phase's inner loops, compiled once per instruction set from one body,
// broad_phase/kernels.inc, and picked at run time (broad_phase/broad_phase_job.cc): portable
// (plain C++ over arrays of 4 floats, every platform: what aarch64 runs), and on x86-64 SSE2 (the
// baseline), AVX2 and AVX-512. Every level evaluates every test with the same float operations in
// the same order, so all levels, on all platforms, give bit-identical results.
//
// The kernel files include nothing but this header, simd/float4.h, <bit>, <cstddef>, <cstdint>
// and the intrinsics, all before any target pragma: no inline function of a shared header may be
// compiled with a wider instruction set (the linker could keep that copy for the whole program).
#pragma once

#include <bit>
#include <cstddef>
#include <cstdint>

#include "simd/float4.h"
#include "skinspheres/runtime/broad_phase/broad_phase.h"
#include "skinspheres/skinning/platform.h"

namespace skinspheres::runtime::kernels {

// Lanes of the widest level: every padded array below has this many readable entries past its end.
inline constexpr size_t kMaxWidth = 16;

// Listed exclusions as bits, for the sweep (FilterView::near): sphere i's listed partners
// j in [i - kNearRange, i + kNearRange) are bit j - i + kNearRange of its kNearWords words (64
// bytes: the sweep reads only the rows of the few spheres it tests against the others).
inline constexpr uint32_t kNearRange = 256;
inline constexpr size_t kNearWords = 2 * kNearRange / 64;

// The exclusion rules of a PairFilter as raw arrays (pair_filter.h).
struct FilterView {
  const uint32_t* row_begin = nullptr;  // n + 1
  const uint32_t* partners = nullptr;   // sorted per row
  const uint32_t* groups = nullptr;     // n, or null: one group
  const uint16_t* parts = nullptr;      // n
  bool within = true;
  bool between = true;
  // Optional (sweep_blocks only): the listed exclusions as bits, kNearWords per sphere, and per
  // sphere whether it has listed partners outside its bits (looked up in partners). When set,
  // sweep_blocks leaves out listed pairs too.
  const uint64_t* near = nullptr;
  const uint8_t* far = nullptr;
  // Optional (all_pairs_build, all_pairs_contacts): the listed exclusions as bit rows, row_words
  // words per sphere, bit j of row i set when the filter lists {i, j} (j > i); every row readable
  // up to bit n + kMaxWidth. When set, the all-pairs kernels mask listed pairs with them instead
  // of walking the partner lists.
  const uint64_t* row_bits = nullptr;
  size_t row_words = 0;
};

// Spheres in structure-of-arrays form, padded by kMaxWidth entries. In index order for the
// all-pairs kernels (padding: NaN centres, which fail every test), in sweep order for the sweep
// kernel (padding: start = +inf).
struct SoaSpheres {
  const float* x = nullptr;
  const float* y = nullptr;
  const float* z = nullptr;
  const float* r = nullptr;
  const float* start = nullptr;      // sweep only: interval start on the sweep axis, ascending per run
  const float* end = nullptr;        // sweep only: interval end
  const uint32_t* sphere = nullptr;  // sweep only: index of the sphere at this position
};

// Pair output: i[k] < j[k]; room for `capacity` pairs. A kernel that runs out of room sets full
// (the pairs written so far are kept).
struct PairSink {
  uint32_t* i = nullptr;
  uint32_t* j = nullptr;
  size_t capacity = 0;
  size_t count = 0;
  bool full = false;
};

// SpherePair output: room for `capacity` + kMaxWidth sphere pairs (kernels write whole vectors).
struct ContactSink {
  SpherePair* data = nullptr;
  size_t capacity = 0;
  size_t count = 0;
};

struct Kernels {
  // Spheres (xyz centre, w radius; n entries of 4 floats): true when every centre and radius is
  // finite and within ±limit and every radius is >= 0. sum: the centres summed (per axis,
  // in a fixed order), for the mean displacement.
  bool (*check_values)(const float* spheres, size_t n, float limit, float sum[3]);

  // The candidate cache's validity (broad_phase/broad_phase_job.cc, CacheHolds, has the bound). ref: the spheres
  // at the build as four arrays x, y, z, r, `stride` floats apart; allow: per sphere, the skin
  // times (1 - 2^-16); slack: 2^-20 |shift|_inf. Writes motion[k] = |c - c_ref - shift| +
  // max(0, r - r_ref) (approximately: for the next skins), and returns false when any sphere
  // moved or grew past its allowance. Every array is padded by kMaxWidth entries.
  bool (*check_motion)(const float* spheres, const float* ref, const float* allow, size_t n, const float shift[3],
                       float slack, size_t stride, float* motion);

  // All pairs (a, b), a < b, rows [row_begin, row_end), of the index-ordered spheres whose balls
  // touch, that the filter allows, in (a, b) order. Returns row_end when done; a smaller row when
  // the sink ran out of room (the build is then abandoned). tests += pairs tested.
  uint32_t (*all_pairs_build)(const SoaSpheres& s, uint32_t n, uint32_t row_begin, uint32_t row_end,
                              const FilterView& f, PairSink* sink, size_t* tests);

  // The same with the exact sphere test on the caller's spheres, writing sphere pairs (depth, parts):
  // only whole rows, stopping before a row when the sink has no room for n more sphere pairs; returns
  // the row to resume from after emptying the sink.
  uint32_t (*all_pairs_contacts)(const SoaSpheres& s, uint32_t n, uint32_t row_begin, uint32_t row_end,
                                 const FilterView& f, ContactSink* sink, size_t* tests);

  // Sweep, on positions of the sweep order: position a against positions b in [b_begin, b_end)
  // while start[b] <= end[a]; otherwise as sweep_runs.
  size_t (*sweep_range)(const SoaSpheres& s, uint32_t a, uint32_t b_begin, uint32_t b_end, const FilterView& f,
                        PairSink* sink);
  // Sweep in blocks of kW positions of the sweep order: every pair in run [a_begin, a_end) (when
  // b_begin == b_end), or between runs [a_begin, a_end) and [b_begin, b_end) (b_len: the
  // longest interval of the second run), that lies in two blocks whose intervals can overlap,
  // whose balls touch and whose groups the filter allows, and, when f.near is set, that the
  // filter does not list (otherwise listed pairs are left to the caller), written as (min, max)
  // sphere indices. Each pair once. Returns the number of pair tests; sets
  // sink->full (and stops; the pairs written so far stay) when the sink has no room for one more
  // block pair's kW x kW pairs.
  size_t (*sweep_blocks)(const SoaSpheres& s, uint32_t a_begin, uint32_t a_end, uint32_t b_begin, uint32_t b_end,
                         float b_len, const FilterView& f, PairSink* sink);

  // The exact sphere test on candidate pairs [begin, end) of (ci, cj) (padded by kMaxWidth valid
  // indices), spheres as n entries of 4 floats. Writes the sphere pairs in candidate order; stops
  // when the sink is full and returns where to resume (end when done).
  size_t (*test_candidates)(const float* spheres, const uint32_t* ci, const uint32_t* cj, size_t begin, size_t end,
                            const uint16_t* parts, ContactSink* sink);
};

const Kernels& PortableKernels();
#if defined(SKINSPHERES_X86_64)
const Kernels& Sse2Kernels();
const Kernels& Avx2Kernels();
const Kernels& Avx512Kernels();
#endif

}  // namespace skinspheres::runtime::kernels
