// The glTF reader's scene, skeleton and skins: the default scene's roots and mesh instances, the
// skeleton (glTF 2.0 §3.7.3: jointMatrix = G_joint · IBM; a skinned mesh node's own transform is
// ignored) and each used skin's bind entries (skin.schema.json: joints are unique node indices).
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "importer_gltf_stages.h"

namespace skinspheres::lib::detail {
namespace {

using nlohmann::json;
using skinning::Transform;

// The scene: json["scene"], else scene 0, else (no scenes) every root node.
std::optional<Error> ReadSceneRoots(const GltfReadContext& ctx, const std::vector<GltfNode>& nodes,
                                    std::vector<int32_t>* scene_roots) {
  const json& j = ctx.doc.json;
  const int32_t n_nodes = static_cast<int32_t>(nodes.size());
  const json& scenes = ArrayOrEmpty(j, "scenes");
  if (!scenes.empty()) {
    const int64_t s = Integer(j, "scene", 0);
    if (s < 0 || s >= static_cast<int64_t>(scenes.size()))
      return ctx.Invalid("\"scene\" " + std::to_string(s) + " does not exist");
    for (const auto& r : ArrayOrEmpty(scenes[static_cast<size_t>(s)], "nodes")) {
      const int64_t root = Integer(r, "nodes");
      if (root < 0 || root >= n_nodes || nodes[static_cast<size_t>(root)].parent != -1) {
        return ctx.Invalid("the scene lists node " + std::to_string(root) + ", which is not a root node");
      }
      scene_roots->push_back(static_cast<int32_t>(root));
    }
  } else {
    for (int32_t n = 0; n < n_nodes; ++n) {
      if (nodes[static_cast<size_t>(n)].parent == -1) scene_roots->push_back(n);
    }
  }
  return std::nullopt;
}

// Mesh instances of the scene (the roots and every node under them), in mesh order, then node order.
std::optional<Error> ReadMeshInstances(const GltfReadContext& ctx, const std::vector<int32_t>& scene_roots,
                                       GltfScene* scene) {
  const std::vector<GltfNode>& nodes = scene->nodes;
  std::vector<char> in_scene(nodes.size(), 0);
  for (int32_t r : scene_roots) in_scene[static_cast<size_t>(r)] = 1;
  for (int32_t n : scene->preorder) {
    const int32_t p = nodes[static_cast<size_t>(n)].parent;
    if (p >= 0 && in_scene[static_cast<size_t>(p)]) in_scene[static_cast<size_t>(n)] = 1;
  }
  const size_t n_meshes = ArrayOrEmpty(ctx.doc.json, "meshes").size();
  const size_t n_skins = ArrayOrEmpty(ctx.doc.json, "skins").size();
  for (int32_t n = 0; n < static_cast<int32_t>(nodes.size()); ++n) {
    const GltfNode& node = nodes[static_cast<size_t>(n)];
    if (!in_scene[static_cast<size_t>(n)] || node.mesh < 0) continue;
    if (node.mesh >= static_cast<int64_t>(n_meshes))
      return ctx.Invalid(NodeLabel(nodes, n) + " uses a mesh that does not exist");
    if (node.skin >= static_cast<int64_t>(n_skins))
      return ctx.Invalid(NodeLabel(nodes, n) + " uses a skin that does not exist");
    scene->instances.push_back({node.mesh, n});
  }
  std::stable_sort(scene->instances.begin(), scene->instances.end(),
                   [](const GltfMeshInstance& x, const GltfMeshInstance& y) { return x.mesh < y.mesh; });
  scene->skinned_file = std::any_of(scene->instances.begin(), scene->instances.end(), [&](const GltfMeshInstance& m) {
    return nodes[static_cast<size_t>(m.node)].skin >= 0;
  });
  return std::nullopt;
}

// The nodes the skeleton needs: skin joints (skin_joints[s], node indices, for each used skin),
// plus every rigid mesh's own node in a skinned file, plus all their ancestors.
struct SkeletonNodes {
  std::vector<char> needed;
  std::vector<std::vector<int32_t>> skin_joints;
  std::vector<char> skin_used;
};

std::optional<Error> FindSkeletonNodes(const GltfReadContext& ctx, const GltfScene& scene, SkeletonNodes* out) {
  const std::vector<GltfNode>& nodes = scene.nodes;
  const int32_t n_nodes = static_cast<int32_t>(nodes.size());
  const json& skins = ArrayOrEmpty(ctx.doc.json, "skins");
  out->needed.assign(nodes.size(), 0);
  out->skin_joints.assign(skins.size(), {});
  out->skin_used.assign(skins.size(), 0);
  std::vector<int64_t> in_skin(nodes.size(), -1);  // the last skin listing each node
  for (const GltfMeshInstance& m : scene.instances) {
    const int64_t s = nodes[static_cast<size_t>(m.node)].skin;
    if (s >= 0)
      out->skin_used[static_cast<size_t>(s)] = 1;
    else if (scene.skinned_file)
      out->needed[static_cast<size_t>(m.node)] = 1;
  }
  for (size_t s = 0; s < skins.size(); ++s) {
    if (!out->skin_used[s]) continue;
    // glTF 2.0 §3.7.3 (skin.schema.json): joints are unique node indices.
    for (const auto& jj : ArrayOrEmpty(skins[s], "joints")) {
      const int64_t joint = Integer(jj, "joints");
      if (joint < 0 || joint >= n_nodes)
        return ctx.Invalid("skin " + std::to_string(s) + " lists joint node " + std::to_string(joint) +
                           ", which does not exist");
      if (in_skin[static_cast<size_t>(joint)] == static_cast<int64_t>(s)) {
        return ctx.Invalid("skin " + std::to_string(s) + " lists joint node " + std::to_string(joint) +
                           " twice (glTF skin joints are unique)");
      }
      in_skin[static_cast<size_t>(joint)] = static_cast<int64_t>(s);
      out->skin_joints[s].push_back(static_cast<int32_t>(joint));
      out->needed[static_cast<size_t>(joint)] = 1;
    }
    if (out->skin_joints[s].empty()) return ctx.Invalid("skin " + std::to_string(s) + " has no joints");
  }
  for (int32_t n = 0; n < n_nodes; ++n) {
    if (!out->needed[static_cast<size_t>(n)]) continue;
    for (int32_t p = nodes[static_cast<size_t>(n)].parent; p >= 0 && !out->needed[static_cast<size_t>(p)];
         p = nodes[static_cast<size_t>(p)].parent) {
      out->needed[static_cast<size_t>(p)] = 1;
    }
  }
  return std::nullopt;
}

// The skeleton in preorder (parents first), joint_of_node, and the rest world transforms of the
// joints and of every node.
std::optional<Error> BuildSkeleton(const GltfReadContext& ctx, const std::vector<char>& needed, GltfScene* scene,
                                   RawCharacter* c) {
  const std::vector<GltfNode>& nodes = scene->nodes;
  const uint64_t joint_count = static_cast<uint64_t>(std::count(needed.begin(), needed.end(), 1));
  if (joint_count > kMaxJoints) {
    return ctx.Invalid("the skeleton has " + std::to_string(joint_count) +
                       " joints (nodes on the paths to the skins' joints); at most " + std::to_string(kMaxJoints) +
                       " are read");
  }
  scene->joint_of_node.assign(nodes.size(), -1);
  if (scene->skinned_file) {
    for (int32_t n : scene->preorder) {
      if (!needed[static_cast<size_t>(n)]) continue;
      const GltfNode& node = nodes[static_cast<size_t>(n)];
      scene->joint_of_node[static_cast<size_t>(n)] = static_cast<int32_t>(c->skeleton.size());
      c->skeleton.joint_names.push_back(node.name.empty() ? "node_" + std::to_string(n) : node.name);
      c->skeleton.parents.push_back(node.parent >= 0 ? scene->joint_of_node[static_cast<size_t>(node.parent)] : -1);
      c->skeleton.rest_local.push_back(node.local);
    }
  } else {
    // Static character: one identity joint, every mesh baked at its node's world transform.
    c->skeleton.joint_names.push_back("root");
    c->skeleton.parents.push_back(-1);
    c->skeleton.rest_local.push_back(Transform{});
  }
  scene->joint_world.resize(c->skeleton.size());
  c->skeleton.RestWorld(scene->joint_world);
  // World transform of any node, from the node tree (for rigid meshes of a static file).
  scene->node_world.resize(nodes.size());
  for (int32_t n : scene->preorder) {
    const GltfNode& node = nodes[static_cast<size_t>(n)];
    const Mat4f local = node.local.ToMatrix();
    scene->node_world[static_cast<size_t>(n)] =
        node.parent >= 0 ? Mat4f(scene->node_world[static_cast<size_t>(node.parent)] * local) : local;
  }
  return std::nullopt;
}

// Bind entries of the used skins: scene->skin_bind[s][k] for the skin's k-th joint.
std::optional<Error> ReadSkinBinds(const GltfReadContext& ctx, const SkeletonNodes& skeleton, GltfScene* scene,
                                   RawCharacter* c) {
  const json& skins = ArrayOrEmpty(ctx.doc.json, "skins");
  scene->skin_bind.assign(skins.size(), {});
  for (size_t s = 0; s < skins.size(); ++s) {
    if (!skeleton.skin_used[s]) continue;
    const size_t n_joints = skeleton.skin_joints[s].size();
    std::vector<float> ibm;
    if (skins[s].contains("inverseBindMatrices")) {
      if (std::string p = ReadAccessorFloats(ctx.doc, Integer(skins[s], "inverseBindMatrices", -1), 16, &ibm);
          !p.empty()) {
        return ctx.Rejected("skin " + std::to_string(s) + ": " + p);
      }
      if (ibm.size() < 16 * n_joints)
        return ctx.Invalid("skin " + std::to_string(s) + " has fewer inverse bind matrices than joints");
    }
    for (size_t k = 0; k < n_joints; ++k) {
      Mat4f m = Mat4f::Identity();
      if (!ibm.empty()) m = Eigen::Map<const Mat4f>(ibm.data() + 16 * k);  // column-major, as Eigen
      if (!m.allFinite()) return ctx.Invalid("skin " + std::to_string(s) + " has a non-finite inverse bind matrix");
      const int32_t joint = scene->joint_of_node[static_cast<size_t>(skeleton.skin_joints[s][k])];
      const int32_t b = FindOrAddBind(c->skin, joint, m);
      if (b < 0) return ctx.Invalid("more than 65536 distinct bind entries");
      scene->skin_bind[s].push_back(b);
    }
  }
  return std::nullopt;
}

}  // namespace

std::optional<Error> ReadSceneAndSkeleton(const GltfReadContext& ctx, GltfScene* scene, RawCharacter* c) {
  std::vector<int32_t> scene_roots;
  if (auto e = ReadSceneRoots(ctx, scene->nodes, &scene_roots)) return e;
  scene->preorder = PreorderNodes(scene->nodes, scene_roots);
  if (auto e = ReadMeshInstances(ctx, scene_roots, scene)) return e;
  SkeletonNodes skeleton;
  if (auto e = FindSkeletonNodes(ctx, *scene, &skeleton)) return e;
  if (auto e = BuildSkeleton(ctx, skeleton.needed, scene, c)) return e;
  return ReadSkinBinds(ctx, skeleton, scene, c);
}

}  // namespace skinspheres::lib::detail
