// DefaultParallelFor: TBB's parallel_for when built with SKINSPHERES_WITH_TBB, otherwise the
// serial loop (the library then never references TBB). SerialFor: the calling thread.
#include "skinspheres/skinning/parallel_for.h"

#if SKINSPHERES_WITH_TBB
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#endif

#include <algorithm>

namespace skinspheres {

const ParallelFor& SerialFor() {
  static const ParallelFor serial = [](size_t count, size_t, RangeBody body) {
    if (count > 0) body(0, count);
  };
  return serial;
}

#if SKINSPHERES_WITH_TBB
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
