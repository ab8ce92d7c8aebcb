// All-pairs self-collision: the O(n^2) oracle kept beside the sort-and-sweep path (the slow,
// obvious version the tests compare the fast one with). Same arithmetic (broad_phase/sphere_test.h), sphere pairs in
// (i, j) order.
#include "broad_phase/sphere_test.h"
#include "skinspheres/runtime/broad_phase/broad_phase.h"

namespace skinspheres::runtime {

bool FindSpherePairsBruteForce(std::span<const Vec4f> spheres, const PairFilter& filter, std::vector<SpherePair>* out) {
  if (out == nullptr) return false;
  out->clear();
  if (spheres.size() != filter.size()) return false;
  for (const Vec4f& s : spheres) {
    if (!internal::SphereValuesOk(s)) return false;
  }
  const uint32_t n = static_cast<uint32_t>(spheres.size());
  for (uint32_t i = 0; i < n; ++i) {
    for (uint32_t j = i + 1; j < n; ++j) {
      const float d2 = internal::CenterDistanceSquared(spheres[i], spheres[j]);
      if (!internal::SpheresTouch(d2, spheres[i].w() + spheres[j].w())) continue;
      if (filter.excluded(i, j)) continue;
      out->push_back(
          SpherePair{i, j, internal::PenetrationDepth(spheres[i], spheres[j]), filter.part(i), filter.part(j)});
    }
  }
  return true;
}

}  // namespace skinspheres::runtime
