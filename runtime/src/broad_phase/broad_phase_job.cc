// Self-collision broad phase (broad_phase.h has the contract): the job, the context, the choice of
// instruction set, and one frame's steps in order (broad_phase/frame.h lists them and the files
// that hold them; broad_phase/kernels.inc has the SIMD loops).
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
//   4. the exact sphere test on the candidates, in order: the sphere pairs come out sorted.
//
// Rounding. The build accepts every pair whose grown spheres truly touch: its float test errs by a
// few units of 2^-24 relative to the distances, far below the 2^-16 growth. The check's float
// error is at most ~8u relative to the moved distance plus 2u |shift| (each subtraction is exactly
// rounded relative to its result), covered by allowing only skin (1 - 2^-16) - 2^-20 |shift|. A
// pair the exact float test accepts is within (r_i + r_j)(1 + 4u) in reals, also covered. So a
// frame's sphere pairs are exactly the oracle's whatever the cache's history.
#include <algorithm>
#include <memory>
#include <utility>

#include "broad_phase/context_state.h"
#include "broad_phase/frame.h"
#include "broad_phase/kernels.h"
#include "broad_phase/sphere_test.h"
#include "skinspheres/runtime/broad_phase/broad_phase.h"
#include "skinspheres/skinning/platform.h"

