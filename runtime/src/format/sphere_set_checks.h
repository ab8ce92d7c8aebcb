// The checks SphereSet::Validate() runs in order, and the helpers their messages share. Each check
// returns std::nullopt when its part of the set is sound, else the first problem found, as an
// ErrorCode::kInvalidData error naming it. A check may assume the checks before it passed.
// Internal to the runtime library.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "skinspheres/runtime/error.h"
#include "skinspheres/runtime/format/sphere_set.h"

namespace skinspheres::runtime::internal {

inline Error Invalid(const std::string& what) { return MakeError(ErrorCode::kInvalidData, what); }

// Point k of the set's point lists (SphereSet::vertices): "source vertex 7", "grid point (1, 0) of
// level 2 of triangle 5".
std::string PointName(const SphereSet& set, uint32_t k);

// A float in as many digits as tell it from its neighbours (a reach one ulp too small must read so).
std::string Digits(float x);

// Offsets of a CSR list: n+1 entries, starting at 0, non-decreasing, ending at the list's size.
inline bool CsrOk(const std::vector<uint32_t>& offsets, size_t n, size_t list_size) {
  if (offsets.size() != n + 1 || offsets.front() != 0 || offsets.back() != list_size) return false;
  for (size_t s = 0; s < n; ++s) {
    if (offsets[s] > offsets[s + 1]) return false;
  }
  return true;
}

// sphere_set_checks.cc
std::optional<Error> CheckSkeleton(const SphereSet& set);
std::optional<Error> CheckParts(const SphereSet& set);
std::optional<Error> CheckSphereArrays(const SphereSet& set);
std::optional<Error> CheckSpheres(const SphereSet& set);
std::optional<Error> CheckOwnership(const SphereSet& set);
std::optional<Error> CheckInfluences(const SphereSet& set);
std::optional<Error> CheckExclusions(const SphereSet& set);
std::optional<Error> CheckMesh(const SphereSet& set);

// sphere_set_checks_fast.cc
std::optional<Error> CheckFastRadii(const SphereSet& set);
std::optional<Error> CheckFastReference(const SphereSet& set);
std::optional<Error> CheckReachGroups(const SphereSet& set);

}  // namespace skinspheres::runtime::internal
