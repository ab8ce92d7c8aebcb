// A ParallelFor for the benchmarks that runs on exactly `threads` threads (its own TBB arena) and
// measures, per thread, the CPU time spent inside the work (CLOCK_THREAD_CPUTIME_ID around every
// body call). Next to the wall time this tells real parallel work from a second core that was
// busy elsewhere: two threads each near the wall time means both cores worked; a second thread
// near zero means the first did it all (and the wall time shows it).
//
//   TimedParallelFor pf(2);
//   for (auto _ : state) RunParallel(jobs, pf.get());
//   pf.Report(state);   // counters cpu_t0_ms, cpu_t1_ms (per iteration, heaviest thread first), cpu_sum_ms
#pragma once

#include <benchmark/benchmark.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <time.h>

#include <algorithm>
#include <functional>
#include <string>
#include <vector>

#include "skinspheres/skinning/parallel_for.h"

namespace skinspheres::bench {

inline double ThreadCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

class TimedParallelFor {
 public:
  explicit TimedParallelFor(int threads) : arena_(threads), slots_(size_t(threads) + 1) {
    for_ = [this](size_t count, size_t grain, RangeBody body) {
      if (count == 0) return;
      arena_.execute([&] {
        tbb::parallel_for(tbb::blocked_range<size_t>(0, count, std::max<size_t>(grain, 1)),
                          [&](const tbb::blocked_range<size_t>& r) {
                            const double t0 = ThreadCpuSeconds();
                            body(r.begin(), r.end());
                            const int slot = tbb::this_task_arena::current_thread_index();
                            Slot& s = slots_[size_t(std::clamp(slot, 0, int(slots_.size()) - 1))];
                            s.seconds += ThreadCpuSeconds() - t0;
                          });
      });
    };
  }
  const ParallelFor& get() const { return for_; }
  void Reset() {
    for (Slot& s : slots_) s.seconds = 0.0;
  }
  // Per-iteration CPU milliseconds of each thread (heaviest first) and their sum, as counters.
  void Report(benchmark::State& state) const {
    std::vector<double> ms;
    for (const Slot& s : slots_) ms.push_back(s.seconds * 1e3 / double(std::max<int64_t>(state.iterations(), 1)));
    std::sort(ms.begin(), ms.end(), std::greater<>());
    double sum = 0.0;
    for (size_t t = 0; t + 1 < slots_.size(); ++t) {
      state.counters["cpu_t" + std::to_string(t) + "_ms"] = ms[t];
      sum += ms[t];
    }
    state.counters["cpu_sum_ms"] = sum + ms.back();
  }

 private:
  struct alignas(64) Slot {
    double seconds = 0.0;
  };
  tbb::task_arena arena_;
  std::vector<Slot> slots_;  // one per arena slot (+1 spare)
  ParallelFor for_;
};

}  // namespace skinspheres::bench
