// Private to the GLB exporter (glb_exporter.cc, which builds the aiScene and exports it): its
// stages, one file each. Not installed; include only from lib/src/io/.
//   glb_export_validate.cc    the checks on the input, before anything is built
//   glb_export_meshes.cc      one aiMesh per MeshRange (vertices, faces, weights, bones, normals)
//                             and the unit sphere of the extras
//   glb_export_animations.cc  the clips baked to LINEAR keys, and the spheres' channels
// Ownership as in glb_exporter.cc: every array is allocated with new[], as Assimp's destructors expect.
#pragma once

#include <assimp/scene.h>

#include <Eigen/Core>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "skinspheres/lib/io/glb_exporter.h"

namespace skinspheres::lib::detail {

aiMatrix4x4 ToAi(const Mat4f& m);
aiVector3D ToAi(const Eigen::Vector3f& v);
aiQuaternion ToAi(const Quatf& q);

// --- The input checks (glb_export_validate.cc) ---

// RawCharacter::Validate's rules, then what the GLB needs beyond them (a consistent skin even
// without vertices, one inverse bind matrix per joint, finite rest positions, meshes inside the
// arrays, ordered clip tracks on existing joints, extras that match their frame times).
// kInvalidArgument "ExportGlb <path>: <problem>" or nullopt.
std::optional<Error> ValidateForExport(const RawCharacter& c, const GlbExtras& e, const std::filesystem::path& path);

// --- The meshes (glb_export_meshes.cc) ---

// The mesh of `range`, named `name`: vertices and faces, weights and bones (skinned: bind space,
// at most 4 influences per vertex; `all_binds` adds a weightless bone for every bind entry no
// vertex uses) or rest positions in the rigid joint's rest space (rigid), and smooth normals.
aiMesh* MakeRangeMesh(const RawCharacter& c, const MeshRange& range, const std::string& name,
                      const std::vector<std::string>& joint_names, const std::vector<Mat4f>& rest_world,
                      bool all_binds);
// A unit sphere centred on the origin, outward faces, normals = positions.
aiMesh* UnitSphereMesh(int segments, int rings);

// --- The animations (glb_export_animations.cc) ---

// One animation per clip (channels on joint_names[joint], every animated joint with translation,
// rotation and scale), in clip order.
std::vector<aiAnimation*> MakeClipAnimations(const RawCharacter& c, const std::vector<std::string>& joint_names);
// The spheres' channels (nodes sphere_nodes[i]): added to the animation named extras.clip_name,
// else appended as an animation of that name. Nothing when extras.spheres is empty.
void AddSphereAnimation(const GlbExtras& extras, const std::vector<std::string>& sphere_nodes,
                        std::vector<aiAnimation*>* anims);

}  // namespace skinspheres::lib::detail
