// ExportGlb (glb_exporter.h): builds an aiScene by hand from a RawCharacter and hands it to
// Assimp's "glb2" exporter. Ownership: the aiScene owns every array below (allocated with new[]
// as Assimp's destructors expect); the unique_ptr frees the whole tree after the export.
// This file builds the node tree and the scene and exports it; the input checks, the meshes and
// the animations are stages of their own (glb_export_stages.h).
#include "skinspheres/lib/io/glb_exporter.h"

#include <assimp/scene.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <assimp/Exporter.hpp>
#include <cstdint>
#include <cstring>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "glb_export_stages.h"
#include "skinspheres/runtime/format/file_io.h"

namespace skinspheres::lib {
namespace detail {

aiMatrix4x4 ToAi(const Mat4f& m) {
  return aiMatrix4x4(m(0, 0), m(0, 1), m(0, 2), m(0, 3), m(1, 0), m(1, 1), m(1, 2), m(1, 3), m(2, 0), m(2, 1), m(2, 2),
                     m(2, 3), m(3, 0), m(3, 1), m(3, 2), m(3, 3));
}

aiVector3D ToAi(const Eigen::Vector3f& v) { return aiVector3D(v.x(), v.y(), v.z()); }
aiQuaternion ToAi(const Quatf& q) { return aiQuaternion(q.w(), q.x(), q.y(), q.z()); }

}  // namespace detail

namespace {

using detail::ToAi;

void AttachChildren(aiNode* parent, const std::vector<aiNode*>& children) {
  if (children.empty()) return;
  parent->mNumChildren = static_cast<unsigned>(children.size());
  parent->mChildren = new aiNode*[children.size()];
  for (size_t i = 0; i < children.size(); ++i) {
    parent->mChildren[i] = children[i];
    children[i]->mParent = parent;
  }
}

// Node names: Assimp's writer binds bones and channels by name, so every joint gets a unique,
// non-empty one (a repeated name, which glTF allows, gets "_2", "_3", ...).
std::vector<std::string> UniqueJointNames(const skinning::Skeleton& sk) {
  std::vector<std::string> joint_names(sk.size());
  std::set<std::string> taken(sk.joint_names.begin(), sk.joint_names.end()), given;
  for (size_t j = 0; j < sk.size(); ++j) {
    const std::string base = sk.joint_names[j].empty() ? "joint_" + std::to_string(j) : sk.joint_names[j];
    std::string n = base;
    for (int k = 2; given.count(n) || (n != sk.joint_names[j] && taken.count(n)); ++k)
      n = base + "_" + std::to_string(k);
    given.insert(n);
    joint_names[j] = n;
  }
  return joint_names;
}

// The node tree from the skeleton, before its children are attached: one node per joint, and the
// scene root (the single root joint when its world transform is the identity and no clip moves
// it, else a node "Root"), under which mesh and sphere nodes hang.
struct NodeTree {
  std::vector<aiNode*> joint_nodes;
  std::vector<std::vector<aiNode*>> children;  // per joint
  aiNode* root = nullptr;
  std::vector<aiNode*> root_children;
  bool joint_is_root = false;
  std::set<std::string> used;  // node names given so far

  // `base` (or "mesh" when empty), made unique among the node names with "_1", "_2", ...
  std::string UniqueName(std::string base) {
    if (base.empty()) base = "mesh";
    std::string n = base;
    for (int k = 1; used.count(n); ++k) n = base + "_" + std::to_string(k);
    used.insert(n);
    return n;
  }

