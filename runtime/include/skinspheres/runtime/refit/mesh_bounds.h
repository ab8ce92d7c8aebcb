// What the refit's bounds (refit_job.h) need from a sphere set's mesh: which influence entries
// repeat a joint, the reach of each influence, each point's reference copies, and the smallest
// sound fast radii. The fitter stores these figures and SphereSet::Validate() holds a loaded set
// to them. Each call reads the set only; no state, safe from any thread.
#pragma once

#include <cstdint>
#include <vector>

#include "skinspheres/runtime/error.h"
#include "skinspheres/runtime/format/sphere_set.h"

namespace skinspheres::runtime {

// Which influence entries of sphere s repeat an earlier entry's joint: (*repeated)[k - influence_offsets[s]] is 1
// where influence_joints[k] is also the joint of an entry of the sphere before k, else 0 (*repeated is resized to the
// sphere's influence count). Such an entry has group blend and deviation 0, so that its joint counts once
// (docs/REFIT.md#group-blends): what Validate() requires and what the fitter writes. Needs s < set.size() and
// well-formed influence offsets.
void RepeatedInfluenceEntries(const SphereSet& set, size_t s, std::vector<uint8_t>* repeated);

// The reach of every influence entry as the set's mesh gives it (set.has_mesh() and the set's lists
// and mesh well formed, i.e. Validate() passes apart from this): for entry k of sphere s, the
// largest over the sphere's source vertices of the vertex's total weight on joint
// influence_joints[k] (its bind entries on that joint summed in order, in float, at most 1), 0 when
// none weighs it. An error naming the sphere when a source vertex has a weight > 0 on a joint that is
// not among its sphere's influences (no reach then bounds it). What the fitter stores and what
// Validate() compares a stored reach with, bit for bit.
Result<std::vector<float>> InfluenceReachFromMesh(const SphereSet& set);

// What the fast bound must hold for each point (source vertex or grid point) of each sphere, in the
// set's reference frame (the stored fast reference, else the rest pose), indexed like
// SphereSet::vertices (entry i of vertex_offsets' CSR):
//   radius[i]: around the sphere's reference centre c (fast_reference_spheres[s] or
//     centers_rest[s]), the weighted mean Σ_b w_b |copy_b - c| of the distances of the point's
//     reference copies R_j(b) · IBM_b · p_bind through each bind entry b it weighs (a grid point's
//     entries and weights W_b: docs/REFIT.md#triangle-pieces), or the farthest copy's distance
//     where float rounding of the weights puts that lower; in double in a fixed order, rounded up to
//     float (docs/REFIT.md#fast-mode);
//   weights[weight_offsets[s] + (i - vertex_offsets[s]) * K_s + (k - influence_offsets[s])]: its total
//     weight on the joint of influence entry k, summed over its bind entries in order in float, at
//     most 1 (what InfluenceReachFromMesh takes the largest of).
// Needs a mesh and otherwise well-formed lists. An error when a reference transform cannot be
// inverted, a source vertex has no weight above 0, or one is weighted on a joint that is not among
// its sphere's influences.
struct FastBoundVertices {
  std::vector<float> radius;
  std::vector<uint32_t> weight_offsets;  // per sphere
  std::vector<float> weights;
};
Result<FastBoundVertices> FastBoundVerticesFromMesh(const SphereSet& set);

// Per sphere, the largest of its points' FastBoundVertices::radius around
// fast_reference_spheres[s].head<3>() (the weighted mean distance of each point's reference copies
// R_j(b) · IBM_b · p_bind, R_j the inverse of fast_reference_inverse[j], inverted in double),
// computed in double and rounded up to float: the smallest sound
// fast_reference_spheres[s].w(). Needs a mesh, a reference (both arrays sized) and lists that are
// otherwise well formed. An error when a reference transform cannot be inverted or a source vertex
// has no weight above 0.
Result<std::vector<float>> FastReferenceRadiiFromMesh(const SphereSet& set);

}  // namespace skinspheres::runtime
