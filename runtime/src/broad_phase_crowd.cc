// Crowds: many characters' self-collision jobs, one after the other or under tbb::parallel_for.
// Each job touches only its own context and output, so the result does not depend on the
// scheduling (ENGINEERING.md §4: threading stays outside the job body).
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <atomic>

#include "skinspheres/runtime/broad_phase.h"

namespace skinspheres::runtime {

bool RunSelfCollisionJobRange(std::span<const SelfCollisionJob> jobs, size_t begin, size_t end) {
  bool ok = begin <= end && end <= jobs.size();
  if (!ok) return false;
  for (size_t k = begin; k < end; ++k) ok &= jobs[k].Run();
  return ok;
}

bool RunSelfCollisionJobs(std::span<const SelfCollisionJob> jobs) {
  std::atomic<bool> ok{true};
  tbb::parallel_for(tbb::blocked_range<size_t>(0, jobs.size(), 1),
                    [&](const tbb::blocked_range<size_t>& range) {
                      if (!RunSelfCollisionJobRange(jobs, range.begin(), range.end())) {
                        ok.store(false, std::memory_order_relaxed);
                      }
                    });
  return ok.load();
}

}  // namespace skinspheres::runtime
