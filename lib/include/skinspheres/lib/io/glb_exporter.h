// ExportGlb: writes a RawCharacter (and optionally animated sphere meshes) to a binary glTF 2.0
// file through Assimp's "glb2" exporter, so any glTF viewer can play it back (ExportGlbToMemory:
// the same bytes in memory; ExportFbxAscii: the same scene as ASCII FBX 7.4).
//
// What is written:
//  - the skeleton as the node tree (rest_local as each node's transform), one node per joint named
//    as the joint; a name used by an earlier joint (glTF allows repeats: RobotExpressive has two
//    "Foot.L") gets "_2", "_3", ..., an empty one "joint_<index>". When the skeleton has
//    one root whose rest transform is the identity, that joint is the scene root; otherwise a
//    node "Root" (identity) is added above the skeleton roots (and a re-import sees it as an
//    extra joint).
//  - one mesh per MeshRange, as a child node of the scene root, with one skin for all skinned
//    meshes (Assimp writes one glTF skin): POSITION = skin.positions_bind, JOINTS_0 / WEIGHTS_0,
//    inverse bind matrices = BindEntry::inverse_bind. Rigid ranges (skinned = false) hang under
//    their rigid_joint (or the root) with vertices in that joint's rest space. Triangles keep
//    their order inside each range (glTF triangle k of mesh r = character triangle
//    r.first_triangle + k). A character without meshes (a skeleton with clips: an
//    animation-only file) is written as its node tree and animations alone.
//  - NORMAL per vertex (viewers light the mesh with it; RawCharacter carries none): smooth
//    normals computed from the written positions, area-weighted over the triangles around each
//    vertex, with vertices at exactly the same position inside a range sharing one normal (so UV
//    seams do not show); a vertex on no non-degenerate triangle gets +Y.
//  - every clip as one glTF animation with the clip's name. Assimp's glTF writer only knows
//    LINEAR, so STEP tracks are written as LINEAR with an extra key kStepBakeEpsilon_s before
//    each change, and CUBICSPLINE tracks are sampled kCubicBakeSubdivisions times per key
//    interval (exact at the keys, within the chord error in between). Every animated joint gets
//    translation, rotation and scale channels (a missing channel is written as one key holding
//    the rest value).
//  - extras.spheres: one unit-sphere mesh node per AnimatedSphere ("sphere_<i>", under the scene
//    root), animated by per-frame translation (x, y, z) and uniform scale (r) keys at
//    extras.frame_times_s. When extras.clip_name is the name of one of the character's clips,
//    those channels are part of that clip's animation (one glTF animation plays the character and
//    its spheres together; the character's other clips leave the spheres where the first frame
//    put them); otherwise they form an extra animation of that name.
//
// Limits (Assimp 5.2.5's glTF2 writer): at most 4 influences per vertex survive (JOINTS_0 only;
// the 4 largest are kept, weights renormalised); a joint may carry one inverse bind matrix (bind
// entries that share a joint with different matrices are refused: kInvalidArgument); Assimp
// joins identical vertices inside a mesh (a mesh without exact duplicate positions keeps its
// vertex order and count). Errors: kInvalidArgument (inconsistent input, named: RawCharacter::Validate's
// rules first, then the exporter's own), kFileUnreadable
// (Assimp could not write the file; its message is included).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "skinspheres/lib/character/raw_character.h"
#include "skinspheres/runtime/error.h"
#include "skinspheres/skinning/math_types.h"

namespace skinspheres::lib {

inline constexpr float kStepBakeEpsilon_s = 1e-4f;
inline constexpr int kCubicBakeSubdivisions = 8;

struct AnimatedSphere {
  std::vector<Vec4f> per_frame_xyzr;  // world centre and radius, one per frame time
};

struct GlbExtras {
  std::vector<AnimatedSphere> spheres;
  std::vector<float> frame_times_s;   // clip times, strictly increasing; each sphere has this many frames
  std::string clip_name = "spheres";  // the character's clip the spheres belong to, or a new clip's name
  int sphere_segments = 16;           // unit-sphere mesh: longitudes (>= 3)
  int sphere_rings = 8;               // latitudes between the poles (>= 2)
};

struct GlbExportSummary {
  uint32_t mesh_count = 0;  // character pieces + spheres
  uint32_t node_count = 0;
  uint32_t animation_count = 0;              // clips written (character clips + the sphere clip if any)
  std::vector<std::string> mesh_node_names;  // per MeshRange, the name of the node holding it
};

struct GlbBlob {
  std::vector<uint8_t> bytes;  // a whole .glb file
  GlbExportSummary summary;
};

Result<GlbExportSummary> ExportGlb(const RawCharacter& character, const std::filesystem::path& path,
                                   const GlbExtras& extras = {});

// The GLB bytes ExportGlb would write, in memory. Error messages name `label` (e.g. the source file).
Result<GlbBlob> ExportGlbToMemory(const RawCharacter& character, const std::string& label,
                                  const GlbExtras& extras = {});

// The same scene as ASCII FBX 7.4 (Assimp's "fbxa"; key times written in seconds). Assimp 5.2.5's
// binary FBX writer makes files its own reader refuses, hence ASCII. Limits as above; Assimp's FBX
// writer re-derives bind matrices from the node tree (rest pose = bind pose in the file).
Result<GlbExportSummary> ExportFbxAscii(const RawCharacter& character, const std::filesystem::path& path);

}  // namespace skinspheres::lib
