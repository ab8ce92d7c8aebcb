// Which SIMD level the fast refit runs at (refit_internal.h): what the host supports, a pinned level
// for tests and benchmarks, and the lanes of a crowd batch.
#include <atomic>
#include <cstddef>

#include "refit/refit_internal.h"
#include "skinspheres/skinning/platform.h"

namespace skinspheres::runtime {

namespace internal {

namespace {
std::atomic<SimdLevel> g_pinned{SimdLevel::kAuto};
}  // namespace

namespace {
thread_local SimdLevel t_last_run = SimdLevel::kAuto;
}  // namespace

SimdLevel LastRefitSimdRun() { return t_last_run; }
void NoteRefitSimdRun(SimdLevel level) { t_last_run = level; }

SimdLevel RefitSimdInUse() {
  const SimdLevel pinned = g_pinned.load(std::memory_order_relaxed);
  if (pinned != SimdLevel::kAuto) return pinned;
  static const SimdLevel best = SimdLevelSupported(SimdLevel::kAvx512) ? SimdLevel::kAvx512
                                : SimdLevelSupported(SimdLevel::kAvx2) ? SimdLevel::kAvx2
                                : SimdLevelSupported(SimdLevel::kSse2) ? SimdLevel::kSse2
                                                                       : SimdLevel::kPortable;
  return best;
}

bool PinRefitSimd(SimdLevel level) {
  if (!SimdLevelSupported(level)) return false;
  g_pinned.store(level, std::memory_order_relaxed);
  return true;
}

const char* RefitLevelName(SimdLevel level) {
  switch (level) {
    case SimdLevel::kAuto: return "auto";
    case SimdLevel::kSse2: return "sse2";
    case SimdLevel::kAvx2: return "avx2";
    case SimdLevel::kAvx512: return "avx512 (crowd batches; avx2 alone)";
    case SimdLevel::kPortable: return "portable";
  }
  return "unknown";
}

}  // namespace internal

namespace internal {

size_t RefitBatchLanes(SimdLevel level) {
  switch (level == SimdLevel::kAuto ? RefitSimdInUse() : level) {
#if defined(SKINSPHERES_X86_64)
    case SimdLevel::kAvx512: return 16;
    case SimdLevel::kAvx2: return 8;
#endif
    default: return 4;  // SSE2 and portable
  }
}

bool RefitBatchUsable() { return RefitBatchLanes() > 1; }

}  // namespace internal

}  // namespace skinspheres::runtime
