// Colliders for engines: a few spheres and capsules attached to joints, which cloth, hair and spring
// bones collide with, fitted to cover the body over its motion within an engine's budget.
//
// What: FitColliders turns a character and a set of poses (the rest pose and clip frames) into at
// most `budget` shapes, each attached to one joint; EvaluateColliders measures, pose by pose, how
// well any set of shapes covers the skinned mesh; PerBoneCapsules is the usual automatic
// generator (one capsule per bone), the baseline the fit is compared with. The method, the
// measures and the figures are in docs/COLLIDERS.md.
// Inputs: a RawCharacter that passes Validate(), with a skin (a character without one has a
// single rigid pose and gets shapes on its root); poses as local joint transforms, one per joint.
// Outputs: shapes in the joint's frame (see Collider). Allocation: proportional to vertices times
// poses. Threads: TBB over poses and groups; results do not depend on the thread count.
// Errors: kInvalidArgument "colliders: ..." for a budget below 1, a pose of the wrong size, or no
// vertices.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "skinspheres/lib/character/raw_character.h"
#include "skinspheres/runtime/error.h"
#include "skinspheres/skinning/skeleton.h"

namespace skinspheres::lib {

// A sphere (head == tail, head_radius == tail_radius) or a capsule: the convex hull of the sphere
// at `head` and the sphere at `tail` (tapered when the radii differ). Points are in the joint's
// rigid frame: its world rotation and translation without scale, in model units, so that
// world = R_joint · p + t_joint. Radii are in model units.
struct Collider {
  uint32_t joint = 0;
  Eigen::Vector3f head = Eigen::Vector3f::Zero();
  Eigen::Vector3f tail = Eigen::Vector3f::Zero();
  float head_radius = 0.0f;
  float tail_radius = 0.0f;
  std::string part;  // body part of the joint ("torso", "arm_l", ...), for collider groups
  bool is_sphere() const { return head == tail; }
};

enum class ColliderShapes { kSpheres, kCapsules, kBoth };

struct ColliderSettings {
  int budget = 32;
  ColliderShapes shapes = ColliderShapes::kBoth;
  bool tapered = true;            // capsules may have two radii (Unity sphere pairs, USD, json)
  float tolerance_share = 0.01f;  // covered: inside, or outside by at most this share of the height
  float covered_quantile = 1.0f;  // each shape covers this share of its vertices over the fit poses
  float slack_share = 0.95f;      // ... within this share of the tolerance (the rest: a margin)
  int max_fit_poses = 64;         // poses used to fit (evenly chosen among those given)
};

// One world-space pose of the character: per joint its world matrix, and the skinned vertices.
struct PosedCharacter {
  std::vector<Mat4f> joint_world;
  std::vector<Eigen::Vector3f> vertices;
};
// Skins `local` (one transform per joint) by linear blend skinning.
Result<PosedCharacter> PoseCharacter(const RawCharacter& character, std::span<const skinning::Transform> local);
// The joint's rigid frame in a pose: its world matrix with the scale divided out of each column.
Mat4f RigidFrame(const Mat4f& joint_world);

struct ColliderFit {
  std::vector<Collider> colliders;
  std::vector<uint32_t> vertex_group;  // per vertex: index of the collider fitted to it
  float height = 0.0f;                 // BodyHeight (geometry/mesh_helpers.h) of the rest pose
  size_t fit_poses = 0;
};
// poses: each a local pose (skeleton.size() transforms); the rest pose is always added first.
Result<ColliderFit> FitColliders(const RawCharacter& character, std::span<const std::vector<skinning::Transform>> poses,
                                 std::span<const std::string> joint_part, const ColliderSettings& settings);

// The signed distance from p to a collider placed in world space (negative inside).
float ColliderDistance(const Eigen::Vector3f& p, const Eigen::Vector3f& head, float head_radius,
                       const Eigen::Vector3f& tail, float tail_radius);
// A collider moved to world space by its joint's rigid frame in a pose.
struct PlacedCollider {
  Eigen::Vector3f head, tail;
  float head_radius = 0.0f, tail_radius = 0.0f;
};
PlacedCollider PlaceCollider(const Collider& c, const Mat4f& joint_world);

struct ColliderPoseStats {
  float covered = 0.0f;   // share of vertices inside or within the tolerance
  float poke_p95 = 0.0f;  // 95th percentile over vertices of how far outside every shape (0 inside)
  float poke_max = 0.0f;
  float standoff = 0.0f;     // mean over vertices of how far inside the colliders' surface they lie (0 outside)
  float surface_gap = 0.0f;  // mean distance of the shapes' exposed surface from the mesh, by area
};
struct ColliderShapeStats {
  float covered = 0.0f;      // of the vertices nearest this shape, share covered by the set, over poses
  float poke_p95 = 0.0f;     // of those vertices, over poses
  float standoff = 0.0f;     // of the vertices nearest this shape, over poses
  float surface_gap = 0.0f;  // of this shape's exposed surface, over poses
};
struct ColliderCoverage {
  float height = 0.0f;
  float tolerance = 0.0f;  // model units
  std::vector<ColliderPoseStats> poses;
  std::vector<ColliderShapeStats> shapes;
  float min_covered = 0.0f, mean_covered = 0.0f;
  float poke_p95 = 0.0f;       // over every (pose, vertex)
  float mean_standoff = 0.0f;  // over poses
  float max_standoff = 0.0f;   // the worst pose's mean
  float mean_surface_gap = 0.0f, max_surface_gap = 0.0f;
};
// Measures `colliders` on each pose (local transforms). Standoff is what cloth resting on the
// colliders sees: how far each vertex lies under their surface. The surface gap looks from the
// shapes instead: points spread evenly by area over each shape's surface that lie inside no other
// shape, and their exact distance to the mesh (MeshDistances), counting where shapes bridge hollows.
Result<ColliderCoverage> EvaluateColliders(const RawCharacter& character,
                                           std::span<const std::vector<skinning::Transform>> poses,
                                           std::span<const Collider> colliders, float tolerance_share);

// The usual automatic generator: per bone (a joint with vertices, to its child joint with the
// most vertices below it, or a point when it has none) one capsule of constant radius around the
// vertices whose largest weight is that joint, at rest. covering: the radius reaches the farthest
// of them; else their median distance. The `count` bones with the most vertices keep theirs.
std::vector<Collider> PerBoneCapsules(const RawCharacter& character, int count, bool covering);

}  // namespace skinspheres::lib
