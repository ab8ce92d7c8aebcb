// Any format Assimp 5.2.5 reads (FBX, COLLADA, OBJ, ...) -> RawCharacter. glTF 2.0 does not come
// here (importer_gltf.cc reads it directly). Only aiProcess_ValidateDataStructure is requested:
// no post-process that welds, reorders or drops vertices or faces. Polygons are fanned into
// triangles in order (n-2 each, degenerate ones kept); point and line faces are not surface and
// are skipped (their vertices stay). Vertex order is Assimp's for these formats (some readers
// split vertices per face corner). Clips: ticks / ticksPerSecond, linear (Assimp has no
// interpolation field).
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <assimp/Importer.hpp>
#include <map>

#include "assimp_nodes.h"
#include "importer_internal.h"

namespace skinspheres::lib::detail {

namespace {

// The scene as the reader goes through it: the node tree (preorder, parents first) with world
// transforms, the mesh instances (mesh order, then node preorder), the skeleton's nodes and the
// node -> joint map.
struct AssimpScene {
  const aiScene& scene;
  const AssimpNodeTree& tree;
  const std::filesystem::path& file;
  std::vector<Mat4f> world;
  std::vector<std::pair<unsigned, int32_t>> instances;
  bool skinned_file = false;
  std::vector<int32_t> joint_of_node;

