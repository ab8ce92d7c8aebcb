// Self-collision broad phase: the candidate cache, its builds and its test (broad_phase.h has the
// contract; broad_phase/kernels.inc has the SIMD loops).
//
// Per frame, for n spheres:
//   1. values: every centre and radius finite, within ±kMaxMagnitude, radii >= 0; centres summed;
//   2. cache check (CacheHolds): with shift = mean centre now - mean centre at the build, every
//      sphere k satisfies |c_k - c_k,build - shift| + max(0, r_k - r_k,build) <= skin_k. Then any
//      pair touching now has |c_i,b - c_j,b| <= r_i,b + r_j,b + skin_i + skin_j (the shift
//      cancels in the difference), so it is a candidate of the cache;
//   3. otherwise a build (Build): skins from each sphere's speed since the last build times the
//      lookahead (a number of frames the controller adapts), radii grown to (r + skin)(1 + 2^-16),
//      and every allowed pair whose grown spheres touch (all pairs, or the column sweep), sorted by
//      (i, j);
//   4. the exact sphere test on the candidates, in order: the contacts come out sorted.
//
// Rounding. The build accepts every pair whose grown spheres truly touch: its float test errs by a
// few units of 2^-24 relative to the distances, far below the 2^-16 growth. The check's float
// error is at most ~8u relative to the moved distance plus 2u |shift| (each subtraction is exactly
// rounded relative to its result), covered by allowing only skin (1 - 2^-16) - 2^-20 |shift|. A
// pair the exact float test accepts is within (r_i + r_j)(1 + 4u) in reals, also covered. So a
// frame's contacts are exactly the oracle's whatever the cache's history.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <span>

#include "broad_phase/kernels.h"
#include "broad_phase/sphere_test.h"
#include "simd/float4.h"
#include "skinspheres/runtime/broad_phase/broad_phase.h"
#include "skinspheres/skinning/platform.h"

namespace skinspheres::runtime {
namespace {

constexpr size_t kPad = kernels::kMaxWidth;
constexpr size_t kStage = 512;                          // contacts staged before the output
constexpr float kGrow = 1.0f + 1.0f / 65536.0f;         // grown radius factor of a build
constexpr float kAllowFactor = 1.0f - 1.0f / 65536.0f;  // of the skin, for the cache check
constexpr float kSlackRelative = 1.0f / 1048576.0f;     // 2^-20 of |shift|_inf
constexpr float kPadRelative = 1.0f / 262144.0f;        // 2^-18: sweep interval pad
constexpr float kPadAbsolute = 0x1p-60f;                // spheres closer than ~2^-75 touch whatever
                                                        // their radii (the squares underflow)
constexpr float kSkinMin = 0x1p-60f;                    // skins^2 stay normal floats
constexpr float kSkinFloorRelative = 1.0f / 64.0f;      // of the radius: the skin of a still sphere
// The lookahead ladder (skin = lookahead x speed per frame; rung 0: no cache, all pairs straight
// into the output) and the work units of its cost model,
// roughly nanoseconds x 2 on a current x86 core: per sphere for the cache check, per candidate
// for its exact test, per sphere for a build's set-up (all pairs / sweep), per pair test of a
// build, per pair a build keeps.
constexpr int kRungs = 8;
constexpr float kLookahead[kRungs] = {0.0f, 0.0f, 1.25f, 2.0f, 3.0f, 4.5f, 7.0f, 11.0f};  // rung 0: no cache
constexpr double kRungFadePerFrame = 0.99;
constexpr double kCheckWork = 5.0;
constexpr double kTestWork = 1.5;
constexpr double kAllPairsSphereWork = 10.0;
constexpr double kSweepSphereWork = 40.0;
constexpr double kPairTestWork = 0.3;
constexpr double kPairWork = 6.0;
constexpr double kCellMargin = 1.0 + 1.0 / 256.0;       // strips are (2 max grown r)(1 + 2^-8) wide
constexpr double kSweepCallCost = 48.0;                 // one sweep call, in interval tests
constexpr size_t kGroupsCrossMax = 16;                  // pairs between characters per sphere, at most
constexpr uint32_t kGroupsPause = 64;                   // frames as one set when they were more
// Per-sphere float arrays of the build (BroadPhaseContext::soa_): 0..3 x, y, z, grown radius and
// 4..5 interval start and end, in the order the kernel reads (index or sweep order); then, in
// index order, the grown radii and the interval starts.
constexpr int kGrown = 6;
constexpr int kStartByIndex = 7;
constexpr int kSoaFields = 8;

bool CpuHas(BroadPhaseSimd level) {
  switch (level) {
    case BroadPhaseSimd::kAuto:
    case BroadPhaseSimd::kPortable: return true;
#if defined(SKINSPHERES_X86_64)
    case BroadPhaseSimd::kSse2:
      return true;
    case BroadPhaseSimd::kAvx2: return HostCpu().avx2 && HostCpu().bmi1 && HostCpu().popcnt;
    case BroadPhaseSimd::kAvx512: return HostCpu().avx512f && HostCpu().bmi1 && HostCpu().popcnt;
#endif
    default: return false;
  }
}

const kernels::Kernels& KernelsFor(BroadPhaseSimd level) {
  switch (ResolveBroadPhaseSimd(level)) {
#if defined(SKINSPHERES_X86_64)
    case BroadPhaseSimd::kAvx512:
      return kernels::Avx512Kernels();
    case BroadPhaseSimd::kAvx2:
      return kernels::Avx2Kernels();
    case BroadPhaseSimd::kSse2: return kernels::Sse2Kernels();
#endif
    default: return kernels::PortableKernels();
  }
}

kernels::FilterView View(const PairFilter& f) {
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
size_t AllPairsRowWords(size_t n) { return (n + kernels::kMaxWidth) / 64 + 1; }

bool NoPairAllowed(const PairFilter& f) {
  return !f.pairs_within_groups() && (f.groups() == nullptr || !f.pairs_between_groups());
}

// Order-preserving bits of a float (not NaN): unsigned order of the result = float order.
uint32_t OrderBits(float f) {
  const uint32_t u = std::bit_cast<uint32_t>(f);
  return (u & 0x80000000u) != 0 ? ~u : (u | 0x80000000u);
}

bool ByPair(const Contact& p, const Contact& q) { return p.i != q.i ? p.i < q.i : p.j < q.j; }

}  // namespace

bool BroadPhaseSimdSupported(BroadPhaseSimd level) { return CpuHas(level); }

BroadPhaseSimd ResolveBroadPhaseSimd(BroadPhaseSimd level) {
  if (level != BroadPhaseSimd::kAuto) return level;
  if (CpuHas(BroadPhaseSimd::kAvx512)) return BroadPhaseSimd::kAvx512;
  if (CpuHas(BroadPhaseSimd::kAvx2)) return BroadPhaseSimd::kAvx2;
#if defined(SKINSPHERES_X86_64)
  return BroadPhaseSimd::kSse2;
#else
  return BroadPhaseSimd::kPortable;
#endif
}

const char* ToString(BroadPhaseSimd level) {
  switch (level) {
    case BroadPhaseSimd::kAuto:
      return "auto";
    case BroadPhaseSimd::kSse2:
      return "sse2";
    case BroadPhaseSimd::kAvx2:
      return "avx2";
    case BroadPhaseSimd::kAvx512:
      return "avx512";
    case BroadPhaseSimd::kPortable: return "portable";
  }
  return "unknown";
}

const char* ToString(BroadPhaseMethod method) {
  switch (method) {
    case BroadPhaseMethod::kNone:
      return "none";
    case BroadPhaseMethod::kCached:
      return "cached";
    case BroadPhaseMethod::kAllPairsBuild:
      return "all-pairs build";
    case BroadPhaseMethod::kSweepBuild:
      return "sweep build";
    case BroadPhaseMethod::kAllPairsDirect:
      return "all-pairs direct";
    case BroadPhaseMethod::kSweepDirect:
      return "sweep direct";
    case BroadPhaseMethod::kGroups:
      return "groups";
  }
  return "unknown";
}

void BroadPhaseContext::Resize(size_t max_spheres, size_t max_candidates) {
  max_spheres_ = max_spheres;
  if (max_candidates == 0) {
    const size_t all_pairs = max_spheres * (max_spheres > 0 ? max_spheres - 1 : 0) / 2;
    max_candidates = std::min(all_pairs, 16 * max_spheres + 256);
  }
  // A direct sweep needs room for one sphere's whole range.
  max_candidates_ = std::max(max_candidates, max_spheres + kPad);
  const size_t padded = max_spheres + kPad;
  ci_.assign(max_candidates_ + kPad, 0);
  cj_.assign(max_candidates_ + kPad, 0);
  ref_.assign(4 * padded, 0.0f);
  allow_.assign(padded, 0.0f);
  motion_.assign(padded, 0.0f);
  speed_.assign(max_spheres, 0.0f);
  soa_.assign(kSoaFields * padded, 0.0f);
  sphere_.assign(padded, 0);
  row_.assign(max_spheres + 1, 0);
  if (max_spheres > kAllPairsMax) {
    order_.assign(max_spheres, SortItem{0, 0, 0});
    order_by_strip_.assign(max_spheres, SortItem{0, 0, 0});
    runs_.assign(max_spheres, ColumnRun{0, 0, 0});
    pi_.assign(max_candidates_ + kPad, 0);
    pj_.assign(max_candidates_ + kPad, 0);
    // The sweep's bits, with room for the all-pairs rows of any set of up to kAllPairsMax spheres
    // (a context this large may run a small set; no extra memory from 576 spheres up).
    near_.assign(std::max(kernels::kNearWords * max_spheres, AllPairsRowWords(kAllPairsMax) * kAllPairsMax), 0);
    far_.assign(max_spheres, 0);
  } else {
    order_.clear();
    order_by_strip_.clear();
    runs_.clear();
    pi_.clear();
    pj_.clear();
    near_.assign(AllPairsRowWords(max_spheres) * max_spheres, 0);  // the all-pairs kernels' bit rows
    far_.clear();
  }
  near_count_ = 0;
  stage_.assign(kStage + kPad, Contact{});
  group_contexts_.clear();
  group_filters_.clear();
  groups_filter_ = 0;
  groups_pause_ = 0;
  Invalidate();
  rung_ = 3;
  std::fill(rung_cost_, rung_cost_ + kRungs, 0.0);
  method_ = BroadPhaseMethod::kNone;
  last_candidates_ = 0;
  last_build_tests_ = 0;
  last_full_sort_ = false;
  build_count_ = 0;
}

void BroadPhaseContext::Invalidate() {
  cache_valid_ = false;
  cache_count_ = 0;
  cache_filter_ = 0;
  age_ = 0;
  candidate_count_ = 0;
  order_count_ = 0;
  axis_ = -1;
  cell_ = 0.0;
  build_cost_ = 0.0;
  for (BroadPhaseContext& c : group_contexts_) c.Invalidate();
  groups_pause_ = 0;
}

// ------------------------------------------------------------------------------------- the job

struct BroadPhaseContext::Impl {
  const SelfCollisionJob& job;
  BroadPhaseContext& ctx;
  const kernels::Kernels& k;
  const PairFilter& filter;
  const kernels::FilterView view;
  const size_t n;
  const float* spheres;  // n x (x, y, z, r)
  size_t padded;         // n + kPad: stride of the per-sphere arrays of this frame

