// GridPoint (format/sphere_set.h) inline, for the library's per-frame loops that compute grid
// points by the thousand (exact refit, the narrow phase's piece corners): the same arithmetic, so
// the same bits, without a call and three divisions per point. Internal to runtime/, compiled with
// the library's flags (no FMA contraction); consumers call the out-of-line GridPoint.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "skinspheres/runtime/format/sphere_set.h"

namespace skinspheres::runtime::internal {

// kGridWeights.w[L][n] = float(n) / float(L) for 1 <= L <= kMaxPieceLevel, 0 <= n <= L: the
// correctly rounded quotient, as the division at run time gives it (IEEE division is exact then
// rounded, at compile time as at run time; GridPointWeightsAreTheRunTimeDivisions checks it on every platform
// the tests run on).
struct GridWeightTable {
  float w[kMaxPieceLevel + 1][kMaxPieceLevel + 1];
};
inline constexpr GridWeightTable kGridWeights = [] {
  GridWeightTable t{};
  for (int l = 1; l <= kMaxPieceLevel; ++l) {
    for (int n = 0; n <= l; ++n) t.w[l][n] = static_cast<float>(n) / static_cast<float>(l);
  }
  return t;
}();

inline Eigen::Vector3f GridPointInline(const Eigen::Vector3f& p0, const Eigen::Vector3f& p1, const Eigen::Vector3f& p2,
                                       uint16_t level, uint8_t i, uint8_t j) {
  float w0, w1, w2;
  if (level >= 1 && level <= kMaxPieceLevel && i + j <= level) {
    const float* w = kGridWeights.w[level];
    w0 = w[level - i - j], w1 = w[i], w2 = w[j];
  } else {  // outside a valid grid: the divisions themselves
    const float l = static_cast<float>(level);
    w0 = static_cast<float>(level - i - j) / l, w1 = static_cast<float>(i) / l, w2 = static_cast<float>(j) / l;
  }
  Eigen::Vector3f out;
  for (int a = 0; a < 3; ++a) {
    const float x = (w0 * p0[a] + w1 * p1[a]) + w2 * p2[a];
    const float lo = std::min(std::min(p0[a], p1[a]), p2[a]), hi = std::max(std::max(p0[a], p1[a]), p2[a]);
    out[a] = x < lo ? lo : (x > hi ? hi : x);  // (a NaN stays NaN: both comparisons are false)
  }
  return out;
}

// SphereSet::PointAt with GridPointInline.
inline Eigen::Vector3f PointAt(const SphereSet& set, uint32_t k, const Eigen::Vector3f* positions) {
  if (k < set.source_vertex_count) return positions[k];
  const PiecePoint& g = set.piece_points[k - set.source_vertex_count];
  const uint32_t* v = set.triangle_vertices.data() + 3 * size_t{g.triangle};
  return GridPointInline(positions[v[0]], positions[v[1]], positions[v[2]], g.level, g.i, g.j);
}

}  // namespace skinspheres::runtime::internal