  Error Invalid(const std::string& problem) const { return ImportError(ErrorCode::kInvalidData, file, problem); }
};

void FindInstances(AssimpScene* s) {
  const std::vector<const aiNode*>& nodes = s->tree.nodes;
  s->world.resize(nodes.size());
  for (size_t i = 0; i < nodes.size(); ++i) {
    const Mat4f l = s->tree.local[i].ToMatrix();
    s->world[i] = s->tree.parent[i] >= 0 ? Mat4f(s->world[static_cast<size_t>(s->tree.parent[i])] * l) : l;
  }
  for (unsigned m = 0; m < s->scene.mNumMeshes; ++m) {
    for (size_t i = 0; i < nodes.size(); ++i) {
      for (unsigned k = 0; k < nodes[i]->mNumMeshes; ++k) {
        if (nodes[i]->mMeshes[k] == m) s->instances.push_back({m, static_cast<int32_t>(i)});
      }
    }
  }
}

// The skeleton: the bones' nodes, every rigid mesh's node in a skinned file, and their ancestors,
// in preorder; one identity joint for a static file.
std::optional<Error> BuildSkeleton(AssimpScene* s, RawCharacter* c) {
  const std::vector<const aiNode*>& nodes = s->tree.nodes;
  const std::vector<int32_t>& parent = s->tree.parent;
  std::vector<char> needed(nodes.size(), 0);
  for (auto [m, n] : s->instances) {
    const aiMesh* mesh = s->scene.mMeshes[m];
    if (!mesh->HasBones()) continue;
    s->skinned_file = true;
    for (unsigned b = 0; b < mesh->mNumBones; ++b) {
      const int32_t bn = s->tree.Find(mesh->mBones[b]->mName);
      if (bn < 0)
        return s->Invalid("bone '" + std::string(mesh->mBones[b]->mName.C_Str()) + "' has no node in the scene");
      needed[static_cast<size_t>(bn)] = 1;
    }
  }
  if (s->skinned_file) {
    for (auto [m, n] : s->instances) {
      if (!s->scene.mMeshes[m]->HasBones()) needed[static_cast<size_t>(n)] = 1;
    }
    for (size_t i = nodes.size(); i-- > 0;) {  // preorder reversed: children before parents
      if (needed[i] && parent[i] >= 0) needed[static_cast<size_t>(parent[i])] = 1;
    }
  }
  const uint64_t joint_count = static_cast<uint64_t>(std::count(needed.begin(), needed.end(), 1));
  if (joint_count > kMaxJoints) {
    return s->Invalid("the skeleton has " + std::to_string(joint_count) + " joints; at most " +
                      std::to_string(kMaxJoints) + " are read");
  }
  s->joint_of_node.assign(nodes.size(), -1);
  if (s->skinned_file) {
    for (size_t i = 0; i < nodes.size(); ++i) {
      if (!needed[i]) continue;
      s->joint_of_node[i] = static_cast<int32_t>(c->skeleton.size());
      c->skeleton.joint_names.emplace_back(nodes[i]->mName.C_Str());
      c->skeleton.parents.push_back(parent[i] >= 0 ? s->joint_of_node[static_cast<size_t>(parent[i])] : -1);
      c->skeleton.rest_local.push_back(s->tree.local[i]);
    }
  } else {
    c->skeleton.joint_names.push_back("root");
    c->skeleton.parents.push_back(-1);
    c->skeleton.rest_local.push_back(skinning::Transform{});
  }
  return std::nullopt;
}

// A skinned mesh's bind entries, and each vertex's influences from the bones' weights.
std::optional<Error> ReadBoneWeights(const AssimpScene& s, const aiMesh& mesh, const std::string& where,
                                     RawCharacter* c, std::vector<std::vector<Influence>>* per_vertex) {
  per_vertex->assign(mesh.mNumVertices, {});
  for (unsigned b = 0; b < mesh.mNumBones; ++b) {
    const aiBone* bone = mesh.mBones[b];
    const Mat4f ibm = ToMat4f(bone->mOffsetMatrix);
    if (!ibm.allFinite())
      return s.Invalid(where + " bone '" + bone->mName.C_Str() + "' has a non-finite offset matrix");
    const int32_t bind = FindOrAddBind(c->skin, s.joint_of_node[static_cast<size_t>(s.tree.Find(bone->mName))], ibm);
    if (bind < 0) return s.Invalid("more than 65536 distinct bind entries");
    for (unsigned w = 0; w < bone->mNumWeights; ++w) {
      const aiVertexWeight& vw = bone->mWeights[w];
      if (vw.mVertexId >= mesh.mNumVertices) {
        return s.Invalid(where + " bone '" + bone->mName.C_Str() + "' weights vertex " + std::to_string(vw.mVertexId) +
                         ", out of range");
      }
      (*per_vertex)[vw.mVertexId].push_back({static_cast<uint32_t>(bind), vw.mWeight});
    }
  }
  return std::nullopt;
}

// A rigid mesh's one bind entry: its node's joint (a skinned file) or the root at identity.
std::optional<Error> RigidBind(const AssimpScene& s, int32_t n, const std::string& where, RawCharacter* c,
                               int32_t* rigid_bind) {
  const Mat4f& rigid_world = s.world[static_cast<size_t>(n)];
  Mat4f ibm = Mat4f::Identity();
  int32_t joint = 0;
  if (s.skinned_file) {
    joint = s.joint_of_node[static_cast<size_t>(n)];
    const float det = rigid_world.topLeftCorner<3, 3>().determinant();
    if (!(std::abs(det) > 0.0f) || !std::isfinite(det)) return s.Invalid(where + " has a singular world transform");
    ibm = rigid_world.inverse();
  }
  *rigid_bind = FindOrAddBind(c->skin, joint, ibm);
  if (*rigid_bind < 0) return s.Invalid("more than 65536 distinct bind entries");
  return std::nullopt;
}

// The mesh's faces fanned into triangles, in order, on vertices from first_vertex on.
std::optional<Error> AppendFaces(const AssimpScene& s, const aiMesh& mesh, const std::string& where,
                                 uint64_t first_vertex, RawCharacter* c) {
  for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
    const aiFace& face = mesh.mFaces[f];
    for (unsigned k = 0; k < face.mNumIndices; ++k) {
      if (face.mIndices[k] >= mesh.mNumVertices)
        return s.Invalid(where + " face " + std::to_string(f) + " has an index out of range");
    }
    for (unsigned k = 1; k + 1 < face.mNumIndices; ++k) {  // fan; faces with < 3 indices add nothing
      c->triangles.emplace_back(static_cast<int>(first_vertex + face.mIndices[0]),
                                static_cast<int>(first_vertex + face.mIndices[k]),
                                static_cast<int>(first_vertex + face.mIndices[k + 1]));
    }
    if (c->triangles.size() > kMaxTriangles) {
      return s.Invalid("more than " + std::to_string(kMaxTriangles) + " triangles (at most that many are read)");
    }
  }
  return std::nullopt;
}

// Mesh instance (m, n): its vertices, influences, triangles and MeshRange. Point and line meshes
// are skipped.
std::optional<Error> ReadMesh(const AssimpScene& s, unsigned m, int32_t n, RawCharacter* c) {
  const aiMesh* mesh = s.scene.mMeshes[m];
  const std::string where = "mesh '" + std::string(mesh->mName.C_Str()) + "'";
  if ((mesh->mPrimitiveTypes & (aiPrimitiveType_TRIANGLE | aiPrimitiveType_POLYGON)) == 0) return std::nullopt;
  const bool skinned = mesh->HasBones();
  const uint64_t first_vertex = c->skin.vertex_count();
  if (first_vertex + mesh->mNumVertices > kMaxVertices) {
    return s.Invalid("more than " + std::to_string(kMaxVertices) + " vertices (at most that many are read)");
  }
  std::vector<std::vector<Influence>> per_vertex(mesh->mNumVertices);
  int32_t rigid_bind = -1;
  const Mat4f& rigid_world = s.world[static_cast<size_t>(n)];
  if (auto e = skinned ? ReadBoneWeights(s, *mesh, where, c, &per_vertex) : RigidBind(s, n, where, c, &rigid_bind))
    return e;
  std::vector<Influence> influences;
  for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
    const aiVector3D& a = mesh->mVertices[v];
    const Eigen::Vector3f p(a.x, a.y, a.z);
    if (!p.allFinite()) return s.Invalid(where + " vertex " + std::to_string(v) + " position is NaN or infinite");
    if (skinned) {
      if (auto e = AppendVertex(c->skin, p, per_vertex[v]))
        return s.Invalid(where + " vertex " + std::to_string(v) + ": " + *e);
    } else {
      influences.assign(1, Influence{static_cast<uint32_t>(rigid_bind), 1.0f});
      if (auto e = AppendVertex(c->skin, (rigid_world * p.homogeneous()).head<3>(), influences))
        return s.Invalid(where + ": " + *e);
    }
  }
  const uint32_t first_triangle = static_cast<uint32_t>(c->triangles.size());
  if (auto e = AppendFaces(s, *mesh, where, first_vertex, c)) return e;
  MeshRange range;
  range.name = mesh->mName.length > 0 ? mesh->mName.C_Str() : "mesh_" + std::to_string(m);
  range.first_vertex = static_cast<uint32_t>(first_vertex);
  range.vertex_count = mesh->mNumVertices;
  range.first_triangle = first_triangle;
  range.triangle_count = static_cast<uint32_t>(c->triangles.size() - first_triangle);
  range.skinned = skinned;
  range.rigid_joint = skinned ? -1 : (s.skinned_file ? s.joint_of_node[static_cast<size_t>(n)] : 0);
  c->meshes.push_back(std::move(range));
  return std::nullopt;
}