  Impl(const SelfCollisionJob& j, const kernels::Kernels& kernels)
      : job(j),
        ctx(*j.context),
        k(kernels),
        filter(*j.filter),
        view(View(*j.filter)),
        n(j.spheres.size()),
        spheres(reinterpret_cast<const float*>(j.spheres.data())),
        padded(j.spheres.size() + kPad) {}

  const Vec4f& Sphere(size_t s) const { return job.spheres[s]; }
  float* Soa(int field) { return ctx.soa_.data() + static_cast<size_t>(field) * padded; }

  bool CacheHolds(const float sum[3]) {
    const float inv_n = 1.0f / static_cast<float>(n);
    float shift[3];
    float largest = 0.0f;
    for (int a = 0; a < 3; ++a) {
      shift[a] = (sum[a] - ctx.ref_sum_[a]) * inv_n;
      largest = std::max(largest, std::fabs(shift[a]));
    }
    return k.check_motion(spheres, ctx.ref_.data(), ctx.allow_.data(), n, shift, largest * kSlackRelative, padded,
                          ctx.motion_.data());
  }

  // Skins for the next cache: lookahead x speed, within [floor, cap]. A sphere's speed is its
  // motion per frame since the last build, or half its previous speed if that is more (a limb
  // at the turn of a swing is about to move again); no sphere counts as slower than half the
  // set's mean (the slowest sphere would otherwise end every cache). Writes the grown radii
  // (index order) into Soa(kGrown) and the allowances.
  void Skins(bool have_motion, float lookahead) {
    float radius_sum = 0.0f, speed_sum = 0.0f;
    const float inv_age = 1.0f / static_cast<float>(std::max<uint32_t>(ctx.age_, 1));
    float* speed = ctx.speed_.data();
    for (size_t s = 0; s < n; ++s) {
      radius_sum += Sphere(s).w();
      speed[s] = have_motion ? std::max(ctx.motion_[s] * inv_age, 0.5f * speed[s]) : 0.0f;
      speed_sum += speed[s];
    }
    const float cap_add = 4.0f * radius_sum / static_cast<float>(n);
    const float slowest = 0.5f * speed_sum / static_cast<float>(n);
    float* grown = Soa(kGrown);
    for (size_t s = 0; s < n; ++s) {
      const float r = Sphere(s).w();
      const float floor = std::max(r * kSkinFloorRelative, kSkinMin);
      const float cap = std::max(floor, std::min(r + cap_add, internal::kMaxMagnitude));
      const float skin = std::clamp(lookahead * std::max(speed[s], slowest), floor, cap);
      grown[s] = (r + skin) * kGrow;
      ctx.allow_[s] = skin * kAllowFactor;
    }
  }

