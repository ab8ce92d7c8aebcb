// Counts every operator new of the test executable that includes it, so a test can check that the
// calls between StartCountingAllocations() and AllocationsCounted() allocate nothing. Include it
// in exactly one source file per executable (it replaces the global operator new/delete, which
// must be defined once). The nothrow forms are replaced too: std::stable_sort's buffer uses them,
// and every new/delete pair must match.
#pragma once

// GCC 12 flags the inlined malloc/free pairs of the replaced operators as mismatched, falsely.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"

#include <atomic>
#include <cstdlib>
#include <new>

namespace skinspheres::test {
inline std::atomic<long> g_allocations{0};
inline std::atomic<bool> g_counting_allocations{false};

inline void StartCountingAllocations() {
  g_allocations = 0;
  g_counting_allocations = true;
}
// Stops counting; returns how many allocations happened since StartCountingAllocations().
inline long AllocationsCounted() {
  g_counting_allocations = false;
  return g_allocations.load();
}
}  // namespace skinspheres::test

void* operator new(std::size_t size) {
  if (skinspheres::test::g_counting_allocations.load(std::memory_order_relaxed)) {
    skinspheres::test::g_allocations.fetch_add(1, std::memory_order_relaxed);
  }
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void* operator new(std::size_t size, const std::nothrow_t&) noexcept {
  if (skinspheres::test::g_counting_allocations.load(std::memory_order_relaxed)) {
    skinspheres::test::g_allocations.fetch_add(1, std::memory_order_relaxed);
  }
  return std::malloc(size == 0 ? 1 : size);
}
void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }
