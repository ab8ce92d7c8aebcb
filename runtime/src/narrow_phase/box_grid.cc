// The uniform grid of box_grid.h: cells from the boxes' mean size, each box's cell range, the
// (cell, box) entries sorted.
#include "narrow_phase/box_grid.h"

#include <cmath>

namespace skinspheres::runtime::narrow_phase {

namespace {

constexpr uint32_t kAxisCells = (uint32_t{1} << 21) - 1;  // cells per axis at most: 21 bits of a key

}  // namespace

BoxGrid::BoxGrid(std::span<const GridBox> boxes, float slack) : boxes_(boxes), slack_(slack) {
  const size_t n = boxes.size();
  finite_.assign(n, 0);
  cells_.assign(n, {UINT32_MAX, UINT32_MAX, UINT32_MAX, UINT32_MAX, UINT32_MAX, UINT32_MAX});
  // The grown boxes' bounds and mean largest extent, in double.
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  double extent = 0.0;
  size_t count = 0;
  for (size_t b = 0; b < n; ++b) {
    const GridBox& box = boxes[b];
    bool finite = true;
    for (int k = 0; k < 3; ++k) finite &= std::isfinite(box.lo[k]) && std::isfinite(box.hi[k]);
    if (!finite) continue;
    finite_[b] = 1;
    double largest = 0.0;
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], double(box.lo[k]) - slack);
      hi[k] = std::max(hi[k], double(box.hi[k]) + slack);
      largest = std::max(largest, double(box.hi[k]) - double(box.lo[k]));
    }
    extent += largest + 2.0 * double(slack);
    ++count;
  }
  if (count == 0) return;
  // A cell about twice the mean grown box, so that a box covers a few cells; no more cells per axis
  // than the keys hold.
  double cell = 2.0 * extent / double(count);
  for (int k = 0; k < 3; ++k) cell = std::max(cell, (hi[k] - lo[k]) / double(kAxisCells));
  if (!(cell > 0.0) || !std::isfinite(cell)) cell = 1.0;  // every box a point at one place
  auto index = [&](double x, int k) {
    const double i = std::floor((x - lo[k]) / cell);
    return uint32_t(std::clamp(i, 0.0, double(kAxisCells)));
  };
  entries_.reserve(4 * count);
  for (uint32_t b = 0; b < n; ++b) {
    if (!finite_[b]) continue;
    std::array<uint32_t, 6> c;
    size_t covered = 1;
    for (int k = 0; k < 3; ++k) {
      // Grown a hair more than the slack, so that boxes the float test in ForEachPair says meet share a cell.
      const double l = boxes[b].lo[k], h = boxes[b].hi[k];
      c[k] = index(l - (double(slack) * (1.0 + 1e-6) + std::fabs(l) * 1e-6), k);
      c[3 + k] = index(h + (double(slack) * (1.0 + 1e-6) + std::fabs(h) * 1e-6), k);
      covered *= size_t{c[3 + k] - c[k]} + 1;
      if (covered > kMaxCellsPerBox) break;
    }
    if (covered > kMaxCellsPerBox) {
      big_.push_back(b);
      continue;
    }
    cells_[b] = c;
    for (uint32_t x = c[0]; x <= c[3]; ++x) {
      for (uint32_t y = c[1]; y <= c[4]; ++y) {
        for (uint32_t z = c[2]; z <= c[5]; ++z) {
          entries_.push_back({(uint64_t{x} << 42) | (uint64_t{y} << 21) | z, b});
        }
      }
    }
  }
  std::sort(entries_.begin(), entries_.end(),
            [](const Entry& p, const Entry& q) { return p.cell != q.cell ? p.cell < q.cell : p.box < q.box; });
}

}  // namespace skinspheres::runtime::narrow_phase