  void CopyCentres() {
    float* x = Soa(0);
    float* y = Soa(1);
    float* z = Soa(2);
    for (size_t s = 0; s < n; ++s) {
      x[s] = Sphere(s).x();
      y[s] = Sphere(s).y();
      z[s] = Sphere(s).z();
    }
  }

  // NaN centres past the end: padding lanes of the all-pairs kernels never touch anything.
  void PadIndexOrder() {
    for (int field : {0, 1, 2, int(kGrown)}) {
      std::fill(Soa(field) + n, Soa(field) + padded, std::numeric_limits<float>::quiet_NaN());
    }
  }

  // The filter's listed exclusions as bit rows for the all-pairs kernels (in ctx.near_, sized by
  // Resize for sets of up to kAllPairsMax spheres), made once per filter: the kernels then mask a
  // vector's listed pairs at once instead of walking the partner list at every vector that hits.
  kernels::FilterView AllPairsView() {
    kernels::FilterView v = view;
    const size_t words = AllPairsRowWords(n);
    if (filter.excluded_pair_count() == 0 || ctx.near_.size() < words * n) return v;
    if (ctx.near_count_ != n || ctx.near_filter_ != filter.id()) {
      uint64_t* rows = ctx.near_.data();
      std::fill(rows, rows + words * n, uint64_t{0});
      for (uint32_t i = 0; i < n; ++i) {
        for (const uint32_t j : filter.excluded_partners(i)) {
          if (j > i) rows[i * words + (j >> 6)] |= uint64_t{1} << (j & 63u);
        }
      }
      ctx.near_filter_ = filter.id();
      ctx.near_count_ = n;
    }
    v.row_bits = ctx.near_.data();
    v.row_words = words;
    return v;
  }

  // All pairs of grown spheres into the cache (index order: already sorted). False if it does not fit.
  bool AllPairsBuild() {
    kernels::SoaSpheres s{Soa(0), Soa(1), Soa(2), Soa(kGrown), nullptr, nullptr, nullptr};
    kernels::PairSink sink{ctx.ci_.data(), ctx.cj_.data(), ctx.max_candidates_, 0, false};
    size_t tests = 0;
    const kernels::FilterView rows_view = AllPairsView();
    const uint32_t next =
        k.all_pairs_build(s, static_cast<uint32_t>(n), 0, static_cast<uint32_t>(n), rows_view, &sink, &tests);
    ctx.last_build_tests_ += tests;
    ctx.candidate_count_ = sink.count;
    return next == n;
  }

