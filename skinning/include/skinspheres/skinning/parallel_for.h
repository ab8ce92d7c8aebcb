// ParallelFor: the one seam between skinspheres' per-frame work and a thread pool.
//
// Every parallel entry point (the jobs' RunParallel, CrowdUpdateAndFindSpherePairs, ...) takes a
// `const ParallelFor&`, so an engine runs the work on its own job system; by default it runs under
// TBB (DefaultParallelFor()), or serially on the calling thread in a build configured with
// -DSKINSPHERES_WITH_TBB=OFF (which never links TBB).
//
// Contract of a ParallelFor `pf`: pf(count, grain, body) calls body(begin, end) on ranges that are
// disjoint and together cover [0, count) exactly once, and returns when every call has returned.
// The calls may run concurrently, on any threads, in any order; grain (>= 1) is the smallest
// range worth a task (a hint: any split is correct). count may be 0. Every entry point computes
// each item by the same instructions whatever the split, so results are identical for any
// ParallelFor, thread count and grain. A ParallelFor must not throw.
//
// Cost: calling one allocates nothing (RangeBody is a non-owning reference; keep the
// ParallelFor itself alive across frames rather than building a std::function per frame).
//
//   // An engine's pool, e.g. with a blocking "parallel for" of its own:
//   skinspheres::ParallelFor pf = [&pool](size_t count, size_t grain, skinspheres::RangeBody body) {
//     pool.ForEachRange(count, grain, [body](size_t b, size_t e) { body(b, e); });
//   };
//   CrowdUpdateAndFindSpherePairs(instances, inputs, RefitMode::kFast, pf);
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <type_traits>

namespace skinspheres {

// A non-owning reference to a callable `void(size_t begin, size_t end)`. Valid while the callable
// it was made from lives (for the duration of one ParallelFor call). Copying it is free.
class RangeBody {
 public:
  template <typename F, typename = std::enable_if_t<!std::is_same_v<std::decay_t<F>, RangeBody>>>
  RangeBody(F&& f)  // NOLINT(google-explicit-constructor): made implicitly from a lambda
      : object_(static_cast<const void*>(std::addressof(f))), call_([](const void* o, size_t begin, size_t end) {
          using Callable = std::remove_reference_t<F>;
          (*static_cast<Callable*>(const_cast<void*>(o)))(begin, end);
        }) {}
  void operator()(size_t begin, size_t end) const { call_(object_, begin, end); }

 private:
  const void* object_;
  void (*call_)(const void*, size_t, size_t);
};

using ParallelFor = std::function<void(size_t count, size_t grain, RangeBody body)>;

// TBB's parallel_for in the calling thread's task arena (limit threads with tbb::task_arena); in a
// build without TBB (SKINSPHERES_WITH_TBB=OFF) the same as SerialFor(); in a ThreadSanitizer build
// of the library, a fixed pool of std::threads the checker can see (it cannot see inside TBB).
const ParallelFor& DefaultParallelFor();
// Whether DefaultParallelFor() runs on TBB in this build of the library.
bool DefaultParallelForUsesTbb();
// Runs body(0, count) on the calling thread: for tests, and for callers that want no threads.
const ParallelFor& SerialFor();

}  // namespace skinspheres