namespace skinspheres::runtime {
namespace {

using namespace broad_phase;  // the frame's constants and helpers (frame.h)

const kernels::Kernels& KernelsFor(SimdLevel level) {
  switch (ResolveBroadPhaseSimd(level)) {
#if defined(SKINSPHERES_X86_64)
    case SimdLevel::kAvx512: return kernels::Avx512Kernels();
    case SimdLevel::kAvx2: return kernels::Avx2Kernels();
    case SimdLevel::kSse2: return kernels::Sse2Kernels();
#endif
    default: return kernels::PortableKernels();
  }
}

}  // namespace

SimdLevel ResolveBroadPhaseSimd(SimdLevel level) {
  if (level != SimdLevel::kAuto) return level;
  if (SimdLevelSupported(SimdLevel::kAvx512)) return SimdLevel::kAvx512;
  if (SimdLevelSupported(SimdLevel::kAvx2)) return SimdLevel::kAvx2;
#if defined(SKINSPHERES_X86_64)
  return SimdLevel::kSse2;
#else
  return SimdLevel::kPortable;
#endif
}

const char* ToString(BroadPhaseMethod method) {
  switch (method) {
    case BroadPhaseMethod::kNone: return "none";
    case BroadPhaseMethod::kCached: return "cached";
    case BroadPhaseMethod::kAllPairsBuild: return "all-pairs build";
    case BroadPhaseMethod::kSweepBuild: return "sweep build";
    case BroadPhaseMethod::kAllPairsDirect: return "all-pairs direct";
    case BroadPhaseMethod::kSweepDirect: return "sweep direct";
    case BroadPhaseMethod::kGroups: return "groups";
  }
  return "unknown";
}

BroadPhaseContext::BroadPhaseContext() : state_(std::make_unique<State>()) {}
BroadPhaseContext::BroadPhaseContext(size_t max_spheres, size_t max_candidates) { Resize(max_spheres, max_candidates); }
BroadPhaseContext::~BroadPhaseContext() = default;
BroadPhaseContext::BroadPhaseContext(const BroadPhaseContext& other)
    : state_(other.state_ ? std::make_unique<State>(*other.state_) : nullptr) {}
BroadPhaseContext& BroadPhaseContext::operator=(const BroadPhaseContext& other) {
  if (this != &other) state_ = other.state_ ? std::make_unique<State>(*other.state_) : nullptr;
  return *this;
}
BroadPhaseContext::BroadPhaseContext(BroadPhaseContext&&) noexcept = default;
BroadPhaseContext& BroadPhaseContext::operator=(BroadPhaseContext&&) noexcept = default;

// (A moved-from context has no state: it reads as empty, and Resize gives it one.)
size_t BroadPhaseContext::max_spheres() const { return state_ ? state_->max_spheres : 0; }
size_t BroadPhaseContext::max_candidates() const { return state_ ? state_->max_candidates : 0; }
BroadPhaseMethod BroadPhaseContext::last_method() const {
  return state_ ? state_->last.method : BroadPhaseMethod::kNone;
}
size_t BroadPhaseContext::last_candidate_count() const { return state_ ? state_->last.candidates : 0; }
size_t BroadPhaseContext::last_build_tests() const { return state_ ? state_->last.build_tests : 0; }
int BroadPhaseContext::sweep_axis() const { return state_ ? state_->scratch.axis : -1; }
bool BroadPhaseContext::last_full_sort() const { return state_ && state_->last.full_sort; }
uint64_t BroadPhaseContext::build_count() const { return state_ ? state_->last.builds : 0; }
float BroadPhaseContext::last_lookahead() const { return state_ ? state_->lookahead.last : 0.0f; }

void BroadPhaseContext::Resize(size_t max_spheres, size_t max_candidates) {
  if (!state_) state_ = std::make_unique<State>();
  State& st = *state_;
  st.max_spheres = max_spheres;
  if (max_candidates == 0) {
    const size_t all_pairs = max_spheres * (max_spheres > 0 ? max_spheres - 1 : 0) / 2;
    max_candidates = std::min(all_pairs, 16 * max_spheres + 256);
  }
  // A direct sweep needs room for one sphere's whole range.
  st.max_candidates = std::max(max_candidates, max_spheres + kPad);
  const size_t padded = max_spheres + kPad;
  st.cache.i.assign(st.max_candidates + kPad, 0);
  st.cache.j.assign(st.max_candidates + kPad, 0);
  st.cache.ref.assign(4 * padded, 0.0f);
  st.cache.allow.assign(padded, 0.0f);
  st.cache.motion.assign(padded, 0.0f);
  st.cache.speed.assign(max_spheres, 0.0f);
  st.scratch.soa.assign(kSoaFields * padded, 0.0f);
  st.scratch.sphere.assign(padded, 0);
  st.scratch.row.assign(max_spheres + 1, 0);
  if (max_spheres > kAllPairsMax) {
    st.scratch.order.assign(max_spheres, broad_phase::SortItem{0, 0, 0});
    st.scratch.order_by_strip.assign(max_spheres, broad_phase::SortItem{0, 0, 0});
    st.scratch.runs.assign(max_spheres, broad_phase::ColumnRun{0, 0, 0});
    st.scratch.pairs_i.assign(st.max_candidates + kPad, 0);
    st.scratch.pairs_j.assign(st.max_candidates + kPad, 0);
    // The sweep's bits, with room for the all-pairs rows of any set of up to kAllPairsMax spheres
    // (a context this large may run a small set; no extra memory from 576 spheres up).
    st.listed.bits.assign(std::max(kernels::kNearWords * max_spheres, AllPairsRowWords(kAllPairsMax) * kAllPairsMax),
                          0);
    st.listed.far.assign(max_spheres, 0);
  } else {
    st.scratch.order.clear();
    st.scratch.order_by_strip.clear();
    st.scratch.runs.clear();
    st.scratch.pairs_i.clear();
    st.scratch.pairs_j.clear();
    st.listed.bits.assign(AllPairsRowWords(max_spheres) * max_spheres, 0);  // the all-pairs kernels' bit rows
    st.listed.far.clear();
  }
  st.listed.sphere_count = 0;
  st.stage.assign(kStage + kPad, SpherePair{});
  st.groups.contexts.clear();
  st.groups.filters.clear();
  st.groups.filter = 0;
  st.groups.pause = 0;
  Invalidate();
  st.lookahead.rung = 3;
  std::fill(st.lookahead.rung_cost, st.lookahead.rung_cost + kRungs, 0.0);
  st.last.method = BroadPhaseMethod::kNone;
  st.last.candidates = 0;
  st.last.build_tests = 0;
  st.last.full_sort = false;
  st.last.builds = 0;
}

void BroadPhaseContext::Invalidate() {
  if (!state_) return;
  State& st = *state_;
  st.cache.valid = false;
  st.cache.sphere_count = 0;
  st.cache.filter = 0;
  st.cache.age = 0;
  st.cache.count = 0;
  st.scratch.order_count = 0;
  st.scratch.axis = -1;
  st.scratch.cell = 0.0;
  st.cache.build_cost = 0.0;
  for (BroadPhaseContext& c : st.groups.contexts) c.Invalidate();
  st.groups.pause = 0;
}

namespace broad_phase {

Frame::Frame(const BroadPhaseJob& j, const kernels::Kernels& kernels)
    : job(j),
      st(*j.context->state_),
      k(kernels),
      filter(*j.filter),
      view(View(*j.filter)),
      n(j.spheres.size()),
      spheres(reinterpret_cast<const float*>(j.spheres.data())),
      padded(j.spheres.size() + kPad) {}

bool Frame::Run() {
  st.last.method = BroadPhaseMethod::kNone;
  st.last.candidates = 0;
  st.last.build_tests = 0;
  float sum[3];
  if (!k.check_values(spheres, n, internal::kMaxMagnitude, sum)) return false;
  if (n < 2 || NoPairAllowed(filter)) return true;
  if (UseGroups() && st.groups.pause == 0 && SetUpGroups()) {
    RunGroups();
    return true;
  }
  if (st.groups.pause > 0) --st.groups.pause;
  const bool same_set = st.cache.valid && st.cache.sphere_count == n && st.cache.filter == filter.id();
  if (same_set) {
    ++st.cache.age;
    if (CacheHolds(sum)) {
      st.last.method = BroadPhaseMethod::kCached;
      TestCache();
      return true;
    }
    AdaptLookahead(ExpiredCacheCost(), st.cache.age);
  }
  if (st.lookahead.rung == 0 && n <= kAllPairsMax) {
    // No cache pays: all pairs into the output.
    st.cache.valid = false;
    Direct();
    AdaptLookahead(kAllPairsSphereWork * double(n) + kPairTestWork * double(st.last.build_tests) +
                       kPairWork * double(job.out->size()),
                   1);
    return true;
  }
  if (!Build(same_set, sum)) {
    Direct();
    return true;
  }
  st.cache.build_cost = (n <= kAllPairsMax ? kAllPairsSphereWork : kSweepSphereWork) * double(n) +
                        kPairTestWork * double(st.last.build_tests) + kPairWork * double(st.cache.count) +
                        kTestWork * double(st.cache.count);
  TestCache();
  return true;
}

}  // namespace broad_phase

bool BroadPhaseJob::Validate() const {
  if (filter == nullptr || context == nullptr || out == nullptr) return false;
  if (spheres.size() != filter->size()) return false;
  if (spheres.size() > context->max_spheres()) return false;
  if (spheres.data() == nullptr && !spheres.empty()) return false;
  if (!SimdLevelSupported(simd)) return false;
  return true;
}

bool BroadPhaseJob::Run() const {
  if (out != nullptr) out->clear();
  if (!Validate()) {
    if (context != nullptr && context->state_) context->state_->last.method = BroadPhaseMethod::kNone;
    return false;
  }
  return broad_phase::Frame(*this, KernelsFor(simd)).Run();
}

}  // namespace skinspheres::runtime