  // Sweep order of the spheres with radii Soa(kGrown): sorted by (strip, interval start), the
  // strips cutting the axis of second largest spread (when `strips` and the cost model below
  // prefers them), gathered into Soa(0..5) and ctx.sphere_; the strips as runs of that order.
  // Returns the run count.
  size_t Order(bool strips) {
    const float* grown = Soa(kGrown);
    // Bounds and spread of the centres (relative to the first, so float sums stay accurate), the
    // largest and mean grown radius.
    namespace F = simd::native;
    const F::Float4 c0 = F::Load4(spheres);
    F::Float4 lo = c0, hi = c0, sum = F::Zero(), sum2 = F::Zero();
    for (size_t s = 0; s < n; ++s) {
      const F::Float4 v = F::Load4(spheres + 4 * s);
      lo = F::Min(lo, v);
      hi = F::Max(hi, v);
      const F::Float4 d = F::Sub(v, c0);
      sum = F::Add(sum, d);
      sum2 = F::Add(sum2, F::Mul(d, d));
    }
    float lo_f[4], hi_f[4], sum_f[4], sum2_f[4];
    F::Store4(lo_f, lo);
    F::Store4(hi_f, hi);
    F::Store4(sum_f, sum);
    F::Store4(sum2_f, sum2);
    float max_r = 0.0f, sum_r = 0.0f;
    for (size_t s = 0; s < n; ++s) {
      max_r = std::max(max_r, grown[s]);
      sum_r += grown[s];
    }
    double variance[3];
    for (int a = 0; a < 3; ++a) {
      const double mean = double(sum_f[a]) / double(n);
      variance[a] = double(sum2_f[a]) / double(n) - mean * mean;
    }
    const int best = int(std::max_element(variance, variance + 3) - variance);
    bool keep_order = ctx.order_count_ == n && ctx.axis_ >= 0;
    if (!keep_order || variance[best] > 1.25 * variance[ctx.axis_]) {
      if (best != ctx.axis_) keep_order = false;
      ctx.axis_ = best;
    }
    const int axis = ctx.axis_;
    const int strip_axis = variance[(axis + 1) % 3] >= variance[(axis + 2) % 3] ? (axis + 1) % 3 : (axis + 2) % 3;

    // Strips at least one grown diameter wide (touching spheres lie in the same or adjacent
    // strips), anchored at multiples of the width (so they do not move with the set) and kept
    // while the width is within 1.5x of the need. Worth it when they save more interval tests
    // than their extra sweep calls cost: a sphere meets about p * n / 2 intervals in one sweep,
    // p * 1.5 n / strips with strips, for 3 calls instead of 1 (p: the chance that two intervals
    // overlap on the sweep axis).
    const double need = 2.0 * double(max_r) * kCellMargin;
    if (!(ctx.cell_ >= need && ctx.cell_ <= 1.5 * need)) {
      ctx.cell_ = need;
      keep_order = false;
    }
    const double cell = std::max({ctx.cell_, std::max(std::fabs(double(lo_f[strip_axis])), std::fabs(double(hi_f[strip_axis]))) * 0x1p-40,
                                  (double(hi_f[strip_axis]) - lo_f[strip_axis]) / std::max(1.0, double(n / 4)),
                                  std::numeric_limits<double>::min()});
    const double inv_cell = 1.0 / cell;
    const double base = std::floor(double(lo_f[strip_axis]) * inv_cell);
    int64_t count = std::max<int64_t>(1, int64_t(double(hi_f[strip_axis]) * inv_cell - base) + 1);
    if (strips && count > 1) {
      const double extent = std::max(double(hi_f[axis]) - lo_f[axis], 1e-30);
      const double p = std::min(1.0, 4.0 * double(sum_r) / double(n) / extent);
      const double cost_one = kSweepCallCost * double(n) + 0.5 * p * double(n) * double(n);
      const double cost_strips = 3.0 * kSweepCallCost * double(n) + 1.5 * p * double(n) * double(n) / double(count);
      strips = cost_strips < cost_one;
    }
    if (!strips) count = 1;
    if (ctx.order_columns_ != (count > 1)) keep_order = false;
    // Strip index: the product is >= base up to rounding, so truncation is the floor.
    const auto strip_of = [&](const Vec4f& p) {
      if (count == 1) return uint32_t{0};
      return static_cast<uint32_t>(
          std::min<int64_t>(int64_t(std::max(double(p[strip_axis]) * inv_cell - base, 0.0)), count - 1));
    };

    // Interval starts in index order (one computation, reused by the keys and the sweep).
    const auto interval_pad = [](float c, float r) { return (std::fabs(c) + r) * kPadRelative + kPadAbsolute; };
    float* start_by_sphere = Soa(kStartByIndex);
    for (size_t s = 0; s < n; ++s) {
      const float c = Sphere(s)[axis], r = grown[s];
      start_by_sphere[s] = c - r - interval_pad(c, r);
    }
    const auto key_of = [&](size_t s) { return (uint64_t{strip_of(Sphere(s))} << 32) | OrderBits(start_by_sphere[s]); };

    // Sort by (strip, start), from the previous order when there is one: a stable counting sort by
    // the new strip, after which each strip's run is a few segments, one per strip its spheres
    // came from (in that strip order), each nearly sorted by start under coherent motion: an
    // insertion sort per segment, then the segments merged (moves of both within a budget for the
    // whole, else std::sort). An insertion sort of the whole run would move every sphere that
    // changed strips across most of the run: a crowd of walking characters overran the budget on
    // every build. Without strips there is one run of one segment (the previous order had no
    // strips either, or it is not kept), so merges only happen with src = order_by_strip_.
    SortItem* order = ctx.order_.data();
    bool full_sort = !keep_order;
    if (keep_order) {
      for (size_t q = 0; q < n; ++q) {
        order[q].from = static_cast<uint32_t>(order[q].key >> 32);
        order[q].key = key_of(order[q].sphere);
      }
      SortItem* src = order;
      if (count > 1) {
        uint32_t* at = ctx.row_.data();
        std::fill(at, at + count + 1, 0u);
        for (size_t q = 0; q < n; ++q) ++at[(order[q].key >> 32) + 1];
        for (int64_t c = 0; c < count; ++c) at[c + 1] += at[c];
        src = ctx.order_by_strip_.data();
        for (size_t q = 0; q < n; ++q) src[at[order[q].key >> 32]++] = order[q];
      }
      size_t moves = 0;
      const size_t budget = 4 * n + 64;
      for (size_t b = 0; b < n && !full_sort;) {
        // The run of one strip, [b, e), and its segments.
        const uint64_t strip = src[b].key >> 32;
        size_t e = b + 1;
        while (e < n && (src[e].key >> 32) == strip) ++e;
        size_t segment_end = b;
        SortItem* merged = src;  // holds [b, segment_end) sorted
        while (segment_end < e) {
          const size_t begin = segment_end;
          size_t end = begin + 1;
          while (end < e && src[end].from == src[begin].from) ++end;
          for (size_t q = begin + 1; q < end && moves <= budget; ++q) {
            const SortItem item = src[q];
            if (!(item.key < src[q - 1].key)) continue;
            size_t m = q;
            do {
              src[m] = src[m - 1];
              --m;
              ++moves;
            } while (m > begin && item.key < src[m - 1].key);
            src[m] = item;
          }
          if (moves > budget) {
            full_sort = true;
            break;
          }
          if (begin > b) {
            // Merge [b, begin) of `merged` with this segment into the other array (which may be
            // src itself: the segment is the tail of the output range, and a forward merge
            // never writes past what it has read of it). Counted against the budget.
            SortItem* out = merged == src ? order : src;
            size_t x = b, y = begin, w = b;
            while (x < begin && y < end) out[w++] = src[y].key < merged[x].key ? src[y++] : merged[x++];
            while (x < begin) out[w++] = merged[x++];
            while (y < end) out[w++] = src[y++];
            merged = out;
            moves += end - b;
          }
          segment_end = end;
        }
        if (!full_sort && merged != order) std::copy(merged + b, merged + e, order + b);
        b = e;
      }
      if (full_sort && src != order) std::copy(src, src + n, order);
    } else {
      for (size_t q = 0; q < n; ++q) order[q] = SortItem{key_of(q), static_cast<uint32_t>(q), 0};
    }
    if (full_sort) {
      std::sort(order, order + n, [](const SortItem& a, const SortItem& b) { return a.key < b.key; });
    }
    ctx.last_full_sort_ = full_sort;
    ctx.order_count_ = n;
    ctx.order_columns_ = count > 1;

    // Gather in sweep order.
    float* x = Soa(0);
    float* y = Soa(1);
    float* z = Soa(2);
    float* r_sorted = Soa(3);
    float* start = Soa(4);
    float* end = Soa(5);
    uint32_t* sphere = ctx.sphere_.data();
    for (size_t q = 0; q < n; ++q) {
      const uint32_t s = order[q].sphere;
      const Vec4f& p = Sphere(s);
      const float r = grown[s];
      sphere[q] = s;
      x[q] = p.x();
      y[q] = p.y();
      z[q] = p.z();
      r_sorted[q] = r;
      start[q] = start_by_sphere[s];
      end[q] = p[axis] + r + interval_pad(p[axis], r);
    }
    for (size_t q = n; q < padded; ++q) {
      x[q] = y[q] = z[q] = r_sorted[q] = 0.0f;
      start[q] = std::numeric_limits<float>::infinity();
      end[q] = -std::numeric_limits<float>::infinity();
      sphere[q] = 0;
    }

    // Columns as runs of the sorted order.
    ColumnRun* runs = ctx.runs_.data();
    size_t run_count = 0;
    for (size_t q = 0; q < n;) {
      const uint32_t col = static_cast<uint32_t>(order[q].key >> 32);
      size_t e = q + 1;
      while (e < n && static_cast<uint32_t>(order[e].key >> 32) == col) ++e;
      runs[run_count++] = ColumnRun{col, static_cast<uint32_t>(q), static_cast<uint32_t>(e)};
      q = e;
    }
    return run_count;
  }

  // Longest interval of a run of the sweep order.
  float RunLength(const ColumnRun& run) {
    const float* start = Soa(4);
    const float* end = Soa(5);
    float len = 0.0f;
    for (uint32_t q = run.begin; q < run.end; ++q) len = std::max(len, end[q] - start[q]);
    return len * (1.0f + 1.0f / 65536.0f);
  }

