// The contact rules: which pairs of a character's triangles are contacts. They are stated on the
// mesh alone, never on the spheres, so what a character reports does not depend on how it was
// fitted (narrow_phase.h finds the pairs; the spheres only filter).
//
// Two source triangles t != u of a set with ContactRules::kTriangles (sphere_set.h) are a CONTACT in
// a frame when they intersect (triangle_contact.h: touching counts), or, with a margin
// (NarrowPhaseSettings::margin > 0), come closer than the margin, and none of these holds:
//  1. SHARED VERTEX: a vertex of t has the bit-identical rest position of a vertex of u (glTF splits
//     vertices along UV and normal seams; two pieces of one cut triangle count as the triangle).
//  2. NEAR JOINTS: their joints are at most SphereSet::contact_hops bones apart (default 1: the same
//     joint, or parent and child) in the skin's joint tree. A triangle's joint is the joint with the
//     largest skin weight summed over its three vertices (ties: the lower joint index). The skin's
//     joint tree holds the joints the mesh's bind entries name; a joint's parent there is its
//     nearest ancestor among them (nodes that are not joints are skipped).
//  3. NEAR AT REST: in the rest pose they intersect, or lie closer than the rest gap
//     (SphereSet::rest_gap, in model units; by default kDefaultRestGapShare of the rest height),
//     or, with a margin, closer than the margin: creases, layered pieces, fingers side by side
//     (NearAtRest). The rest pose is the mesh skinned with the skeleton's rest transforms
//     (RestPositions).
// A triangle DEGENERATE in the frame (two corners equal or all three collinear in its float
// positions; a repeated vertex index among them) has no area and is never a contact
// (triangle_contact.h): its edges are those of the triangles beside it, which are tested.
// Everything else that intersects is reported, in exact and fast mode, on every platform, for one
// character and in crowds. Rule 3 is decided for the pairs that meet in a frame, from the rest
// positions (no list of pairs is stored: a dense hand's fingers lie side by side by the million).
//
// The spheres only filter: SphereSet::excluded_pairs lists the sphere pairs whose every pair of
// triangles (or pieces) is excluded by rule 2 in every pose (every joint of one sphere's triangles
// within contact_hops of every joint of the other's); the broad phase never reports those, and no
// other pair is dropped. A sphere holding triangles of joints further apart is also tested against
// itself.
//
// Sets written before these rules (ContactRules::kSpherePairs: JSON before version 4, binary before
// layout 6) keep the rules they were fitted with, stated on sphere pairs: pairs of triangles owned by
// spheres their excluded_pairs name (same joint, adjacent joints, overlapping at rest) are never
// tested, nor the triangles of one sphere against each other; rules 1 and 3 hold with a rest gap of 0
// (and the margin). What such a set reports depends on its fit; fit the character again for these
// rules.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "skinspheres/runtime/error.h"
#include "skinspheres/runtime/format/sphere_set.h"

namespace skinspheres::runtime {

// Rule 2's default, and the most a set may state (the fitter's --hops: 0, 1 or 2).
inline constexpr uint32_t kDefaultContactHops = 1;
inline constexpr uint32_t kMaxContactHops = 2;
// Rule 3's default rest gap, as a share of the rest height (the mesh at rest, its extent along +Y),
// and the largest allowed: a gap is a crease's width, not a search radius (the pairs within it grow
// with its square).
inline constexpr float kDefaultRestGapShare = 0.01f;
inline constexpr float kMaxRestGapShare = 0.05f;

// A triangle with no skin weight at all has this joint: near no joint, not even its own kind.
inline constexpr uint16_t kNoTriangleJoint = 0xFFFF;

// The mesh skinned with the skeleton's rest transforms, per source vertex (what the spheres were
// fitted on and rule 3 measures). False when the bind entries and the skeleton disagree. Needs a set
// with a mesh.
bool RestPositions(const SphereSet& set, std::vector<Eigen::Vector3f>* out);

// The extent along +Y (glTF's up) of the given positions: the rest height the rest gap's and the
// touch tolerance's shares are taken of.
float RestHeight(std::span<const Eigen::Vector3f> positions);

// Rule 1: per source vertex, the first source vertex with the bit-identical rest position (-0 and +0
// alike).
std::vector<uint32_t> WeldedVertices(std::span<const Eigen::Vector3f> rest_positions);

// Rule 2's joint of each source triangle (above), or kNoTriangleJoint. Needs a set with a mesh whose
// influences and bind entries are well formed (Validate() apart from the rules).
std::vector<uint16_t> TriangleJoints(const SphereSet& set);

// Rule 2's joint pairs: per skeleton joint, the joints at most `hops` bones from it in the skin's
// joint tree (itself included), sorted.
class NearJoints {
 public:
  // Up to this many joints a bit per joint pair answers (128 KB at most); beyond, a search per query.
  static constexpr size_t kDenseJoints = 1024;

  NearJoints() = default;
  NearJoints(const SphereSet& set, uint32_t hops);
  // Any a, b: false when either is kNoTriangleJoint or not a joint.
  bool operator()(uint16_t a, uint16_t b) const {
    if (a >= count_ || b >= count_) return false;
    if (!dense_.empty()) return ((dense_[a * words_ + (b >> 6)] >> (b & 63)) & 1u) != 0;
    return Search(a, b);
  }
  // a < joint count.
  std::span<const uint16_t> of(uint16_t a) const {
    return {joints_.data() + offsets_[a], joints_.data() + offsets_[a + 1]};
  }

 private:
  bool Search(uint16_t a, uint16_t b) const;
  size_t count_ = 0, words_ = 0;
  std::vector<uint32_t> offsets_;  // joint count + 1
  std::vector<uint16_t> joints_;
  std::vector<uint64_t> dense_;  // count_ <= kDenseJoints: row a's bit b
};

// The sphere pairs i < j the rules exclude in every pose: every joint of one sphere's triangles (whole
// or cut) within `hops` of every joint of the other's (rule 2), reason kSameJoint when all of them
// are one joint, else kAdjacentJoints. Sorted. triangle_joints: TriangleJoints(set).
std::vector<ExcludedPair> ExcludedSpherePairs(const SphereSet& set, std::span<const uint16_t> triangle_joints,
                                              const NearJoints& near);

// Rule 3: whether the triangles with vertices a[0..2] and b[0..2] intersect, or lie closer than
// `distance` (>= 0), at the rest positions: their boxes apart by more than `distance` on an axis
// first, then TriangleContactOf (triangle_contact.h: a degenerate triangle is near nothing). What the
// narrow phase and its oracle both call, with distance the larger of the rest gap and the margin.
bool NearAtRest(const Eigen::Vector3f* rest, const uint32_t a[3], const uint32_t b[3], float distance);

// Fills the rules of a set (contact_rules, contact_hops, rest_gap and excluded_pairs) for rule 2 at
// `hops` and a rest gap of rest_gap_share of the rest height (0 without a mesh): what the fitter
// writes, and what a set made by hand calls. kInvalidArgument for hops above kMaxContactHops or a
// share outside [0, kMaxRestGapShare]; kInvalidData when the mesh cannot be skinned at rest.
std::optional<Error> WriteContactRules(SphereSet* set, uint32_t hops, float rest_gap_share);

// The rules' part of SphereSet::Validate(): hops and gap in range (with a mesh, the gap at most
// kMaxRestGapShare of the rest height); with kTriangles and a mesh, every excluded sphere pair
// excluded whole by rule 2 (a pair listed that is not would hide contacts). Needs the rest of
// Validate() to have passed.
std::optional<Error> CheckContactRules(const SphereSet& set);

}  // namespace skinspheres::runtime
