// Counts every operator new of the test executable that includes this header, for the tests that
// check that per-frame calls do not allocate. Include it from exactly one source file of an
// executable (it replaces the global operator new and delete). Counting is off until a test sets
// g_count_allocations, and costs one relaxed load per allocation otherwise.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdlib>
#include <new>

// The replaced new and delete pair malloc with free; GCC cannot see that through inlining.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"

namespace skinspheres::test {
inline std::atomic<bool> g_count_allocations{false};
inline std::atomic<size_t> g_allocations{0};
}  // namespace skinspheres::test

void* operator new(std::size_t size) {
  if (skinspheres::test::g_count_allocations.load(std::memory_order_relaxed)) {
    skinspheres::test::g_allocations.fetch_add(1, std::memory_order_relaxed);
  }
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
// The nothrow forms too (std::stable_sort's buffer uses them): every new/delete pair must match.
void* operator new(std::size_t size, const std::nothrow_t&) noexcept {
  if (skinspheres::test::g_count_allocations.load(std::memory_order_relaxed)) {
    skinspheres::test::g_allocations.fetch_add(1, std::memory_order_relaxed);
  }
  return std::malloc(size == 0 ? 1 : size);
}
void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }
