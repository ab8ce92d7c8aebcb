// The same character as other rigs, for tests of retargeting (and `export-builtin`): edits that
// keep the motion in world space but change what a clip's local tracks mean.
//
// RotateJointFrames: every joint's local frame turned by its own rotation R_j (about its origin;
// axis and angle from a seeded generator, angles 30-150°), so the world rest pose, the mesh and
// the world motion stay the same while every local rest rotation, offset and key changes:
//   L'_j = R_parent⁻¹ · L_j · R_j,  IBM'_j = R_j⁻¹ · IBM_j,
// every key of every clip likewise (CUBICSPLINE tangents too: the map is linear). Scales must be
// uniform (a non-uniform scale does not turn with its frame): kInvalidArgument otherwise.
// ScaleBones: the whole rig and mesh scaled by s about the origin: every rest and keyed
// translation, every vertex and every IBM's translation times s (bones s times as long, the
// same rotations).
#pragma once

#include <cstdint>
#include <optional>

#include "skinspheres/lib/character/raw_character.h"

namespace skinspheres::lib {

std::optional<Error> RotateJointFrames(RawCharacter& character, uint32_t seed);
void ScaleBones(RawCharacter& character, float s);

}  // namespace skinspheres::lib