  kernels::SoaSpheres SweepSoa() {
    return kernels::SoaSpheres{Soa(0), Soa(1), Soa(2), Soa(3), Soa(4), Soa(5), ctx.sphere_.data()};
  }

  // The filter's listed exclusions as bits for the sweep (ctx.near_, ctx.far_), made once per
  // filter: a set whose spheres overlap their listed neighbours (a fitted character) would
  // otherwise send mostly listed pairs through the sort (96% of them for a crowd of CesiumMan).
  kernels::FilterView SweepView() {
    kernels::FilterView v = view;
    if (filter.excluded_pair_count() == 0) return v;
    if (ctx.near_count_ != n || ctx.near_filter_ != filter.id()) {
      uint64_t* near = ctx.near_.data();
      std::fill(near, near + kernels::kNearWords * n, uint64_t{0});
      for (uint32_t i = 0; i < n; ++i) {
        uint8_t far = 0;
        for (const uint32_t j : filter.excluded_partners(i)) {
          const uint32_t d = j + kernels::kNearRange - i;  // modulo 2^32
          if (d < 2 * kernels::kNearRange) {
            near[size_t{i} * kernels::kNearWords + (d >> 6)] |= uint64_t{1} << (d & 63u);
          } else {
            far = 1;
          }
        }
        ctx.far_[i] = far;
      }
      ctx.near_filter_ = filter.id();
      ctx.near_count_ = n;
    }
    v.near = ctx.near_.data();
    v.far = ctx.far_.data();
    return v;
  }

  // Sort and sweep in strips of the spheres with radii Soa(kGrown): the pairs whose balls touch
  // and the filter allows (listed exclusions included) into (pi_, pj_). False when they do not fit.
  bool SweepBuild(size_t* pair_count) {
    const size_t run_count = Order(true);
    const ColumnRun* runs = ctx.runs_.data();
    const kernels::SoaSpheres soa = SweepSoa();
    const kernels::FilterView sweep_view = SweepView();
    kernels::PairSink sink{ctx.pi_.data(), ctx.pj_.data(), ctx.max_candidates_, 0, false};
    size_t tests = 0;
    for (size_t ri = 0; ri < run_count && !sink.full; ++ri) {
      const ColumnRun& ra = runs[ri];
      tests += k.sweep_blocks(soa, ra.begin, ra.end, 0, 0, 0.0f, sweep_view, &sink);
      // The next strip, if it holds spheres: both ways (blocks of A against B, then B against A
      // would count pairs twice, so one call with B's longest interval as reach).
      if (ri + 1 < run_count && runs[ri + 1].column == ra.column + 1 && !sink.full) {
        const ColumnRun& rb = runs[ri + 1];
        tests += k.sweep_blocks(soa, ra.begin, ra.end, rb.begin, rb.end, RunLength(rb), sweep_view, &sink);
      }
    }
    ctx.last_build_tests_ += tests;
    *pair_count = sink.count;
    return !sink.full;
  }

  // The direct path's sweep (one axis, no columns: a fallback for sets too dense for any cache):
  // every touching pair the filter allows into the output, unsorted (FlushDirect leaves out the
  // listed exclusions, so the output never holds more than the frame's contacts).
  void SweepDirect() {
    Order(false);
    const kernels::SoaSpheres soa = SweepSoa();
    kernels::PairSink sink{ctx.pi_.data(), ctx.pj_.data(), ctx.max_candidates_, 0, false};
    size_t tests = 0;
    for (uint32_t a = 0; a + 1 < n; ++a) {
      const size_t before = sink.count;
      tests += k.sweep_range(soa, a, a + 1, static_cast<uint32_t>(n), view, &sink);
      if (!sink.full) continue;
      // Out of room: stream what came before this sphere, then redo it (max_candidates >= n + pad).
      FlushDirect(before);
      sink.count = 0;
      sink.full = false;
      k.sweep_range(soa, a, a + 1, static_cast<uint32_t>(n), view, &sink);
    }
    FlushDirect(sink.count);
    ctx.last_build_tests_ = tests;
  }

  // The unsorted pairs (pi_, pj_)[0, m) into the cache, sorted by (i, j) (two counting-sort
  // passes: by j, then stably by i; the arrays then swap roles). The sweep left out every pair the
  // filter excludes.
  void SortPairsIntoCache(size_t m) {
    uint32_t* count = ctx.row_.data();
    const auto pass = [&](const uint32_t* key, const uint32_t* other, uint32_t* key_out, uint32_t* other_out) {
      std::fill(count, count + n + 1, 0u);
      for (size_t p = 0; p < m; ++p) ++count[key[p] + 1];
      for (size_t s = 0; s < n; ++s) count[s + 1] += count[s];
      for (size_t p = 0; p < m; ++p) {
        const uint32_t at = count[key[p]]++;
        key_out[at] = key[p];
        other_out[at] = other[p];
      }
    };
    pass(ctx.pj_.data(), ctx.pi_.data(), ctx.cj_.data(), ctx.ci_.data());  // by j into (ci, cj)
    pass(ctx.ci_.data(), ctx.cj_.data(), ctx.pi_.data(), ctx.pj_.data());  // stably by i into (pi, pj)
    std::swap(ctx.ci_, ctx.pi_);
    std::swap(ctx.cj_, ctx.pj_);
    ctx.candidate_count_ = m;
  }

  // Pads the cache's pair arrays with valid indices for the vector reads past its end.
  void PadCache() {
    std::fill(ctx.ci_.data() + ctx.candidate_count_, ctx.ci_.data() + ctx.candidate_count_ + kPad, 0u);
    std::fill(ctx.cj_.data() + ctx.candidate_count_, ctx.cj_.data() + ctx.candidate_count_ + kPad, 0u);
  }

