// DefaultParallelFor: TBB's parallel_for when built with SKINSPHERES_WITH_TBB, otherwise the
// serial loop (the library then never references TBB); in a ThreadSanitizer build, a pool of
// std::threads (below). SerialFor: the calling thread.
#include "skinspheres/skinning/parallel_for.h"

#if SKINSPHERES_WITH_TBB && !defined(__SANITIZE_THREAD__)
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#endif

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <mutex>
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
// the ranges on a fixed pool of std::threads synchronised by a mutex and condition variables (what
// the checker sees), so what it reports are races in skinspheres' own code. The pool starts on the
// first call and a call allocates nothing, like the TBB default (the soak counts allocations). With
// or without SKINSPHERES_WITH_TBB.
namespace {

constexpr auto kNoRanges = [](size_t, size_t) {};

class CheckedPool {
 public:
  CheckedPool() {
    const unsigned threads = std::max(2u, std::thread::hardware_concurrency());
    for (unsigned t = 1; t < threads; ++t) workers_.emplace_back([this] { Serve(); });
  }
  ~CheckedPool() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    for (auto& t : workers_) t.join();
  }

  void Run(size_t count, size_t grain, RangeBody body) {
    if (count == 0) return;
    grain = std::max<size_t>(grain, 1);
    const size_t chunks = (count + grain - 1) / grain;
    // One call at a time uses the pool: a nested call (from a range body) or one from another
    // thread runs its ranges on its own thread.
    std::unique_lock<std::mutex> busy(run_, std::try_to_lock);
    if (!busy.owns_lock() || chunks == 1) {
      body(0, count);
      return;
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      job_ = Job{count, grain, chunks, body};
      next_ = 0;
      working_ = workers_.size();
      ++generation_;
    }
    wake_.notify_all();
    Ranges(job_);
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [this] { return working_ == 0; });
  }

 private:
  struct Job {
    size_t count = 0, grain = 1, chunks = 0;
    RangeBody body = kNoRanges;
  };

  void Ranges(const Job& job) {
    for (size_t c = next_++; c < job.chunks; c = next_++)
      job.body(c * job.grain, std::min(job.count, (c + 1) * job.grain));
  }

  void Serve() {
    uint64_t seen = 0;
    for (;;) {
      Job job;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [&] { return stop_ || generation_ != seen; });
        if (stop_) return;
        seen = generation_;
        job = job_;
      }
      Ranges(job);
      std::lock_guard<std::mutex> lock(mutex_);
      if (--working_ == 0) done_.notify_one();
    }
  }

  std::mutex run_;    // held by the call using the pool
  std::mutex mutex_;  // guards everything below but next_
  std::condition_variable wake_, done_;
  std::vector<std::thread> workers_;
  Job job_;
  std::atomic<size_t> next_{0};  // next chunk of job_
  size_t working_ = 0;           // workers not yet done with job_
  uint64_t generation_ = 0;      // bumped for each job
  bool stop_ = false;
};

}  // namespace

const ParallelFor& DefaultParallelFor() {
  static CheckedPool pool;  // destroyed after thread_for (constructed before it)
  static const ParallelFor thread_for = [](size_t count, size_t grain, RangeBody body) {
    pool.Run(count, grain, body);
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
