// The fast refit as the plain scalar formula of refit_job.h, written out in plain floats: the
// bit-equality reference of every SIMD and portable copy, on every platform (test oracle).
#pragma once

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <span>
#include <vector>

#include "skinspheres/runtime/format/sphere_set.h"
#include "skinspheres/runtime/refit/refit_job.h"
#include "skinspheres/skinning/math_types.h"

namespace skinspheres::test {

using runtime::RefitRestData;
using runtime::SphereSet;

// The fast refit as the plain scalar formula of the header, one float operation after the other:
// the bit-equality reference of every SIMD and portable copy, on every platform.
// bound: kRestData, the bound the runtime computes, from the rest data: the largest over the
// sphere's reach groups of s_max · r_g + min(max_j |d_j|, Σ_j W_gj |d_j|) (one group, the set's
// radius_fast and reach, when the set has none: refit_job.h), that min also taken with
// |Σ_k m_gk d_k| + Σ_k e_gk |d_k| when the set has group blends ("Group blends"); kWithoutReach: Kavan & Žára's
// r' = s_max · radius_fast + max_j |d_j| as written before reach existed (no min), the oracle of
// "never above the old bound" and "a set without reach is the old bound".
enum class Bound { kRestData, kWithoutReach };
inline std::vector<skinspheres::Vec4f> ScalarFastRefit(const SphereSet& set, const RefitRestData& rest,
                                                       std::span<const skinspheres::Mat4f> world, Bound bound) {
  // Written out in plain floats in the order refit_job.h documents (every 3-term sum as
  // a0 + (a1 + a2)): Eigen's own evaluation order differs between targets (NEON has 2-float
  // packets), and the runtime must give these bits on every platform.
  const auto apply = [](const skinspheres::Mat4f& g, const Eigen::Vector3f& p) {
    Eigen::Vector3f r;
    for (int m = 0; m < 3; ++m) r[m] = (g(m, 0) * p.x() + (g(m, 1) * p.y() + g(m, 2) * p.z())) + g(m, 3);
    return r;
  };
  const auto norm2 = [](const Eigen::Vector3f& d) { return d.x() * d.x() + (d.y() * d.y() + d.z() * d.z()); };
  std::vector<skinspheres::Vec4f> out(set.size());
  const auto q = rest.center_in_joint();
  const auto w = rest.weights();
  const auto rinv = rest.rest_linear_inverse();
  for (size_t s = 0; s < set.size(); ++s) {
    const uint32_t k0 = set.influence_offsets[s], k1 = set.influence_offsets[s + 1];
    Eigen::Vector3f c = Eigen::Vector3f::Zero();
    for (uint32_t k = k0; k < k1; ++k) {
      const Eigen::Vector3f p = apply(world[set.influence_joints[k]], q[k]);
      for (int m = 0; m < 3; ++m) c[m] = c[m] + w[k] * p[m];
    }
    const uint32_t g0 = rest.group_offsets()[s], groups = rest.group_offsets()[s + 1] - g0;
    const float* g_reach = rest.group_reach().data() + rest.group_reach_offsets()[s];
    std::vector<float> reached(groups, 0.0f), deviated(groups, 0.0f);
    std::vector<Eigen::Vector3f> blended(groups, Eigen::Vector3f::Zero());
    std::vector<float> blend_sum(groups, 0.0f);
    float moved_sum = 0.0f;
    const bool blends = !rest.group_blend().empty();
    float spread2 = 0.0f, s2 = 0.0f;
    for (uint32_t k = k0; k < k1; ++k) {
      const uint16_t j = set.influence_joints[k];
      const Eigen::Vector3f d = apply(world[j], q[k]) - c;
      const float d2 = norm2(d);
      float a[3][3], ata[3][3];  // A = linear(G_j(t)) · R_j, then AᵀA
      for (int m = 0; m < 3; ++m) {
        for (int k2 = 0; k2 < 3; ++k2) {
          a[m][k2] =
              world[j](m, 0) * rinv[j](0, k2) + (world[j](m, 1) * rinv[j](1, k2) + world[j](m, 2) * rinv[j](2, k2));
        }
      }
      for (int i = 0; i < 3; ++i) {
        for (int k2 = 0; k2 < 3; ++k2) ata[i][k2] = a[0][i] * a[0][k2] + (a[1][i] * a[1][k2] + a[2][i] * a[2][k2]);
      }
      float row_max = 0.0f;
      for (int i = 0; i < 3; ++i) {
        row_max = std::max(row_max, std::fabs(ata[i][0]) + (std::fabs(ata[i][1]) + std::fabs(ata[i][2])));
      }
      spread2 = std::max(spread2, d2);
      for (uint32_t g = 0; g < groups; ++g) reached[g] += g_reach[g * (k1 - k0) + (k - k0)] * std::sqrt(d2);
      for (uint32_t g = 0; g < groups && blends; ++g) {
        const size_t at = rest.group_reach_offsets()[s] + g * (k1 - k0) + (k - k0);
        for (int m = 0; m < 3; ++m) blended[g][m] = blended[g][m] + rest.group_blend()[at] * d[m];
        deviated[g] = deviated[g] + rest.group_deviation()[at] * std::sqrt(d2);
        blend_sum[g] = blend_sum[g] + rest.group_blend()[at];
      }
      if (blends) moved_sum = moved_sum + std::sqrt(d2);
      s2 = std::max(s2, row_max);
    }
    float r = std::sqrt(s2) * rest.radii_fast()[s] + std::sqrt(spread2);
    if (bound == Bound::kRestData) {
      const float largest = std::max(std::fabs(c.x()), std::max(std::fabs(c.y()), std::fabs(c.z())));
      const auto term = [&](uint32_t g) {
        const float t = std::min(std::sqrt(spread2), reached[g]);
        const float rounding = 32.0f * FLT_EPSILON * (moved_sum + blend_sum[g] * largest);
        return blends ? std::min(t, (std::sqrt(norm2(blended[g])) + deviated[g]) + rounding) : t;
      };
      r = std::sqrt(s2) * rest.group_radii()[g0] + term(0);
      for (uint32_t g = 1; g < groups; ++g) r = std::max(r, std::sqrt(s2) * rest.group_radii()[g0 + g] + term(g));
    }
    const float largest = std::max(std::fabs(c.x()), std::max(std::fabs(c.y()), std::fabs(c.z())));
    const float radius = r + 16.0f * FLT_EPSILON * (largest + r);
    out[s] = skinspheres::Vec4f(c.x(), c.y(), c.z(), radius);
  }
  return out;
}

}  // namespace skinspheres::test
