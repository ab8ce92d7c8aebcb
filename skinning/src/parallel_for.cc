#include "skinspheres/skinning/parallel_for.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>

namespace skinspheres {

const ParallelFor& DefaultParallelFor() {
  static const ParallelFor tbb_for = [](size_t count, size_t grain, RangeBody body) {
    if (count == 0) return;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, count, std::max<size_t>(grain, 1)),
                      [body](const tbb::blocked_range<size_t>& r) { body(r.begin(), r.end()); });
  };
  return tbb_for;
}

const ParallelFor& SerialFor() {
  static const ParallelFor serial = [](size_t count, size_t, RangeBody body) {
    if (count > 0) body(0, count);
  };
  return serial;
}

}  // namespace skinspheres
