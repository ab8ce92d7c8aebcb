// MakeBuiltinCharacter: a procedural skinned humanoid generated in code, for tests, demos and
// benchmarks that must run without the shared assets.
//
// Shape: about 1.81 units tall (feet at y = 0, head top at y ≈ 1.81), +Y up, facing +Z, the
// character's left on +X, standing in a T-pose (arms along ±X, clear of the torso). Nine closed,
// watertight, outward-oriented pieces, one MeshRange each, all skinned. The pieces touch each
// other only where a body would: the arms hang from shoulder joints 0.24 out from the axis, so an
// arm never passes through the torso, and in the clips no two pieces intersect except a hand and
// the chest or the head in the touch windows (pieces that overlap at rest, the neck in the torso
// and the head on the neck, stay as they are):
//   "TorsoMesh" pelvis to chest, ELLIPTIC section (half-width a along X > half-depth b along Z,
//              a/b ≈ 1.5 at the chest: the paper's non-tubular case), domed caps at both ends;
//   "NeckMesh", "HeadMesh" (an ellipsoid, semi-axes 0.085 x 0.11 x 0.10);
//   "LeftArmMesh", "RightArmMesh"  one tube each: upper arm, forearm and a flat hand (wider than thick);
//   "LeftLegMesh", "RightLegMesh"  thigh and shin;  "LeftFootMesh", "RightFootMesh".
// (Mesh names differ from joint names: glTF writers and readers match nodes by name.)
// 8,720 triangles (4,378 vertices), 26 joints with Mixamo-like names (Armature root, Hips, Spine, Spine1,
// Spine2, Neck, Head, HeadTop_End, {Left,Right}{Shoulder,Arm,ForeArm,Hand},
// {Left,Right}{UpLeg,Leg,Foot,ToeBase,Toe_End}); every rest rotation is the identity.
// Rest pose = bind pose: IBM_j = (rest world of joint j)^-1, positions_bind = positions_rest.
// Skin weights blend smoothly across each joint (2 influences near a joint, never more than 4, so
// a glTF JOINTS_0/WEIGHTS_0 round trip is exact), normalised to sum 1.
//
// Clips (all rotation tracks LINEAR unless said):
//   "walk"  1.0 s loop (first key = last key): thighs swing ±25°, knees bend in the swing phase,
//           arms lowered 75° and swing ±20° opposite to the legs, spine twists ±5°; the Hips
//           translation bobs ±0.015 with a CUBICSPLINE track.
//   "touch" 4.0 s: from the T-pose both hands come forward (in front of the body at 0.4 s), move
//           onto the front of the chest, stay, move onto the sides of the head, stay, and
//           return. Hand surfaces reach into the chest / head surface (about 1 cm deep at the
//           palm centre, 4 cm at the fingertips on the chest) over the whole windows below:
//             chest contact: t ∈ [kTouchChestBegin_s, kTouchChestEnd_s] = [0.8, 1.6] s
//             head contact:  t ∈ [kTouchHeadBegin_s,  kTouchHeadEnd_s]  = [2.4, 3.2] s
//           and a few frames either side of them; nothing else of the arms touches anything.
//           HeadTop_End carries a STEP rotation track (no vertex depends on it).
#pragma once

#include "skinspheres/lib/character/raw_character.h"

namespace skinspheres::lib {

inline constexpr float kTouchChestBegin_s = 0.8f;
inline constexpr float kTouchChestEnd_s = 1.6f;
inline constexpr float kTouchHeadBegin_s = 2.4f;
inline constexpr float kTouchHeadEnd_s = 3.2f;
inline constexpr float kTouchDuration_s = 4.0f;
inline constexpr float kWalkDuration_s = 1.0f;

// Builds the character described above. Deterministic: every call returns the same data.
RawCharacter MakeBuiltinCharacter();

}  // namespace skinspheres::lib
