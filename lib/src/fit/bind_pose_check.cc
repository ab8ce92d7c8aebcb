// The fitter's self-check: the fitted set is consistent and proves, in double precision, every
// triangle inside its owner sphere in the bind pose. See sphere_fitter.h and fit_stages.h.
#include <string>

#include "fit_stages.h"

namespace skinspheres::lib {

int CountUncoveredTriangles(const RawCharacter& ch, const runtime::SphereSet& set, int* first_bad) {
  std::vector<int32_t> owner(ch.triangle_count(), -1);
  for (size_t s = 0; s < set.size(); ++s) {
    for (uint32_t k = set.triangle_offsets[s]; k < set.triangle_offsets[s + 1]; ++k) {
      if (set.triangles[k] < owner.size()) owner[set.triangles[k]] = static_cast<int32_t>(s);
    }
  }
  int bad = 0;
  for (size_t t = 0; t < owner.size(); ++t) {
    bool inside = owner[t] >= 0;
    if (inside) {
      const Eigen::Vector3d c = set.centers_rest[owner[t]].cast<double>();
      const double r = set.radii_rest[owner[t]] * (1.0 + 1e-6);
      for (int k = 0; k < 3 && inside; ++k) {
        inside = (ch.positions_rest[ch.triangles[t][k]].cast<double>() - c).norm() <= r;
      }
    }
    if (!inside) {
      if (bad == 0 && first_bad) *first_bad = static_cast<int>(t);
      ++bad;
    }
  }
  return bad;
}

std::optional<Error> CheckFittedSet(const RawCharacter& ch, const runtime::SphereSet& set) {
  const std::string name = ch.Name();
  if (auto err = set.Validate())
    return MakeError(ErrorCode::kInvalidData, name + ": fitted set is inconsistent: " + err->message);
  int first_bad = -1;
  const int uncovered = CountUncoveredTriangles(ch, set, &first_bad);
  if (uncovered) {
    return MakeError(ErrorCode::kCheckFailed,
                     name + ": bind-pose check failed: " + std::to_string(uncovered) +
                         " triangles outside their sphere (first: " + std::to_string(first_bad) + ")");
  }
  return std::nullopt;
}

}  // namespace skinspheres::lib
