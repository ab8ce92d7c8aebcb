// PoseSolver: one pose's joint rotations changed as little as possible so that no part pair
// penetrates deeper than a limit, given a way to play a pose (the per-frame step of `skinspheres
// fix`, and of PoseFixer for engines). Method: docs/TOOL.md#fixing-clips.
//
// What:    Solve() turns the joints on the chains between each penetrating part pair's two sides
//          (damped least squares on the contact centre along the contact normal, distal joints
//          cheaper, a step kept only when the summed excess depth over every pair goes down).
// Inputs:  the skeleton's parents (parents[i] < i), each source triangle's joint (TriangleJoints),
//          the source pose (local transforms), a correction per joint (a rotation vector applied
//          before the joint's local rotation, in its parent's frame) to start from, and a callback
//          that plays a pose: its contacts and its joints' world matrices, both valid until the
//          callback runs again.
// Outputs: the correction, changed in place; the steps taken, or -1 when the pose still fails.
// Memory:  allocates per call (small: one row per penetrating pair). Not for a per-frame budget
//          of microseconds: each step plays the pose again.
// Threads: const; one callback per thread. Errors: what the callback returns.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <span>
#include <utility>
#include <vector>

#include "skinspheres/runtime/error.h"
#include "skinspheres/runtime/narrow_phase/narrow_phase.h"
#include "skinspheres/skinning/skeleton.h"
#include "skinspheres/skinning/skinned_mesh.h"

namespace skinspheres::runtime {

struct PoseSolveSettings {
  float max_depth = 0.0f;                            // model units: deeper fails
  int iterations = 8;                                // least-squares steps at most
  float max_rotation_rad = 1.0471976f;               // largest correction of one joint (60 degrees)
  std::vector<std::pair<uint16_t, uint16_t>> allow;  // part pairs left alone (part_a <= part_b)
};

// A played pose, as the callback returns it.
struct PlayedPose {
  const FrameContacts* contacts = nullptr;
  std::span<const Mat4f> joint_world;
};
using PlayPoseFn = std::function<Result<PlayedPose>(std::span<const skinning::Transform> pose)>;

// A part pair deeper than a limit in a played pose.
struct PoseViolation {
  uint16_t part_a = 0, part_b = 0;
  float depth = 0.0f;
  Eigen::Vector3f normal = Eigen::Vector3f::Zero();  // from part_b towards part_a
  Eigen::Vector3f center = Eigen::Vector3f::Zero();
  int32_t joint_a = -1, joint_b = -1;       // each side's most frequent joint among its intersecting triangles
  std::vector<int32_t> joints_a, joints_b;  // every joint of each side's intersecting triangles
};

// Each triangle's joint: the one with the largest summed weight over its three vertices.
// triangle_vertices: 3 per triangle, indices into the mesh's vertices.
std::vector<int32_t> TriangleJoints(const skinning::SkinnedMesh& mesh, std::span<const uint32_t> triangle_vertices);

// `source` with `correction` applied (per joint, a rotation vector before the local rotation).
void ApplyCorrection(std::span<const skinning::Transform> source, std::span<const Eigen::Vector3f> correction,
                     std::vector<skinning::Transform>* pose);

class PoseSolver {
 public:
  PoseSolver(std::vector<int32_t> parents, std::vector<int32_t> triangle_joint)
      : parents_(std::move(parents)), triangle_joint_(std::move(triangle_joint)) {}
  // The part pairs of `contacts` (not allowed) penetrating deeper than `limit`.
  std::vector<PoseViolation> Violations(const FrameContacts& contacts, float limit,
                                        const std::vector<std::pair<uint16_t, uint16_t>>& allow) const;
  // Steps from `correction` until no pair is deeper than 0.9 of the limit: the steps taken, or -1.
  Result<int> Solve(std::span<const skinning::Transform> source, const PoseSolveSettings& settings,
                    const PlayPoseFn& play, std::vector<Eigen::Vector3f>* correction) const;

 private:
  std::vector<int32_t> parents_, triangle_joint_;
};

}  // namespace skinspheres::runtime