  // Builds the cache. False when it does not fit even without skins.
  bool Build(bool have_motion, const float sum[3]) {
    ++ctx.build_count_;
    ctx.last_build_tests_ = 0;
    const bool small = n <= kAllPairsMax;
    for (float lookahead : {have_motion ? kLookahead[ctx.rung_] : 0.0f, 0.0f}) {
      ctx.last_lookahead_ = lookahead;
      Skins(have_motion, lookahead);
      CopyCentres();
      bool fits;
      if (small) {
        PadIndexOrder();
        fits = AllPairsBuild();
      } else {
        size_t m = 0;
        fits = SweepBuild(&m);
        if (fits) SortPairsIntoCache(m);
      }
      if (fits) {
        ctx.method_ = small ? BroadPhaseMethod::kAllPairsBuild : BroadPhaseMethod::kSweepBuild;
        PadCache();
        // The reference: this frame's spheres.
        float* rx = ctx.ref_.data();
        for (size_t s = 0; s < n; ++s) {
          const Vec4f& p = Sphere(s);
          rx[s] = p.x();
          rx[padded + s] = p.y();
          rx[2 * padded + s] = p.z();
          rx[3 * padded + s] = p.w();
        }
        std::copy(sum, sum + 3, ctx.ref_sum_);
        ctx.cache_valid_ = true;
        ctx.cache_count_ = n;
        ctx.cache_filter_ = filter.id();
        ctx.age_ = 0;
        return true;
      }
      // Too many candidates with these skins: less lookahead from now on, and this rung looks
      // expensive for a long while. A small set goes straight to the direct path (all pairs into
      // the output), cheaper than another build.
      double& memory = ctx.rung_cost_[ctx.rung_];
      memory = 4.0 * std::max({memory, ctx.rung_cost_[std::max(MinRung(), ctx.rung_ - 1)], 1.0});
      ctx.rung_ = std::max(MinRung(), ctx.rung_ - 2);
      if (lookahead == 0.0f || small) break;
    }
    ctx.cache_valid_ = false;
    return false;
  }

  // Rung 0 (no cache: all pairs straight into the output) only for sets the all-pairs kernels take.
  int MinRung() const { return n <= kAllPairsMax ? 0 : 1; }

  // Adapts the lookahead (a rung of kLookahead) from the cost per frame of what the current rung
  // just did, in counted work (not time: the choice is deterministic). Each rung keeps a moving
  // average of its cost; the next frames take the cheapest of this rung and its two neighbours, a
  // neighbour never tried counting as a little cheaper (so it gets tried) and a neighbour's
  // memory fading towards cheap (so it is tried again when the motion changes).
  void AdaptLookahead(double cost, uint32_t frames) {
    double* memory = ctx.rung_cost_;
    const double fade = std::pow(kRungFadePerFrame, double(std::max<uint32_t>(frames, 1)));
    const int rung = std::max(ctx.rung_, MinRung());
    memory[rung] = memory[rung] > 0.0 ? 0.5 * (memory[rung] + cost) : cost;
    int best = rung;
    double best_cost = memory[rung];
    for (const int r : {rung - 1, rung + 1}) {
      if (r < MinRung() || r >= kRungs) continue;
      memory[r] *= fade;
      const double guess = memory[r] > 0.0 ? memory[r] : 0.9 * memory[rung];
      if (guess < best_cost) {
        best = r;
        best_cost = guess;
      }
    }
    ctx.rung_ = best;
  }

  // Cost per frame of the cache that just expired.
  double ExpiredCacheCost() const {
    const double frames = std::max<uint32_t>(ctx.age_, 1);
    const double cached = kCheckWork * double(n) + kTestWork * double(ctx.candidate_count_);
    return (ctx.build_cost_ + (frames - 1.0) * cached) / frames;
  }

  // Streams the unsorted pairs (pi_, pj_)[0, m) as contacts into the output (direct sweep), less
  // the listed exclusions (the sweep's view has no bits for them).
  void FlushDirect(size_t m) {
    const uint32_t* pi = ctx.pi_.data();
    const uint32_t* pj = ctx.pj_.data();
    const bool listed = filter.excluded_pair_count() > 0;
    for (size_t p = 0; p < m; ++p) {
      const uint32_t i = pi[p], j = pj[p];
      if (listed && filter.excluded(i, j)) continue;
      job.out->push_back(Contact{i, j, internal::PenetrationDepth(Sphere(i), Sphere(j)), filter.part(i), filter.part(j)});
    }
  }

  // No cache fits: contacts straight into the output.
  void Direct() {
    ctx.last_build_tests_ = 0;
    if (n <= kAllPairsMax) {
      ctx.method_ = BroadPhaseMethod::kAllPairsDirect;
      CopyCentres();
      float* r = Soa(kGrown);
      for (size_t s = 0; s < n; ++s) r[s] = Sphere(s).w();
      PadIndexOrder();
      kernels::SoaSpheres s{Soa(0), Soa(1), Soa(2), Soa(kGrown), nullptr, nullptr, nullptr};
      kernels::ContactSink sink{ctx.stage_.data(), kStage, 0};
      size_t tests = 0;
      const kernels::FilterView rows_view = AllPairsView();
      for (uint32_t row = 0; row < n;) {
        row = k.all_pairs_contacts(s, static_cast<uint32_t>(n), row, static_cast<uint32_t>(n), rows_view, &sink,
                                   &tests);
        job.out->insert(job.out->end(), ctx.stage_.data(), ctx.stage_.data() + sink.count);
        sink.count = 0;
      }
      ctx.last_build_tests_ = tests;
      return;
    }
    ctx.method_ = BroadPhaseMethod::kSweepDirect;
    float* r = Soa(kGrown);
    for (size_t s = 0; s < n; ++s) r[s] = Sphere(s).w();
    SweepDirect();
    std::sort(job.out->begin(), job.out->end(), ByPair);
  }

  void TestCache() {
    const uint16_t* parts = filter.parts().data();
    kernels::ContactSink sink{ctx.stage_.data(), kStage, 0};
    const size_t count = ctx.candidate_count_;
    for (size_t pos = 0; pos < count;) {
      pos = k.test_candidates(spheres, ctx.ci_.data(), ctx.cj_.data(), pos, count, parts, &sink);
      job.out->insert(job.out->end(), ctx.stage_.data(), ctx.stage_.data() + sink.count);
      sink.count = 0;
    }
    ctx.last_candidates_ = count;
  }

  // ------------------------------------------------------------------ a space of several characters
  //
  // With the filter of PairFilter::Combine, one cache for the whole space would end whenever any
  // one character's sphere left its skin: with ten walking characters that is every frame, and
  // each build sweeps every character's own pairs again. Instead each character (group) keeps its
  // own context and cache, as if it were alone, and the pairs between characters come from a
  // sweep of the characters' bounding boxes: for each pair of characters whose boxes overlap, the
  // spheres of each that lie inside the other's box, every pair of them given the exact test. The
  // two lists are merged by (i, j): within a row, a character's own pairs come first (their j lies
  // in its own index range, before every later character's).

  // Whether the space is worth splitting: several groups of 16 or more spheres on average, and
  // more spheres than one all-pairs build takes.
  bool UseGroups() const {
    const size_t groups = filter.group_count();
    return groups >= 2 && n > kAllPairsMax && n >= 16 * groups;
  }

