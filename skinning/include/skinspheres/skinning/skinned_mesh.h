// SkinnedMesh: what linear blend skinning reads for a set of vertices.
//
// A vertex is skinned as  p' = Σ_k w_k · (G_{joint(b_k)} · IBM_{b_k}) · p_bind  where b_k are
// *bind entries*: a (joint, inverse bind matrix) pair. One glTF skin gives one entry per skin
// joint; several skins that share a skeleton add entries only where their inverse bind matrices
// differ; a rigid mesh hanging under a joint gets an entry with IBM = G_joint(rest)^-1 and its
// vertices baked to world rest positions. Weights are normalised per vertex (sum 1).
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "skinspheres/skinning/math_types.h"

namespace skinspheres::skinning {

struct BindEntry {
  int32_t joint = -1;  // Skeleton joint index
  Mat4f inverse_bind = Mat4f::Identity();
};

// How far a vertex's float weights may sum from 1 where the sum is checked (the fitter's input,
// SphereSet::Validate). Normalised in double and rounded once per weight, a sum is within half an
// epsilon of 1; the fast refit's bounds take the sum as 1 and leave the rest to their rounding
// margin of 16 epsilons of the coordinates (refit_job.h), of which a centre off by 4 epsilons
// (times up to sqrt(3) for its norm) takes under half.
inline constexpr double kWeightSumTolerance = 4.0 * 1.1920928955078125e-07;  // 4 float epsilons

// The first vertex whose weights, summed in double, are not within kWeightSumTolerance of 1 (a NaN
// sum is not), or SIZE_MAX if there is none; *sum gets that vertex's sum. offsets: CSR offsets into
// weights (vertex count + 1 entries, each within weights, checked by the caller).
inline size_t FirstVertexNotSummingToOne(std::span<const uint32_t> offsets, std::span<const float> weights,
                                         double* sum) {
  for (size_t v = 0; v + 1 < offsets.size(); ++v) {
    double s = 0.0;
    for (uint32_t k = offsets[v]; k < offsets[v + 1]; ++k) s += weights[k];
    if (!(std::abs(s - 1.0) <= kWeightSumTolerance)) {
      *sum = s;
      return v;
    }
  }
  return std::numeric_limits<size_t>::max();
}

struct SkinnedMesh {
  std::vector<Eigen::Vector3f> positions_bind;  // per vertex, in the space IBMs map from
  std::vector<BindEntry> binds;
  // Influences in CSR form: vertex v uses [influence_offsets[v], influence_offsets[v+1]).
  std::vector<uint32_t> influence_offsets;  // vertex_count() + 1
  std::vector<uint16_t> influence_binds;    // index into binds
  std::vector<float> influence_weights;     // > 0, sum to 1 per vertex

  size_t vertex_count() const { return positions_bind.size(); }
};

}  // namespace skinspheres::skinning
