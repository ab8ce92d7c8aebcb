// Synthetic skinned data for the skinning tests: random affine matrices and random CSR
// influences with 1..max influences per vertex (weights normalised), deterministic per seed.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <random>
#include <vector>

#include "skinspheres/skinning/math_types.h"

namespace skinspheres::test {

struct SyntheticMesh {
  size_t vertex_count = 0;
  std::vector<float> positions;  // xyz per vertex, tightly packed
  std::vector<uint32_t> offsets;
  std::vector<uint16_t> binds;
  std::vector<float> weights;
  std::vector<skinspheres::Mat4f> matrices;
};

inline skinspheres::Mat4f RandomAffine(std::mt19937& rng, bool with_scale = true) {
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  const Eigen::Vector3f axis = Eigen::Vector3f(u(rng), u(rng), u(rng) + 2.5f).normalized();
  Eigen::Affine3f a = Eigen::Translation3f(2 * u(rng), 2 * u(rng), 2 * u(rng)) * Eigen::AngleAxisf(3.0f * u(rng), axis);
  if (with_scale) a = a * Eigen::Scaling(1.0f + 0.5f * u(rng), 1.0f + 0.5f * u(rng), 1.0f + 0.5f * u(rng));
  return a.matrix();
}

// min_influences may be 0 (vertices without influences skin to the origin).
inline SyntheticMesh MakeSyntheticMesh(size_t vertex_count, size_t bind_count, int min_influences, int max_influences,
                                       uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::uniform_int_distribution<int> count(min_influences, max_influences);
  std::uniform_int_distribution<int> bind(0, static_cast<int>(bind_count) - 1);
  SyntheticMesh m;
  m.vertex_count = vertex_count;
  m.positions.resize(3 * vertex_count);
  for (float& p : m.positions) p = u(rng);
  m.offsets.push_back(0);
  for (size_t v = 0; v < vertex_count; ++v) {
    const int n = count(rng);
    float sum = 0.0f;
    for (int k = 0; k < n; ++k) {
      m.binds.push_back(static_cast<uint16_t>(bind(rng)));
      m.weights.push_back(0.05f + (u(rng) + 1.0f));
      sum += m.weights.back();
    }
    for (int k = 0; k < n; ++k) m.weights[m.weights.size() - 1 - static_cast<size_t>(k)] /= sum;
    m.offsets.push_back(static_cast<uint32_t>(m.binds.size()));
  }
  for (size_t b = 0; b < bind_count; ++b) m.matrices.push_back(RandomAffine(rng));
  return m;
}

}  // namespace skinspheres::test