  // The per-group filters and contexts, made once per filter. False if a group's filter cannot
  // be made (it can: Combine made the same rows; then the space runs as one set).
  bool SetUpGroups() {
    if (ctx.groups_filter_ == filter.id() && ctx.group_filters_.size() == filter.group_count()) return true;
    const size_t groups = filter.group_count();
    ctx.groups_filter_ = 0;
    ctx.group_filters_.clear();
    ctx.group_filters_.reserve(groups);
    ctx.group_contexts_.resize(groups);
    std::vector<ExcludedPair> listed;
    size_t largest = 0;
    for (uint32_t g = 0; g < groups; ++g) {
      const uint32_t b = filter.group_begin(g), e = filter.group_begin(g + 1);
      listed.clear();
      for (uint32_t i = b; i < e; ++i) {
        for (const uint32_t j : filter.excluded_partners(i)) {
          if (j > i && j < e) listed.push_back(ExcludedPair{i - b, j - b, ExclusionReason::kSameJoint});
        }
      }
      auto made = PairFilter::Create(e - b, filter.parts().subspan(b, e - b), listed);
      if (!made.ok()) return false;
      ctx.group_filters_.push_back(std::move(*made));
      BroadPhaseContext& c = ctx.group_contexts_[g];
      if (c.max_spheres() != e - b) {
        c.Resize(e - b);
      } else {
        c.Invalidate();
      }
      largest = std::max<size_t>(largest, e - b);
    }
    ctx.group_box_.assign(8 * groups, 0.0f);
    ctx.group_order_.resize(groups);
    for (uint32_t g = 0; g < groups; ++g) ctx.group_order_[g] = g;
    ctx.cross_a_.reserve(largest);
    ctx.cross_b_.reserve(largest);
    ctx.cross_.clear();
    ctx.cross_.shrink_to_fit();
    ctx.cross_.reserve(n);
    // A character's contacts: at most its cache's room while it has a cache (more only on the
    // frames it is answered without one, see Direct).
    size_t most = 0;
    for (const BroadPhaseContext& c : ctx.group_contexts_) most = std::max(most, c.max_candidates());
    ctx.group_out_.clear();
    ctx.group_out_.reserve(most + kPad);
    ctx.groups_filter_ = filter.id();
    return true;
  }

  // A sphere's box, padded as the sweep pads its intervals (two spheres that the exact test finds
  // touching have overlapping padded boxes on every axis).
  static void PaddedBox(const float* sphere, simd::native::Float4* lo, simd::native::Float4* hi) {
    namespace F = simd::native;
    const F::Float4 v = F::Load4(sphere);
    const F::Float4 r = F::Splat<3>(v);
    const F::Float4 pad = F::Add(F::Mul(F::Add(F::Abs(v), r), F::Set1(kPadRelative)), F::Set1(kPadAbsolute));
    *lo = F::Sub(F::Sub(v, r), pad);
    *hi = F::Add(F::Add(v, r), pad);
  }

  static bool BoxesOverlap(const float* a, const float* b) {  // 8 floats each (low, high)
    namespace F = simd::native;
    const unsigned lo_ok = F::Bits(F::LessEqual(F::Load4(a), F::Load4(b + 4)));
    const unsigned hi_ok = F::Bits(F::LessEqual(F::Load4(b), F::Load4(a + 4)));
    return (lo_ok & hi_ok & 7) == 7;
  }

  // The contacts between characters into ctx.cross_ (sorted by (i, j)), or, with `to_out`, appended
  // to the output unsorted. Returns the candidates tested, or SIZE_MAX when ctx.cross_ (room for n
  // contacts, never grown) cannot hold them.
  size_t CrossGroups(bool to_out) {
    const size_t groups = filter.group_count();
    float* box = ctx.group_box_.data();
    namespace F = simd::native;
    for (uint32_t g = 0; g < groups; ++g) {
      F::Float4 lo = F::Set1(std::numeric_limits<float>::infinity());
      F::Float4 hi = F::Set1(-std::numeric_limits<float>::infinity());
      for (uint32_t s = filter.group_begin(g); s < filter.group_begin(g + 1); ++s) {
        F::Float4 l, h;
        PaddedBox(spheres + 4 * size_t{s}, &l, &h);
        lo = F::Min(lo, l);
        hi = F::Max(hi, h);
      }
      F::Store4(box + 8 * g, lo);
      F::Store4(box + 8 * g + 4, hi);
    }
    // Characters by the low end of their boxes along the axis of largest spread of those ends:
    // an insertion sort from last frame's order (coherent motion), std::sort past 4G moves.
    float lo_end[3], hi_end[3];
    for (int a = 0; a < 3; ++a) {
      lo_end[a] = std::numeric_limits<float>::infinity();
      hi_end[a] = -std::numeric_limits<float>::infinity();
      for (uint32_t g = 0; g < groups; ++g) {
        if (!(box[8 * g] <= box[8 * g + 4])) continue;  // no sphere
        lo_end[a] = std::min(lo_end[a], box[8 * g + a]);
        hi_end[a] = std::max(hi_end[a], box[8 * g + a]);
      }
    }
    int axis = 0;
    for (int a = 1; a < 3; ++a) axis = hi_end[a] - lo_end[a] > hi_end[axis] - lo_end[axis] ? a : axis;
    uint32_t* order = ctx.group_order_.data();
    const auto low = [&](uint32_t g) { return box[8 * g + axis]; };
    const auto before = [&](uint32_t g, uint32_t h) { return low(g) < low(h) || (low(g) == low(h) && g < h); };
    size_t moves = 0;
    for (size_t q = 1; q < groups && moves <= 4 * groups; ++q) {
      const uint32_t g = order[q];
      size_t m = q;
      for (; m > 0 && before(g, order[m - 1]); --m, ++moves) order[m] = order[m - 1];
      order[m] = g;
    }
    if (moves > 4 * groups) std::sort(order, order + groups, before);
    // Candidates of one pair of characters at a time, rows ascending (test_candidates reads a
    // block as one row when its first and last rows agree, so the rows must not go back).
    ctx.cross_.clear();
    uint32_t* pi = ctx.pi_.data();
    uint32_t* pj = ctx.pj_.data();
    const size_t capacity = ctx.max_candidates_;
    const uint16_t* parts = filter.parts().data();
    size_t count = 0, candidates = 0;
    bool room = true;
    const auto test = [&] {
      std::fill(pi + count, pi + count + kPad, 0u);
      std::fill(pj + count, pj + count + kPad, 0u);
      kernels::ContactSink sink{ctx.stage_.data(), kStage, 0};
      for (size_t pos = 0; pos < count;) {
        pos = k.test_candidates(spheres, pi, pj, pos, count, parts, &sink);
        std::vector<Contact>& into = to_out ? *job.out : ctx.cross_;
        if (!to_out && ctx.cross_.size() + sink.count > ctx.cross_.capacity()) room = false;
        if (room) into.insert(into.end(), ctx.stage_.data(), ctx.stage_.data() + sink.count);
        sink.count = 0;
      }
      candidates += count;
      count = 0;
    };
    const auto inside = [&](uint32_t g, const float* other, std::vector<uint32_t>* list) {
      list->clear();
      float sphere_box[8];
      for (uint32_t s = filter.group_begin(g); s < filter.group_begin(g + 1); ++s) {
        F::Float4 l, h;
        PaddedBox(spheres + 4 * size_t{s}, &l, &h);
        F::Store4(sphere_box, l);
        F::Store4(sphere_box + 4, h);
        if (BoxesOverlap(sphere_box, other)) list->push_back(s);
      }
    };
    // A sweep along that axis over the characters' boxes; each pair whose boxes overlap, as it is
    // found.
    for (size_t q = 0; q < groups && room; ++q) {
      const uint32_t first = order[q];
      const float high = box[8 * first + 4 + axis];
      for (size_t q2 = q + 1; q2 < groups && low(order[q2]) <= high && room; ++q2) {
        const uint32_t g = std::min(first, order[q2]), h = std::max(first, order[q2]);
        if (!BoxesOverlap(box + 8 * g, box + 8 * h)) continue;
        inside(g, box + 8 * h, &ctx.cross_a_);
        if (ctx.cross_a_.empty()) continue;
        inside(h, box + 8 * g, &ctx.cross_b_);
        for (const uint32_t a : ctx.cross_a_) {
          if (count + ctx.cross_b_.size() > capacity) test();
          for (const uint32_t b : ctx.cross_b_) {
            pi[count] = a;
            pj[count] = b;
            ++count;
          }
        }
        test();
      }
    }
    if (!room) return SIZE_MAX;
    if (!to_out) std::sort(ctx.cross_.begin(), ctx.cross_.end(), ByPair);
    return candidates;
  }

