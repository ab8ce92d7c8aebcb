// The stages of SplitBodyParts (body_parts/body_parts.h), in the order it runs them. Internal to lib/.
//
//   RawCharacter::Validate   character/raw_character.cc  skeleton, triangle indices, skin arrays
//   BuildWeightedSkeleton    weighted_skeleton.cc  dominant joints, the weighted tree, subtree stats
//   FindHumanoid             humanoid_search.cc    the best (pelvis, spine, chest, head, arms, legs)
//   BuildHumanoid            humanoid_parts.cc     the six parts, leftovers attached; sides from
//     FindSides              sides.cc              the feet, else the names, else glTF's +Z facing
//   or BuildChains           chains.cc             one part per chain of the weighted tree
//   ApplyOverrides           overrides.cc          joint -> part, as the user asked
//   AssignTriangles          body_parts.cc         each triangle to its dominant joint's part
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "skinspheres/lib/body_parts/body_parts.h"

namespace skinspheres::lib {

// A sum of points and their count.
struct PointStats {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  double count = 0.0;
  Eigen::Vector3d Centroid() const { return count > 0.0 ? Eigen::Vector3d(sum / count) : Eigen::Vector3d::Zero(); }
};

// The skeleton as the split sees it: the tree, the joints that carry weight, and per-subtree
// statistics. Immutable once built.
struct WeightedSkeleton {
  int32_t n = 0;                                       // joints
  std::vector<int32_t> parent;                         // skeleton.parents
  std::vector<std::vector<int32_t>> children;          // all children, ascending
  std::vector<std::vector<int32_t>> wchildren;         // children whose subtree carries weight
  std::vector<Eigen::Vector3d> jpos;                   // rest-pose world position per joint
  std::vector<int32_t> vertex_joint;                   // dominant joint per vertex (-1: no weight)
  std::vector<bool> weighted;                          // dominant joint of some vertex or triangle
  std::vector<bool> sub;                               // weighted, or has a weighted descendant
  std::vector<PointStats> own, subtree;                // dominated vertices + the joint itself
  std::vector<double> own_vertices, subtree_vertices;  // dominated vertex counts
  std::vector<int32_t> subtree_weighted;               // weighted joints in the subtree
  double total_vertices = 0.0;
  int32_t total_weighted = 0;

  // a is j or above j.
  bool IsAncestor(int32_t a, int32_t j) const;
  // The main chain from `root`: at a fork, on to the child (weighted subtrees first) whose subtree
  // holds the joint farthest from `root` in the rest pose (the middle finger, the toe); ties ->
  // smallest index.
  std::vector<int32_t> MainChain(int32_t root) const;
};

// The weighted skeleton, and the dominant joint of every triangle (the joint with the largest
// summed weight over its 3 vertices; ties -> smallest index; a weightless triangle takes its mesh's
// rigid joint, else joint 0). The input must have passed RawCharacter::Validate.
WeightedSkeleton BuildWeightedSkeleton(const RawCharacter& ch, std::vector<int32_t>* triangle_joint);

// Every joint of `root`'s subtree goes to `part` (joint_part).
void MarkSubtree(const WeightedSkeleton& ws, int32_t root, int32_t part, std::vector<int32_t>* joint_part);
// part.joints = part.chain, then the part's other joints depth-first from the chain and `roots`.
void FillJoints(const WeightedSkeleton& ws, std::span<const int32_t> joint_part, int32_t part_index,
                const std::vector<int32_t>& roots, BodyPart* part);

// A humanoid reading of the skeleton: the pelvis P, its child s that starts the spine, the chest C
// (below s), and the roots of the head, arms and legs; cost = inf when there is none.
struct HumanoidCandidate {
  int32_t pelvis = -1, spine_child = -1, chest = -1, head = -1;
  int32_t arm[2] = {-1, -1};
  int32_t leg[2] = {-1, -1};
  double cost = std::numeric_limits<double>::infinity();
};
// Candidates cheaper than this are humanoid.
inline constexpr double kHumanoidMaxCost = 1.5;
// Scores every (P, s, C, head, arms, legs) candidate; returns the cheapest (first on ties).
HumanoidCandidate FindHumanoid(const WeightedSkeleton& ws);

// The six parts of a humanoid (torso, head, arm_l, arm_r, leg_l, leg_r): out->parts, joint_part,
// humanoid, up, left, facing_from.
void BuildHumanoid(const RawCharacter& ch, const WeightedSkeleton& ws, const HumanoidCandidate& c, BodyParts* out);

// Which side is the character's left. `joint_part` holds the provisional parts (0 torso, 1 head,
// 2/3 the candidate's arm[0]/arm[1], 4/5 its leg[0]/leg[1]).
struct Sides {
  Eigen::Vector3d up = Eigen::Vector3d::Zero();    // legs -> head
  Eigen::Vector3d left = Eigen::Vector3d::Zero();  // up x forward (not yet normalised)
  const char* from = "";                           // "feet", "names" or "convention"
  bool swap_arms = false, swap_legs = false;       // arm[1] / leg[1] is the left one
};
Sides FindSides(const RawCharacter& ch, const WeightedSkeleton& ws, const HumanoidCandidate& c,
                std::span<const int32_t> joint_part);

// Not humanoid: one part per chain of the weighted tree (chain_<k>, depth-first).
void BuildChains(const WeightedSkeleton& ws, BodyParts* out);

// Moves each overridden joint (and so its triangles) to the named part. kNotFound: a joint the
// skeleton lacks; kInvalidArgument: a part this character does not have.
std::optional<Error> ApplyOverrides(const RawCharacter& ch, const PartOverrides& overrides, BodyParts* out);

}  // namespace skinspheres::lib
