#include "skinspheres/runtime/format/sphere_set.h"

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "format/grid_point.h"
#include "format/sphere_set_checks.h"
#include "skinspheres/runtime/narrow_phase/contact_rules.h"

namespace skinspheres::runtime {

const char* ToString(ExclusionReason reason) {
  switch (reason) {
    case ExclusionReason::kSameJoint: return "same_joint";
    case ExclusionReason::kAdjacentJoints: return "adjacent_joints";
    case ExclusionReason::kBindOverlap: return "bind_overlap";
  }
  return "unknown";
}

std::optional<ExclusionReason> ExclusionReasonFromString(std::string_view text) {
  if (text == "same_joint") return ExclusionReason::kSameJoint;
  if (text == "adjacent_joints") return ExclusionReason::kAdjacentJoints;
  if (text == "bind_overlap") return ExclusionReason::kBindOverlap;
  return std::nullopt;
}

bool PieceCorners(uint16_t level, uint16_t index, uint8_t corners[3][2]) {
  if (level < 2 || level > kMaxPieceLevel || index >= uint32_t{level} * level) return false;
  const uint32_t up = uint32_t{level} * (level + 1) / 2;
  // Row j of the upward pieces holds level - j of them, row j of the downward ones level - 1 - j.
  const bool upward = index < up;
  uint32_t k = upward ? index : index - up;
  uint32_t j = 0;
  for (uint32_t row = upward ? level : level - 1u; k >= row; --row) {
    k -= row;
    ++j;
  }
  const auto i = static_cast<uint8_t>(k), jj = static_cast<uint8_t>(j);
  const uint8_t up_corners[3][2] = {{i, jj}, {uint8_t(i + 1), jj}, {i, uint8_t(jj + 1)}};
  const uint8_t down_corners[3][2] = {{uint8_t(i + 1), jj}, {uint8_t(i + 1), uint8_t(jj + 1)}, {i, uint8_t(jj + 1)}};
  for (int c = 0; c < 3; ++c) {
    for (int a = 0; a < 2; ++a) corners[c][a] = upward ? up_corners[c][a] : down_corners[c][a];
  }
  return true;
}

Eigen::Vector3f GridPoint(const Eigen::Vector3f& p0, const Eigen::Vector3f& p1, const Eigen::Vector3f& p2,
                          uint16_t level, uint8_t i, uint8_t j) {
  return internal::GridPointInline(p0, p1, p2, level, i, j);
}

std::vector<uint32_t> SourceVerticesOfPoints(const SphereSet& set) {
  std::vector<uint32_t> out;
  out.reserve(set.vertices.size());
  for (uint32_t point : set.vertices) {
    if (point < set.source_vertex_count) {
      out.push_back(point);
      continue;
    }
    const uint32_t t = set.piece_points[point - set.source_vertex_count].triangle;
    for (int c = 0; c < 3; ++c) out.push_back(set.triangle_vertices[3 * size_t{t} + c]);
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

std::optional<Error> SphereSet::Validate() const {
  using namespace internal;  // sphere_set_checks.h
  for (const auto check :
       {CheckSkeleton, CheckParts, CheckSphereArrays, CheckSpheres, CheckOwnership, CheckInfluences, CheckExclusions,
        CheckMesh, CheckFastRadii, CheckFastReference, CheckReachGroups, CheckContactRules}) {
    if (auto err = check(*this)) return err;
  }
  return std::nullopt;
}

namespace internal {

std::string PointName(const SphereSet& set, uint32_t k) {
  if (k < set.source_vertex_count) return "source vertex " + std::to_string(k);
  const PiecePoint& g = set.piece_points[k - set.source_vertex_count];
  return "grid point (" + std::to_string(g.i) + ", " + std::to_string(g.j) + ") of level " + std::to_string(g.level) +
         " of triangle " + std::to_string(g.triangle);
}

// A float in as many digits as tell it from its neighbours (a reach one ulp too small must read so).
std::string Digits(float x) {
  char text[32];
  std::snprintf(text, sizeof text, "%.9g", static_cast<double>(x));
  return text;
}

}  // namespace internal

}  // namespace skinspheres::runtime