  // The whole space by groups (UseGroups, SetUpGroups done): each character's own contacts, the
  // contacts between characters merged in by (i, j).
  void RunGroups() {
    const size_t groups = filter.group_count();
    const bool between = filter.pairs_between_groups();
    size_t cross_candidates = between ? CrossGroups(false) : 0;
    const bool merged = cross_candidates != SIZE_MAX;
    if (!between || !merged) ctx.cross_.clear();
    size_t candidates = 0, tests = 0, builds = 0;
    double lookahead = 0.0;
    const std::vector<Contact>& cross = ctx.cross_;
    size_t c = 0;
    std::vector<Contact>& out = *job.out;
    if (filter.pairs_within_groups()) {
      for (uint32_t g = 0; g < groups; ++g) {
        const uint32_t b = filter.group_begin(g), e = filter.group_begin(g + 1);
        BroadPhaseContext& gc = ctx.group_contexts_[g];
        const uint64_t builds_before = gc.build_count_;
        const SelfCollisionJob sub{job.spheres.subspan(b, e - b), &ctx.group_filters_[g], &gc, &ctx.group_out_, job.simd};
        ctx.group_out_.clear();
        Impl(sub, k).Run();  // cannot fail: the values were checked, the sizes match
        candidates += gc.last_candidates_;
        tests += gc.last_build_tests_;
        builds += gc.build_count_ - builds_before;
        lookahead += gc.last_lookahead_;
        for (Contact w : ctx.group_out_) {
          w.i += b;
          w.j += b;
          while (c < cross.size() && ByPair(cross[c], w)) out.push_back(cross[c++]);
          out.push_back(w);
        }
      }
    }
    out.insert(out.end(), cross.begin() + static_cast<ptrdiff_t>(c), cross.end());
    if (!merged) {
      // More contacts between characters than the context holds: appended, then all sorted.
      cross_candidates = CrossGroups(true);
      std::sort(out.begin(), out.end(), ByPair);
    }
    // Characters piled into each other: their pairs, tested afresh every frame, cost more than
    // one cache over the whole space would hold; run the space as one set for a while.
    if (cross_candidates > kGroupsCrossMax * n + 1024) ctx.groups_pause_ = kGroupsPause;
    ctx.method_ = BroadPhaseMethod::kGroups;
    ctx.last_candidates_ = candidates + cross_candidates;
    ctx.last_build_tests_ = tests + cross_candidates;
    ctx.build_count_ += builds;
    ctx.last_lookahead_ = float(lookahead / double(groups));
  }

  bool Run() {
    ctx.method_ = BroadPhaseMethod::kNone;
    ctx.last_candidates_ = 0;
    ctx.last_build_tests_ = 0;
    float sum[3];
    if (!k.check_values(spheres, n, internal::kMaxMagnitude, sum)) return false;
    if (n < 2 || NoPairAllowed(filter)) return true;
    if (UseGroups() && ctx.groups_pause_ == 0 && SetUpGroups()) {
      RunGroups();
      return true;
    }
    if (ctx.groups_pause_ > 0) --ctx.groups_pause_;
    const bool same_set = ctx.cache_valid_ && ctx.cache_count_ == n && ctx.cache_filter_ == filter.id();
    if (same_set) {
      ++ctx.age_;
      if (CacheHolds(sum)) {
        ctx.method_ = BroadPhaseMethod::kCached;
        TestCache();
        return true;
      }
      AdaptLookahead(ExpiredCacheCost(), ctx.age_);
    }
    if (ctx.rung_ == 0 && n <= kAllPairsMax) {
      // No cache pays: all pairs into the output.
      ctx.cache_valid_ = false;
      Direct();
      AdaptLookahead(kAllPairsSphereWork * double(n) + kPairTestWork * double(ctx.last_build_tests_) +
                         kPairWork * double(job.out->size()),
                     1);
      return true;
    }
    if (!Build(same_set, sum)) {
      Direct();
      return true;
    }
    ctx.build_cost_ = (n <= kAllPairsMax ? kAllPairsSphereWork : kSweepSphereWork) * double(n) +
                      kPairTestWork * double(ctx.last_build_tests_) + kPairWork * double(ctx.candidate_count_) +
                      kTestWork * double(ctx.candidate_count_);
    TestCache();
    return true;
  }
};

bool SelfCollisionJob::Validate() const {
  if (filter == nullptr || context == nullptr || out == nullptr) return false;
  if (spheres.size() != filter->size()) return false;
  if (spheres.size() > context->max_spheres()) return false;
  if (spheres.data() == nullptr && !spheres.empty()) return false;
  if (!BroadPhaseSimdSupported(simd)) return false;
  return true;
}

bool SelfCollisionJob::Run() const {
  if (out != nullptr) out->clear();
  if (!Validate()) {
    if (context != nullptr) context->method_ = BroadPhaseMethod::kNone;
    return false;
  }
  BroadPhaseContext::Impl impl(*this, KernelsFor(simd));
  return impl.Run();
}

}  // namespace skinspheres::runtime