  // Every node under its parent, the root as the scene's.
  void Attach(aiScene* scene) {
    for (size_t j = 0; j < joint_nodes.size(); ++j) {
      if (!(joint_is_root && j == 0)) AttachChildren(joint_nodes[j], children[j]);
    }
    AttachChildren(root, root_children);
    scene->mRootNode = root;
  }
};

NodeTree MakeNodeTree(const RawCharacter& c, const std::vector<Mat4f>& rest_world,
                      const std::vector<std::string>& joint_names) {
  const auto& sk = c.skeleton;
  NodeTree tree;
  tree.joint_nodes.resize(sk.size());
  tree.children.resize(sk.size());
  std::vector<aiNode*> roots;
  for (size_t j = 0; j < sk.size(); ++j) {
    tree.joint_nodes[j] = new aiNode(joint_names[j]);
    tree.joint_nodes[j]->mTransformation = ToAi(sk.rest_local[j].ToMatrix());
  }
  for (size_t j = 0; j < sk.size(); ++j) {
    if (sk.parents[j] < 0) {
      roots.push_back(tree.joint_nodes[j]);
    } else {
      tree.children[sk.parents[j]].push_back(tree.joint_nodes[j]);
    }
  }
  bool root_animated = false;
  for (const auto& clip : c.clips) {
    for (const auto& tr : clip.tracks) root_animated |= (tr.joint == 0);
  }
  // Mesh and sphere nodes hang under the scene root, whose world transform must be the identity.
  tree.joint_is_root = roots.size() == 1 && sk.parents[0] < 0 && rest_world[0].isIdentity(1e-6f) && !root_animated;
  tree.root = tree.joint_is_root ? tree.joint_nodes[0] : new aiNode("Root");
  tree.root_children = tree.joint_is_root ? tree.children[0] : roots;
  tree.used.insert(joint_names.begin(), joint_names.end());
  if (!tree.joint_is_root) tree.used.insert("Root");
  return tree;
}

// One mesh and node per MeshRange: a skinned mesh's node under the scene root, a rigid one's
// under its joint (or the root).
void AddMeshes(const RawCharacter& c, const std::vector<Mat4f>& rest_world, const std::vector<std::string>& joint_names,
               NodeTree* tree, std::vector<aiMesh*>* meshes, GlbExportSummary* summary) {
  bool first_skinned = true;
  for (const MeshRange& range : c.meshes) {
    const std::string node_name = tree->UniqueName(range.name);
    summary->mesh_node_names.push_back(node_name);
    meshes->push_back(detail::MakeRangeMesh(c, range, node_name, joint_names, rest_world, first_skinned));
    if (range.skinned) first_skinned = false;
    auto* node = new aiNode(node_name);
    node->mNumMeshes = 1;
    node->mMeshes = new unsigned int[1]{static_cast<unsigned>(meshes->size() - 1)};
    if (range.skinned || range.rigid_joint < 0) {
      tree->root_children.push_back(node);
    } else {
      tree->children[range.rigid_joint].push_back(node);
    }
  }
}

// The sphere meshes (one shared unit sphere) and their nodes, at their first frame; the nodes' names.
std::vector<std::string> AddSphereNodes(const GlbExtras& extras, NodeTree* tree, std::vector<aiMesh*>* meshes) {
  std::vector<std::string> sphere_nodes;
  if (extras.spheres.empty()) return sphere_nodes;
  meshes->push_back(detail::UnitSphereMesh(extras.sphere_segments, extras.sphere_rings));
  const unsigned sphere_mesh = static_cast<unsigned>(meshes->size() - 1);
  for (size_t i = 0; i < extras.spheres.size(); ++i) {
    const std::string name = tree->UniqueName("sphere_" + std::to_string(i));
    sphere_nodes.push_back(name);
    auto* node = new aiNode(name);
    const Vec4f& f = extras.spheres[i].per_frame_xyzr.front();
    node->mTransformation = aiMatrix4x4(f.w(), 0, 0, f.x(), 0, f.w(), 0, f.y(), 0, 0, f.w(), f.z(), 0, 0, 0, 1);
    node->mNumMeshes = 1;
    node->mMeshes = new unsigned int[1]{sphere_mesh};
    tree->root_children.push_back(node);
  }
  return sphere_nodes;
}

// The meshes and the one default material into the scene.
void SetMeshesAndMaterial(const std::vector<aiMesh*>& meshes, aiScene* scene) {
  scene->mNumMeshes = static_cast<unsigned>(meshes.size());
  if (!meshes.empty()) {
    scene->mMeshes = new aiMesh*[meshes.size()];
    std::copy(meshes.begin(), meshes.end(), scene->mMeshes);
  }
  scene->mNumMaterials = 1;
  scene->mMaterials = new aiMaterial*[1];
  scene->mMaterials[0] = new aiMaterial();
  const aiString material_name(std::string("default"));
  scene->mMaterials[0]->AddProperty(&material_name, AI_MATKEY_NAME);
}

struct BuiltScene {
  std::unique_ptr<aiScene> scene;
  GlbExportSummary summary;
};

// The whole aiScene for `c` (see glb_exporter.h for what it holds); `path` only names errors.
Result<BuiltScene> BuildScene(const RawCharacter& c, const std::filesystem::path& path, const GlbExtras& extras) {
  if (auto err = detail::ValidateForExport(c, extras, path)) return *err;
  const auto& sk = c.skeleton;
  std::vector<Mat4f> rest_world(sk.size());
  sk.RestWorld(rest_world);

  auto scene = std::make_unique<aiScene>();
  GlbExportSummary summary;
  const std::vector<std::string> joint_names = UniqueJointNames(sk);
  NodeTree tree = MakeNodeTree(c, rest_world, joint_names);
  std::vector<aiMesh*> meshes;
  AddMeshes(c, rest_world, joint_names, &tree, &meshes, &summary);
  const std::vector<std::string> sphere_nodes = AddSphereNodes(extras, &tree, &meshes);
  tree.Attach(scene.get());
  SetMeshesAndMaterial(meshes, scene.get());

  std::vector<aiAnimation*> anims = detail::MakeClipAnimations(c, joint_names);
  detail::AddSphereAnimation(extras, sphere_nodes, &anims);
  if (!anims.empty()) {
    scene->mNumAnimations = static_cast<unsigned>(anims.size());
    scene->mAnimations = new aiAnimation*[anims.size()];
    std::copy(anims.begin(), anims.end(), scene->mAnimations);
  }

  summary.mesh_count = static_cast<uint32_t>(meshes.size());
  summary.animation_count = static_cast<uint32_t>(anims.size());
  summary.node_count =
      static_cast<uint32_t>(sk.size() + c.meshes.size() + extras.spheres.size() + (tree.joint_is_root ? 0 : 1));
  return BuiltScene{std::move(scene), summary};
}

// Assimp's glb2 writer leaves gaps in the binary chunk that no buffer view covers (35 KB of a
// 557 KB file for the built-in character with two clips), holding whatever its heap held: zeroed
// here, so a file carries no stray memory and the same character gives the same bytes. A blob that
// is not a GLB with a JSON and a BIN chunk is left as it is.
void ZeroUnviewedBytes(std::vector<uint8_t>& glb) {
  auto u32 = [&](size_t at) {
    uint32_t v;
    std::memcpy(&v, glb.data() + at, sizeof v);
    return size_t{v};
  };
  if (glb.size() < 28 || std::memcmp(glb.data(), "glTF", 4) != 0 || u32(16) != 0x4E4F534Au) return;  // "JSON"
  const size_t json_length = u32(12), bin_header = 20 + json_length;
  if (bin_header + 8 > glb.size() || u32(bin_header + 4) != 0x004E4942u) return;  // "BIN\0"
  const size_t bin_length = std::min(u32(bin_header), glb.size() - bin_header - 8);
  const auto doc = nlohmann::json::parse(glb.begin() + 20, glb.begin() + static_cast<std::ptrdiff_t>(bin_header),
                                         nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded() || !doc.is_object()) return;
  std::vector<std::pair<size_t, size_t>> viewed;  // [begin, end) of the BIN chunk, buffer 0
  const auto views = doc.find("bufferViews");
  if (views == doc.end() || !views->is_array()) return;
  for (const auto& v : *views) {
    if (!v.is_object() || v.value("buffer", 0) != 0) continue;
    const size_t begin = v.value("byteOffset", size_t{0}), length = v.value("byteLength", size_t{0});
    viewed.emplace_back(std::min(begin, bin_length), std::min(begin + std::min(length, bin_length), bin_length));
  }
  std::sort(viewed.begin(), viewed.end());
  uint8_t* bin = glb.data() + bin_header + 8;
  size_t covered = 0;
  for (const auto& [begin, end] : viewed) {
    if (begin > covered) std::fill(bin + covered, bin + begin, uint8_t{0});
    covered = std::max(covered, end);
  }
  std::fill(bin + covered, bin + bin_length, uint8_t{0});
}

Result<GlbExportSummary> Export(const RawCharacter& c, const std::filesystem::path& path, const GlbExtras& extras,
                                const char* format) {
  auto built = BuildScene(c, path, extras);
  if (!built.ok()) return built.error();
  // Exported to memory, then written and checked through the close (runtime/file_io.h): Assimp's
  // own file writer does not check its close, so a full disk went unnoticed.
  Assimp::Exporter exporter;
  const aiExportDataBlob* blob = exporter.ExportToBlob(built->scene.get(), format);
  if (blob == nullptr || blob->data == nullptr) {
    return MakeError(ErrorCode::kFileUnreadable,
                     "ExportGlb " + path.string() + ": Assimp could not write the file: " + exporter.GetErrorString());
  }
  if (blob->next != nullptr) {
    return MakeError(ErrorCode::kFileUnreadable, "ExportGlb " + path.string() + ": Assimp made more than one file");
  }
  const auto* data = static_cast<const uint8_t*>(blob->data);
  std::vector<uint8_t> bytes(data, data + blob->size);
  if (std::string_view(format) == "glb2") ZeroUnviewedBytes(bytes);
  if (auto err =
          runtime::WriteWholeFile(path, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()))) {
    return *err;
  }
  return built->summary;
}

}  // namespace

Result<GlbExportSummary> ExportGlb(const RawCharacter& c, const std::filesystem::path& path, const GlbExtras& extras) {
  return Export(c, path, extras, "glb2");
}

Result<GlbExportSummary> ExportFbxAscii(const RawCharacter& c, const std::filesystem::path& path) {
  return Export(c, path, {}, "fbxa");
}

Result<GlbBlob> ExportGlbToMemory(const RawCharacter& c, const std::string& label, const GlbExtras& extras) {
  auto built = BuildScene(c, label, extras);
  if (!built.ok()) return built.error();
  Assimp::Exporter exporter;
  const aiExportDataBlob* blob = exporter.ExportToBlob(built->scene.get(), "glb2");
  if (blob == nullptr || blob->data == nullptr) {
    return MakeError(ErrorCode::kFileUnreadable,
                     "ExportGlb " + label + ": Assimp could not write the GLB: " + exporter.GetErrorString());
  }
  const auto* data = static_cast<const uint8_t*>(blob->data);
  std::vector<uint8_t> bytes(data, data + blob->size);
  ZeroUnviewedBytes(bytes);
  return GlbBlob{std::move(bytes), std::move(built->summary)};
}

}  // namespace skinspheres::lib
