// glTF 2.0 -> RawCharacter, read from the JSON and binary buffers directly (not through Assimp):
// this keeps the file's vertex and triangle order exactly, validates JOINTS_n/WEIGHTS_n from the
// accessors, and keeps the animation samplers' STEP/LINEAR/CUBICSPLINE interpolation, which
// Assimp 5.2.5 drops (aiNodeAnim has no interpolation field).
// Spec references: glTF 2.0 §3.5 (nodes, TRS/matrix), §3.7 (meshes, primitive modes),
// §3.7.3 (skins: jointMatrix = G_joint · IBM; a skinned mesh node's own transform is ignored),
// §3.11 (animations), and the JSON schema of each object (node.schema.json, skin.schema.json,
// animation.sampler.schema.json) where a rule is stated there.
// Work is linear in the number of nodes (no walk to the root per node) and nothing recurses.
// The stages, one file each, are listed in importer_gltf_stages.h.
#include "importer_gltf_stages.h"

namespace skinspheres::lib::detail {

Result<RawCharacter> ImportGltf(const std::filesystem::path& file, std::span<const uint8_t> bytes,
                                const ImportOptions& options) {
  Result<GltfDocument> loaded = LoadGltf(file, bytes);
  if (!loaded.ok()) return loaded.error();
  const GltfReadContext ctx{*loaded, file};
  GltfScene scene;
  if (std::string p = ReadNodes(ctx.doc.json, &scene.nodes); !p.empty()) return ctx.Rejected(p);
  RawCharacter c;
  if (auto e = ReadSceneAndSkeleton(ctx, &scene, &c)) return *e;
  if (auto e = ReadMeshes(ctx, scene, &c)) return *e;
  if (options.read_clips && scene.skinned_file) {
    if (std::string p = ReadClips(ctx.doc, scene.nodes, scene.joint_of_node, &c.clips); !p.empty())
      return ctx.Invalid(p);
  }
  return c;
}

}  // namespace skinspheres::lib::detail
