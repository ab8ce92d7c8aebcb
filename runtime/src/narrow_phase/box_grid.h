// Private: the pairs of boxes (one per triangle of a whole mesh) that come within a slack of each
// other, through a uniform grid: what the sphere-free oracle (narrow_phase.h,
// FindContactsBruteForce) starts from. Each box lists the cells its box grown by the slack covers; a pair is
// found in every cell both cover and reported only in the lowest of them, so once. A box covering more
// than kMaxCellsPerBox cells (a triangle much larger than the usual one) is tested against every
// other box instead. The cost is about the number of boxes plus the pairs sharing a cell.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace skinspheres::runtime::narrow_phase {

struct GridBox {
  float lo[3], hi[3];  // non-finite: the box is left out
};

class BoxGrid {
 public:
  static constexpr size_t kMaxCellsPerBox = 64;

  // The grid over these boxes, each grown by slack (finite, >= 0); the cell edge follows the boxes'
  // mean size. Allocates; boxes must outlive the grid.
  BoxGrid(std::span<const GridBox> boxes, float slack);

  // fn(a, b), a < b, once for every pair of finite boxes within the slack of each other on every axis
  // (float subtraction, as narrow_phase::BoxesMeet), in no particular order.
  template <class Fn>
  void ForEachPair(Fn&& fn) const;

 private:
  bool Meet(uint32_t a, uint32_t b) const {
    const GridBox &p = boxes_[a], &q = boxes_[b];
    for (int k = 0; k < 3; ++k) {
      if (!(p.lo[k] - q.hi[k] <= slack_ && q.lo[k] - p.hi[k] <= slack_)) return false;
    }
    return true;
  }
  std::span<const GridBox> boxes_;
  float slack_ = 0.0f;
  std::vector<std::array<uint32_t, 6>> cells_;  // per box: lowest and highest cell per axis
  struct Entry {
    uint64_t cell;  // (x << 42) | (y << 21) | z
    uint32_t box;
  };
  std::vector<Entry> entries_;   // every (cell, box) of the boxes in cells, sorted
  std::vector<uint32_t> big_;    // boxes tested against every other box (their cells_ all UINT32_MAX)
  std::vector<uint8_t> finite_;  // per box
};

template <class Fn>
void BoxGrid::ForEachPair(Fn&& fn) const {
  // Boxes sharing a cell, reported in the lowest cell both cover (the componentwise largest of their
  // lowest cells).
  for (size_t begin = 0; begin < entries_.size();) {
    const uint64_t cell = entries_[begin].cell;
    size_t end = begin + 1;
    while (end < entries_.size() && entries_[end].cell == cell) ++end;
    for (size_t x = begin; x < end; ++x) {
      const uint32_t a = entries_[x].box;
      for (size_t y = x + 1; y < end; ++y) {
        const uint32_t b = entries_[y].box;
        const auto &ca = cells_[a], &cb = cells_[b];
        const uint64_t lowest = (uint64_t{std::max(ca[0], cb[0])} << 42) | (uint64_t{std::max(ca[1], cb[1])} << 21) |
                                std::max(ca[2], cb[2]);
        if (lowest != cell || !Meet(a, b)) continue;
        fn(a, b);  // a < b: entries are sorted by box within a cell
      }
    }
    begin = end;
  }
  // The big boxes against every box (a pair of two big boxes once).
  for (size_t x = 0; x < big_.size(); ++x) {
    const uint32_t a = big_[x];
    for (uint32_t b = 0; b < boxes_.size(); ++b) {
      if (b == a || !finite_[b] || (cells_[b][0] == UINT32_MAX && b < a) || !Meet(a, b)) continue;
      fn(std::min(a, b), std::max(a, b));
    }
  }
}

}  // namespace skinspheres::runtime::narrow_phase