// Every animation with channels, tracks on the skeleton's joints (channels on other nodes dropped).
std::optional<Error> ReadClips(const AssimpScene& s, RawCharacter* c) {
  for (unsigned a = 0; a < s.scene.mNumAnimations; ++a) {
    const aiAnimation* anim = s.scene.mAnimations[a];
    if (anim->mNumChannels == 0) continue;  // morph or camera animation only (assimp_nodes.h)
    auto header = ReadClipHeader(*anim, a, s.file);
    if (!header.ok()) return header.error();
    skinning::AnimationClip clip = header->clip;
    for (unsigned ch = 0; ch < anim->mNumChannels; ++ch) {
      const aiNodeAnim* na = anim->mChannels[ch];
      const int32_t n = s.tree.Find(na->mNodeName);
      // Channels on nodes outside the skeleton cannot move the character: dropped.
      if (n < 0 || s.joint_of_node[static_cast<size_t>(n)] < 0) continue;
      skinning::JointTrack track;
      track.joint = s.joint_of_node[static_cast<size_t>(n)];
      if (auto bad = AppendChannelKeys(*na, *header, s.file, &track)) return *bad;
      clip.tracks.push_back(std::move(track));
    }
    std::sort(clip.tracks.begin(), clip.tracks.end(),
              [](const skinning::JointTrack& x, const skinning::JointTrack& y) { return x.joint < y.joint; });
    c->clips.push_back(std::move(clip));
  }
  return std::nullopt;
}

}  // namespace

Result<RawCharacter> ImportWithAssimp(const std::filesystem::path& file, std::span<const uint8_t> /*bytes*/,
                                      const ImportOptions& options) {
  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFile(file.string(), aiProcess_ValidateDataStructure);
  if (scene == nullptr || scene->mRootNode == nullptr || (scene->mFlags & AI_SCENE_FLAGS_INCOMPLETE) != 0) {
    std::string why = importer.GetErrorString();
    if (why.empty()) why = "no scene";
    return ImportError(ErrorCode::kFormatRejected, file, "rejected by Assimp: " + why);
  }
  // Nodes in preorder (parents first), with world transforms.
  auto tree = ReadAssimpNodeTree(*scene, file);
  if (!tree.ok()) return tree.error();
  AssimpScene s{*scene, *tree, file, {}, {}, false, {}};
  FindInstances(&s);
  RawCharacter c;
  if (auto e = BuildSkeleton(&s, &c)) return *e;
  for (auto [m, n] : s.instances) {
    if (auto e = ReadMesh(s, m, n, &c)) return *e;
  }
  if (c.skin.influence_offsets.empty()) c.skin.influence_offsets.push_back(0);
  if (options.read_clips && s.skinned_file) {
    if (auto e = ReadClips(s, &c)) return *e;
  }
  return c;
}

}  // namespace skinspheres::lib::detail
