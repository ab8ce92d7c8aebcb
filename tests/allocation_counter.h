// Counting replacements of the global operator new / delete, for tests of "no allocation per frame"
// and "no allocation larger than the input justifies". Include in exactly one source file of a test
// executable: it defines the replacements (malloc/free underneath, so every new/delete pair matches).
#pragma once
// The replacements pair malloc/free; GCC 12 flags the inlined pairs falsely.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"

#include <atomic>
#include <cstddef>
#include <cstdlib>
#include <new>

namespace skinspheres::test {

// While one is alive, every operator new on any thread is counted, its bytes summed and the largest
// size kept.
// One at a time.
class AllocationCounter {
 public:
  AllocationCounter() {
    count_ = 0;
    bytes_ = 0;
    largest_ = 0;
    active_ = true;
  }
  ~AllocationCounter() { active_ = false; }
  AllocationCounter(const AllocationCounter&) = delete;
  AllocationCounter& operator=(const AllocationCounter&) = delete;

  long count() const { return count_.load(); }
  size_t bytes() const { return bytes_.load(); }
  size_t largest() const { return largest_.load(); }

  static void Note(size_t size) {
    if (!active_.load(std::memory_order_relaxed)) return;
    count_.fetch_add(1, std::memory_order_relaxed);
    bytes_.fetch_add(size, std::memory_order_relaxed);
    size_t seen = largest_.load(std::memory_order_relaxed);
    while (size > seen && !largest_.compare_exchange_weak(seen, size, std::memory_order_relaxed)) {
    }
  }

 private:
  static inline std::atomic<bool> active_{false};
  static inline std::atomic<long> count_{0};
  static inline std::atomic<size_t> bytes_{0};
  static inline std::atomic<size_t> largest_{0};
};

}  // namespace skinspheres::test

void* operator new(size_t size) {
  skinspheres::test::AllocationCounter::Note(size);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, size_t) noexcept { std::free(p); }
// The nothrow forms too (std::stable_sort's buffer uses them): every new/delete pair must match.
void* operator new(size_t size, const std::nothrow_t&) noexcept {
  skinspheres::test::AllocationCounter::Note(size);
  return std::malloc(size == 0 ? 1 : size);
}
void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }
