// Crowds: many characters' broad-phase jobs, one after the other or through a ParallelFor.
// Each job touches only its own context and output, so the result does not depend on the
// scheduling (threading stays outside the job body).
#include <atomic>

#include "skinspheres/runtime/broad_phase/broad_phase.h"

namespace skinspheres::runtime {

bool RunRange(std::span<const BroadPhaseJob> jobs, size_t begin, size_t end) {
  bool ok = begin <= end && end <= jobs.size();
  if (!ok) return false;
  for (size_t k = begin; k < end; ++k) ok &= jobs[k].Run();
  return ok;
}

bool RunParallel(std::span<const BroadPhaseJob> jobs, const ParallelFor& parallel_for) {
  std::atomic<bool> ok{true};
  parallel_for(jobs.size(), 1, [&](size_t begin, size_t end) {
    if (!RunRange(jobs, begin, end)) ok.store(false, std::memory_order_relaxed);
  });
  return ok.load();
}

}  // namespace skinspheres::runtime
