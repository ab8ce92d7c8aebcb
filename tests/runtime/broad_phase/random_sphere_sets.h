// Random sphere sets, part lists and exclusions for the broad-phase and pair-filter tests: several
// kinds of set chosen to hit the edge cases of every path (touching, identical centres, zero radii,
// coplanar, large coordinates, slabs, sparse).
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <vector>

#include "skinspheres/runtime/broad_phase/pair_filter.h"
#include "skinspheres/skinning/math_types.h"

namespace skinspheres::test {

using runtime::ExcludedPair;
using runtime::ExclusionReason;
using runtime::PairFilter;

// Random exclusions: each pair with probability p, listed in random order (i > j allowed).
inline std::vector<ExcludedPair> RandomExclusions(size_t n, double p, std::mt19937& rng) {
  std::vector<ExcludedPair> pairs;
  std::bernoulli_distribution pick(p), swap(0.5);
  for (uint32_t i = 0; i < n; ++i) {
    for (uint32_t j = i + 1; j < n; ++j) {
      if (!pick(rng)) continue;
      pairs.push_back(swap(rng) ? ExcludedPair{j, i, ExclusionReason::kBindOverlap}
                                : ExcludedPair{i, j, ExclusionReason::kSameJoint});
    }
  }
  std::shuffle(pairs.begin(), pairs.end(), rng);
  return pairs;
}

inline std::vector<uint16_t> RandomParts(size_t n, std::mt19937& rng) {
  std::uniform_int_distribution<int> part(0, 6);
  std::vector<uint16_t> parts(n);
  for (auto& p : parts) p = static_cast<uint16_t>(part(rng));
  return parts;
}

// Several kinds of random set, chosen by `kind`, to hit the edge cases of every path.
inline std::vector<skinspheres::Vec4f> RandomSpheres(size_t n, int kind, std::mt19937& rng) {
  std::uniform_real_distribution<float> u(-1.0f, 1.0f), ur(0.0f, 0.3f);
  std::uniform_int_distribution<int> grid(-3, 3), coin(0, 3);
  std::vector<skinspheres::Vec4f> s(n);
  for (size_t k = 0; k < n; ++k) {
    skinspheres::Vec4f& v = s[k];
    switch (kind) {
      case 0:  // uniform
        v = {u(rng), u(rng), u(rng), ur(rng)};
        break;
      case 1:  // integer lattice, radii 0, 0.5, 1: many exactly touching spheres, shared coordinates
        v = {float(grid(rng)), float(grid(rng)), float(grid(rng)), 0.5f * float(coin(rng) % 3)};
        break;
      case 2:  // a few identical centres, some zero radii: a dense clump (every pair touches)
        v = {0.25f * float(coin(rng)), 0.5f, -0.125f * float(coin(rng)),
             coin(rng) == 0 ? 0.0f : 0.1f * float(coin(rng))};
        break;
      case 3:  // all centres on one plane x = 0.5 (coincident on that axis), thin in y
        v = {0.5f, 0.01f * u(rng), 4.0f * u(rng), 0.5f * ur(rng)};
        break;
      case 4:  // a long thin limb-like chain plus noise, large coordinates
        v = {1000.0f + 0.05f * float(k) + 0.01f * u(rng), -500.0f + 0.02f * u(rng), 250.0f + 0.02f * u(rng),
             0.04f + 0.02f * ur(rng)};
        break;
      case 5:  // a wide slab (the sweep cuts it into strips)
        v = {20.0f * u(rng), 20.0f * u(rng), 0.2f * u(rng), 0.3f * ur(rng)};
        break;
      default:  // sparse: few contacts
        v = {20.0f * u(rng), 20.0f * u(rng), 20.0f * u(rng), ur(rng)};
        break;
    }
  }
  return s;
}
constexpr int kKinds = 7;

inline PairFilter MakeFilter(size_t n, double p_exclude, std::mt19937& rng) {
  auto parts = RandomParts(n, rng);
  auto pairs = RandomExclusions(n, p_exclude, rng);
  auto filter = PairFilter::Create(n, parts, pairs);
  EXPECT_TRUE(filter.ok()) << (filter.ok() ? "" : filter.error().message);
  return std::move(filter).value();
}

}  // namespace skinspheres::test
