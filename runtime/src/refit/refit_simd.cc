// Which SIMD level the fast refit runs at (refit_internal.h): what the host supports, a pinned level
// for tests and benchmarks, and the lanes of a crowd batch.
#include <atomic>
#include <cstddef>

#include "refit/refit_internal.h"
#include "skinspheres/skinning/platform.h"

namespace skinspheres::runtime {

namespace internal {

namespace {
std::atomic<RefitSimd> g_pinned{RefitSimd::kAuto};
}  // namespace

bool RefitSimdSupported(RefitSimd level) {
  switch (level) {
    case RefitSimd::kAuto:
    case RefitSimd::kPortable: return true;
#if defined(SKINSPHERES_X86_64)
    case RefitSimd::kSse2: return true;
    case RefitSimd::kAvx2: return HostCpu().avx2;
    case RefitSimd::kAvx512: return HostCpu().avx512f;
#endif
    default: return false;
  }
}

namespace {
thread_local RefitSimd t_last_run = RefitSimd::kAuto;
}  // namespace

RefitSimd LastRefitSimdRun() { return t_last_run; }
void NoteRefitSimdRun(RefitSimd level) { t_last_run = level; }

RefitSimd RefitSimdInUse() {
  const RefitSimd pinned = g_pinned.load(std::memory_order_relaxed);
  if (pinned != RefitSimd::kAuto) return pinned;
  static const RefitSimd best = RefitSimdSupported(RefitSimd::kAvx512) ? RefitSimd::kAvx512
                                : RefitSimdSupported(RefitSimd::kAvx2) ? RefitSimd::kAvx2
                                : RefitSimdSupported(RefitSimd::kSse2) ? RefitSimd::kSse2
                                                                       : RefitSimd::kPortable;
  return best;
}

bool PinRefitSimd(RefitSimd level) {
  if (!RefitSimdSupported(level)) return false;
  g_pinned.store(level, std::memory_order_relaxed);
  return true;
}

const char* ToString(RefitSimd level) {
  switch (level) {
    case RefitSimd::kAuto: return "auto";
    case RefitSimd::kSse2: return "sse2";
    case RefitSimd::kAvx2: return "avx2";
    case RefitSimd::kAvx512: return "avx512 (crowd batches; avx2 alone)";
    case RefitSimd::kPortable: return "portable";
  }
  return "unknown";
}

}  // namespace internal

namespace internal {

size_t RefitBatchLanes(RefitSimd level) {
  switch (level == RefitSimd::kAuto ? RefitSimdInUse() : level) {
#if defined(SKINSPHERES_X86_64)
    case RefitSimd::kAvx512: return 16;
    case RefitSimd::kAvx2: return 8;
#endif
    default: return 4;  // SSE2 and portable
  }
}

bool RefitBatchUsable() { return RefitBatchLanes() > 1; }

}  // namespace internal

}  // namespace skinspheres::runtime
