// Stage 4 of the fitter, beyond the paper (safety): every triangle owned by exactly one sphere of
// its part, then Lloyd-style refinement. See fit_stages.h.
#include <algorithm>
#include <cmath>
#include <limits>

#include "fit_stages.h"
#include "skinspheres/lib/geometry/mesh_helpers.h"

namespace skinspheres::lib {
namespace {

// Each triangle of each part goes to the sphere of its part (spheres part_first[k] ..
// part_first[k + 1]) whose centre is nearest its farthest vertex: the sphere that holds it with the
// smallest radius (ties: lowest index). Spheres with a negative radius are out. Parts in parallel.
void AssignToNearest(const RawCharacter& ch, const BodyParts& parts, std::span<const uint32_t> part_first,
                     std::span<const Ball> balls, std::vector<int32_t>* owner) {
  ParallelIndices(parts.parts.size(), [&](size_t k) {
    for (uint32_t t : parts.parts[k].triangles) {
      const Eigen::Vector3f& p0 = ch.positions_rest[ch.triangles[t][0]];
      const Eigen::Vector3f& p1 = ch.positions_rest[ch.triangles[t][1]];
      const Eigen::Vector3f& p2 = ch.positions_rest[ch.triangles[t][2]];
      float best = std::numeric_limits<float>::infinity();
      int32_t best_s = -1;
      for (uint32_t s = part_first[k]; s < part_first[k + 1]; ++s) {
        const Ball& b = balls[s];
        if (b.radius < 0.0f) continue;  // dropped
        // max_v |p_v - c| with one sqrt: sqrt is monotonic and correctly rounded, so this is
        // bit-identical to the max of the three norms.
        const float need = std::sqrt(
            std::max({(p0 - b.center).squaredNorm(), (p1 - b.center).squaredNorm(), (p2 - b.center).squaredNorm()}));
        if (need < best) {
          best = need;
          best_s = static_cast<int32_t>(s);
        }
      }
      (*owner)[t] = best_s;
    }
  });
}

// One refine round: each sphere becomes the minimum ball of the vertices it owns, each vertex once
// (a closed mesh lists a vertex in ~6 triangles, so MinimumBall sees ~6x fewer points; the minimum
// ball of a set does not depend on repeats). A sphere that owns nothing gets radius -1: out of the
// next assignment.
void MoveToOwnedBalls(const RawCharacter& ch, std::span<const int32_t> owner, UniqueVertices& unique,
                      std::vector<Ball>* balls) {
  // Triangles grouped by owner (counting sort, ascending t).
  const size_t n = balls->size();
  std::vector<uint32_t> first(n + 1, 0);
  for (int32_t o : owner) {
    if (o >= 0) ++first[o + 1];
  }
  for (size_t s = 0; s < n; ++s) first[s + 1] += first[s];
  std::vector<uint32_t> by_owner(first.back()), fill(first.begin(), first.end() - 1);
  for (size_t t = 0; t < owner.size(); ++t) {
    if (owner[t] >= 0) by_owner[fill[owner[t]]++] = static_cast<uint32_t>(t);
  }
  std::vector<std::vector<Eigen::Vector3f>> pts(n);
  for (size_t s = 0; s < n; ++s) {
    pts[s] = unique.Positions(ch.positions_rest, std::span(by_owner).subspan(first[s], first[s + 1] - first[s]));
  }
  ParallelIndices(n, [&](size_t s) {
    if (pts[s].empty()) {
      (*balls)[s].radius = -1.0f;
    } else {
      (*balls)[s] = MinimumBall(pts[s]);
    }
  });
}

// After the last refine round reassigned triangles: each sphere's centre moves once more to the
// minimum ball of what it now owns (its vertices in ascending index order).
void RecentreOnOwned(const RawCharacter& ch, UniqueVertices& unique, OwnedSpheres* owned) {
  const size_t n = owned->spheres.size();
  std::vector<std::vector<Eigen::Vector3f>> pts(n);
  for (size_t s = 0; s < n; ++s) {
    std::vector<uint32_t> ids = unique.Indices(owned->triangles[s]);
    std::sort(ids.begin(), ids.end());
    pts[s].reserve(ids.size());
    for (uint32_t v : ids) pts[s].push_back(ch.positions_rest[v]);
  }
  ParallelIndices(n, [&](size_t s) {
    if (!owned->triangles[s].empty()) owned->spheres[s].ball.center = MinimumBall(pts[s]).center;
  });
}

}  // namespace

Result<OwnedSpheres> AssignOwnership(const RawCharacter& ch, const BodyParts& parts, std::span<const PartSpheres> paper,
                                     int refine_iterations) {
  OwnedSpheres out;
  std::vector<uint32_t> part_first(parts.parts.size() + 1, 0);
  for (size_t k = 0; k < paper.size(); ++k) {
    part_first[k] = static_cast<uint32_t>(out.spheres.size());
    for (const auto& s : paper[k].spheres) {
      out.spheres.push_back(s);
      out.part.push_back(static_cast<uint16_t>(k));
    }
  }
  part_first[paper.size()] = static_cast<uint32_t>(out.spheres.size());

  // Ownership, then (refine_iterations times) each sphere is replaced by the minimum ball of the
  // vertices it owns and ownership is redone against the new spheres.
  std::vector<int32_t> owner(ch.triangle_count(), -1);
  UniqueVertices unique(ch.triangles, ch.vertex_count());
  std::vector<Ball> balls(out.spheres.size());
  for (size_t s = 0; s < out.spheres.size(); ++s) balls[s] = out.spheres[s].ball;
  AssignToNearest(ch, parts, part_first, balls, &owner);
  for (int round = 0; round < refine_iterations; ++round) {
    MoveToOwnedBalls(ch, owner, unique, &balls);
    AssignToNearest(ch, parts, part_first, balls, &owner);
  }
  // Centres move; the radius stays the paper's (what the growth report measures against).
  for (size_t s = 0; s < out.spheres.size(); ++s) {
    if (balls[s].radius >= 0.0f) out.spheres[s].ball.center = balls[s].center;
  }
  out.triangles.resize(out.spheres.size());
  for (size_t t = 0; t < owner.size(); ++t) {
    if (owner[t] < 0) {
      return MakeError(ErrorCode::kInvalidData, ch.Name() + ": triangle " + std::to_string(t) + " belongs to no part");
    }
    out.triangles[owner[t]].push_back(static_cast<uint32_t>(t));
  }
  if (refine_iterations > 0) RecentreOnOwned(ch, unique, &out);
  return out;
}

}  // namespace skinspheres::lib
