// The uniform grid behind the sphere-free oracle (runtime/src/narrow_phase/box_grid.h) against the
// brute-force pairing of every box with every other under the same float test: the same pairs, each
// once, for boxes of mixed sizes (a few much larger than the rest, which the grid tests against
// everything), touching boxes, slacks from 0 up, and boxes with a non-finite coordinate (left out).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <set>
#include <utility>
#include <vector>

#include "narrow_phase/box_grid.h"  // runtime/src

namespace skinspheres::runtime::narrow_phase {
namespace {

bool Finite(const GridBox& b) {
  for (int k = 0; k < 3; ++k) {
    if (!std::isfinite(b.lo[k]) || !std::isfinite(b.hi[k])) return false;
  }
  return true;
}

// The grid's test, on finite boxes only.
bool Meet(const GridBox& p, const GridBox& q, float slack) {
  if (!Finite(p) || !Finite(q)) return false;
  for (int k = 0; k < 3; ++k) {
    if (!(p.lo[k] - q.hi[k] <= slack && q.lo[k] - p.hi[k] <= slack)) return false;
  }
  return true;
}

std::vector<GridBox> RandomBoxes(std::mt19937& rng, size_t n, float scale) {
  std::uniform_real_distribution<float> where(-scale, scale), size(0.0f, 0.02f * scale), unit(0.0f, 1.0f);
  std::vector<GridBox> boxes(n);
  for (GridBox& b : boxes) {
    const float grow = unit(rng) < 0.02f ? 40.0f : 1.0f;  // a few boxes far larger than the rest
    for (int k = 0; k < 3; ++k) {
      b.lo[k] = where(rng);
      b.hi[k] = b.lo[k] + grow * size(rng);
    }
  }
  // Two boxes that touch exactly on a face, and a point box inside another.
  boxes[1] = boxes[0];
  boxes[1].lo[0] = boxes[0].hi[0];
  boxes[1].hi[0] = boxes[0].hi[0] + 0.01f * scale;
  for (int k = 0; k < 3; ++k) boxes[3].lo[k] = boxes[3].hi[k] = 0.5f * (boxes[2].lo[k] + boxes[2].hi[k]);
  // Non-finite boxes meet nothing.
  boxes[4].lo[1] = std::numeric_limits<float>::quiet_NaN();
  boxes[5].hi[2] = std::numeric_limits<float>::infinity();
  return boxes;
}

TEST(BoxGrid, FindsExactlyTheBruteForcePairsOnce) {
  std::mt19937 rng(11);
  for (const float scale : {1.0f, 1000.0f}) {
    for (const float slack_share : {0.0f, 0.001f, 0.02f}) {
      const std::vector<GridBox> boxes = RandomBoxes(rng, 1500, scale);
      const float slack = slack_share * scale;
      std::set<std::pair<uint32_t, uint32_t>> expected;
      for (uint32_t a = 0; a < boxes.size(); ++a) {
        for (uint32_t b = a + 1; b < boxes.size(); ++b) {
          if (Meet(boxes[a], boxes[b], slack)) expected.insert({a, b});
        }
      }
      std::set<std::pair<uint32_t, uint32_t>> found;
      size_t calls = 0;
      const BoxGrid grid(boxes, slack);
      grid.ForEachPair([&](uint32_t a, uint32_t b) {
        ++calls;
        EXPECT_LT(a, b);
        found.insert({a, b});
      });
      EXPECT_EQ(calls, found.size()) << "a pair reported twice (scale " << scale << ", slack " << slack << ")";
      EXPECT_EQ(found, expected) << "scale " << scale << ", slack " << slack;
      EXPECT_TRUE(expected.count({0, 1})) << "boxes touching on a face meet";
      EXPECT_TRUE(expected.count({2, 3}));
      std::printf("[grid] scale %g slack %g: %zu pairs of %zu boxes\n", double(scale), double(slack), found.size(),
                  boxes.size());
    }
  }
}

TEST(BoxGrid, EmptyAndDegenerateInputs) {
  const BoxGrid none(std::span<const GridBox>{}, 0.0f);
  none.ForEachPair([](uint32_t, uint32_t) { ADD_FAILURE() << "no boxes, no pairs"; });
  // Every box the same point: one cell, every pair.
  std::vector<GridBox> same(20, GridBox{{1, 2, 3}, {1, 2, 3}});
  size_t pairs = 0;
  BoxGrid(same, 0.0f).ForEachPair([&](uint32_t, uint32_t) { ++pairs; });
  EXPECT_EQ(pairs, 20u * 19u / 2u);
}

}  // namespace
}  // namespace skinspheres::runtime::narrow_phase
