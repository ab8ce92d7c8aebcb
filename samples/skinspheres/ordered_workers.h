// RunOrdered: clips handled on several threads, their results reported in order (what `check`
// and `fix` do with a library of clips).
#pragma once

#include <atomic>
#include <cstddef>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace skinspheres::tool {

// Calls work(k, state) for every k in [0, count) on `jobs` threads (the calling one included), each
// thread with its own state from make_state() (a player, a fixer: made once per thread); done(k),
// under a lock, for each k as soon as it and every one before it are finished, in order.
template <class MakeState, class Work>
void RunOrdered(size_t count, int jobs, MakeState make_state, Work work, const std::function<void(size_t)>& done) {
  std::mutex mutex;
  std::vector<char> finished(count, 0);
  std::atomic<size_t> next{0};
  size_t reported = 0;
  auto worker = [&]() {
    auto state = make_state();
    for (size_t k = next++; k < count; k = next++) {
      work(k, state);
      std::lock_guard<std::mutex> lock(mutex);
      finished[k] = 1;
      while (reported < count && finished[reported]) done(reported++);
    }
  };
  std::vector<std::thread> threads;
  for (int t = 1; t < jobs; ++t) threads.emplace_back(worker);
  worker();
  for (auto& t : threads) t.join();
}

}  // namespace skinspheres::tool
