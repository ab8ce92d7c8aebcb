// ParallelFor (parallel_for.h): the default (TBB) and serial loops cover [0, count) exactly once
// for any count and grain; RangeBody calls the callable it refers to.
#include <gtest/gtest.h>

#include <atomic>
#include <vector>

#include "skinspheres/skinning/parallel_for.h"
#include "test_support.h"

namespace skinspheres {
namespace {

void ExpectCoversOnce(const ParallelFor& pf, size_t count, size_t grain) {
  std::vector<std::atomic<int>> hits(count);
  std::atomic<int> calls{0};
  pf(count, grain, [&](size_t begin, size_t end) {
    EXPECT_LT(begin, end);
    EXPECT_LE(end, count);
    ++calls;
    for (size_t i = begin; i < end; ++i) ++hits[i];
  });
  for (size_t i = 0; i < count; ++i) ASSERT_EQ(hits[i].load(), 1) << "item " << i << " of " << count;
  if (count == 0) {
    EXPECT_EQ(calls.load(), 0);
  }
}

TEST(ParallelForTest, DefaultSerialAndEngineStyleCoverEveryItemOnce) {
  const ParallelFor engine = test::EngineStyleFor(3);
  for (const ParallelFor* pf : {&DefaultParallelFor(), &SerialFor(), &engine}) {
    for (size_t count : {0, 1, 2, 7, 64, 1000, 100003}) {
      for (size_t grain : {0, 1, 3, 64, 5000}) ExpectCoversOnce(*pf, count, grain);
    }
  }
}

TEST(ParallelForTest, SerialForRunsOneRangeOnTheCallingThread) {
  int calls = 0;
  SerialFor()(10, 1, [&](size_t begin, size_t end) {
    ++calls;
    EXPECT_EQ(begin, 0u);
    EXPECT_EQ(end, 10u);
  });
  EXPECT_EQ(calls, 1);
}

TEST(ParallelForTest, RangeBodyRefersToItsCallable) {
  size_t sum = 0;
  auto add = [&](size_t begin, size_t end) { sum += end - begin; };
  const RangeBody body(add);
  const RangeBody copy = body;
  copy(2, 5);
  body(0, 1);
  EXPECT_EQ(sum, 4u);
}

}  // namespace
}  // namespace skinspheres
