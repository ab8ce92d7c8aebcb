// DefaultParallelFor: TBB's parallel_for when built with SKINSPHERES_WITH_TBB, otherwise the
// serial loop (the library then never references TBB); in a ThreadSanitizer build, std::threads
// (below). SerialFor: the calling thread.
#include "skinspheres/skinning/parallel_for.h"

#if SKINSPHERES_WITH_TBB && !defined(__SANITIZE_THREAD__)
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#endif

#include <algorithm>
#include <atomic>
#include <thread>
#include <vector>

namespace skinspheres {

const ParallelFor& SerialFor() {
  static const ParallelFor serial = [](size_t count, size_t, RangeBody body) {
    if (count > 0) body(0, count);
  };
  return serial;
}

#if defined(__SANITIZE_THREAD__)
// ThreadSanitizer build (.ci/run's TSan stage): TBB is a prebuilt library the checker cannot see
// into, so it would report every hand-over between TBB's threads as a race. Here the default runs
// the ranges on std::threads it starts and joins (synchronisation the checker sees), so what it
// reports are races in skinspheres' own code. With or without SKINSPHERES_WITH_TBB.
const ParallelFor& DefaultParallelFor() {
  static const ParallelFor thread_for = [](size_t count, size_t grain, RangeBody body) {
    if (count == 0) return;
    grain = std::max<size_t>(grain, 1);
    const size_t chunks = (count + grain - 1) / grain;
    const size_t threads = std::min<size_t>(chunks, std::max(2u, std::thread::hardware_concurrency()));
    std::atomic<size_t> next{0};
    auto work = [&] {
      for (size_t c = next++; c < chunks; c = next++) body(c * grain, std::min(count, (c + 1) * grain));
    };
    std::vector<std::thread> pool;
    for (size_t t = 1; t < threads; ++t) pool.emplace_back(work);
    work();
    for (auto& t : pool) t.join();
  };
  return thread_for;
}
bool DefaultParallelForUsesTbb() { return false; }
#elif SKINSPHERES_WITH_TBB
const ParallelFor& DefaultParallelFor() {
  static const ParallelFor tbb_for = [](size_t count, size_t grain, RangeBody body) {
    if (count == 0) return;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, count, std::max<size_t>(grain, 1)),
                      [body](const tbb::blocked_range<size_t>& r) { body(r.begin(), r.end()); });
  };
  return tbb_for;
}
bool DefaultParallelForUsesTbb() { return true; }
#else
const ParallelFor& DefaultParallelFor() { return SerialFor(); }
bool DefaultParallelForUsesTbb() { return false; }
#endif

}  // namespace skinspheres
