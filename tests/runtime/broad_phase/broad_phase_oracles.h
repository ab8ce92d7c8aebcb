// Oracles for the broad-phase tests that do not go through the library's query: the contract's
// sphere test written out as in broad_phase.h, and a uniform grid for sets too large for the
// O(n^2) loop. And the instruction sets this CPU runs.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "skinspheres/runtime/broad_phase/broad_phase.h"
#include "skinspheres/runtime/broad_phase/pair_filter.h"

namespace skinspheres::test {

inline bool ByPair(const runtime::SpherePair& p, const runtime::SpherePair& q) {
  return p.sphere_i != q.sphere_i ? p.sphere_i < q.sphere_i : p.sphere_j < q.sphere_j;
}

// Appends contact (i, j) when spheres i < j touch: dx = c_j - c_i, ((dx dx + dy dy) + dz dz) <=
// (r_i + r_j)^2 in float, depth r_i + r_j - sqrt. The filter only gives the parts.
inline void TestPair(const std::vector<Vec4f>& s, uint32_t i, uint32_t j, const runtime::PairFilter& f,
                     std::vector<runtime::SpherePair>* out) {
  const float dx = s[j].x() - s[i].x(), dy = s[j].y() - s[i].y(), dz = s[j].z() - s[i].z();
  const float d2 = (dx * dx + dy * dy) + dz * dz, rs = s[i].w() + s[j].w();
  if (d2 <= rs * rs) out->push_back(runtime::SpherePair{i, j, rs - std::sqrt(d2), f.part(i), f.part(j)});
}

// Every pair not excluded by f that touches, sorted by (i, j): cells one largest diameter wide, the
// 27 neighbouring cells of each sphere's cell, TestPair, then a sort.
inline std::vector<runtime::SpherePair> GridOracle(const std::vector<Vec4f>& s, const runtime::PairFilter& f) {
  float r_max = 0.0f;
  for (const auto& v : s) r_max = std::max(r_max, v.w());
  const double cell = std::max(2.0 * double(r_max), 1e-6);
  using Cell = std::array<int64_t, 3>;
  struct CellHash {
    size_t operator()(const Cell& c) const { return size_t((c[0] * 73856093) ^ (c[1] * 19349663) ^ (c[2] * 83492791)); }
  };
  std::unordered_map<Cell, std::vector<uint32_t>, CellHash> cells;
  std::vector<Cell> at(s.size());
  for (uint32_t i = 0; i < s.size(); ++i) {
    for (int a = 0; a < 3; ++a) at[i][a] = int64_t(std::floor(double(s[i][a]) / cell));
    cells[at[i]].push_back(i);
  }
  std::vector<runtime::SpherePair> out;
  for (uint32_t i = 0; i < s.size(); ++i) {
    for (int d = 0; d < 27; ++d) {
      auto it = cells.find(Cell{at[i][0] + d % 3 - 1, at[i][1] + d / 3 % 3 - 1, at[i][2] + d / 9 - 1});
      if (it == cells.end()) continue;
      for (uint32_t j : it->second) {
        if (j > i && !f.excluded(i, j)) TestPair(s, i, j, f, &out);
      }
    }
  }
  std::sort(out.begin(), out.end(), ByPair);
  return out;
}

// The instruction sets of the broad phase this build and CPU have (portable always; SSE2 on x86-64).
inline std::vector<runtime::SimdLevel> SupportedLevels() {
  std::vector<runtime::SimdLevel> levels;
  for (auto l : {runtime::SimdLevel::kPortable, runtime::SimdLevel::kSse2, runtime::SimdLevel::kAvx2,
                 runtime::SimdLevel::kAvx512}) {
    if (runtime::SimdLevelSupported(l)) levels.push_back(l);
  }
  return levels;
}

// The all-pairs oracle's sphere pairs (FindSpherePairsBruteForce), with a test failure if it refuses.
inline std::vector<runtime::SpherePair> Oracle(const std::vector<Vec4f>& s, const runtime::PairFilter& f) {
  std::vector<runtime::SpherePair> out;
  EXPECT_TRUE(runtime::FindSpherePairsBruteForce(s, f, &out));
  return out;
}

// One space of the members' spheres laid end to end (PairFilter::Combine).
inline runtime::PairFilter Combined(const std::vector<runtime::PairFilter>& members,
                                    runtime::PairFilter::CombineOptions options) {
  std::vector<const runtime::PairFilter*> pointers;
  for (const auto& m : members) pointers.push_back(&m);
  return runtime::PairFilter::Combine(pointers, options).value();
}

}  // namespace skinspheres::test
