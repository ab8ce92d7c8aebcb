// ExportGlb (glb_exporter.h): builds an aiScene by hand from a RawCharacter and hands it to
// Assimp's "glb2" exporter. Ownership: the aiScene owns every array below (allocated with new[]
// as Assimp's destructors expect); the unique_ptr frees the whole tree after the export.
#include "skinspheres/lib/io/glb_exporter.h"

#include <assimp/scene.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <assimp/Exporter.hpp>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <numbers>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include "skinspheres/runtime/format/file_io.h"

namespace skinspheres::lib {
namespace {

using Eigen::Vector3f;
using skinning::Interpolation;

aiMatrix4x4 ToAi(const Mat4f& m) {
  return aiMatrix4x4(m(0, 0), m(0, 1), m(0, 2), m(0, 3), m(1, 0), m(1, 1), m(1, 2), m(1, 3), m(2, 0), m(2, 1), m(2, 2),
                     m(2, 3), m(3, 0), m(3, 1), m(3, 2), m(3, 3));
}

Error Invalid(const std::filesystem::path& path, const std::string& what) {
  return MakeError(ErrorCode::kInvalidArgument, "ExportGlb " + path.string() + ": " + what);
}

// Smooth per-vertex normals of one mesh (local vertex indices): the area-weighted sum of the
// face normals around each vertex, vertices at exactly the same position sharing one sum (so a
// UV seam, where a file splits vertices, does not show as a crease). +Y where the sum vanishes.
std::vector<Vector3f> SmoothNormals(const std::vector<Vector3f>& positions, const aiMesh& mesh) {
  struct Hash {
    size_t operator()(const Vector3f& p) const {
      size_t h = 0;
      for (int k = 0; k < 3; ++k) h = h * 1000003u ^ std::hash<float>()(p[k]);
      return h;
    }
  };
  std::unordered_map<Vector3f, uint32_t, Hash> slot_of;
  std::vector<uint32_t> slot(positions.size());
  for (size_t v = 0; v < positions.size(); ++v) {
    slot[v] = slot_of.emplace(positions[v], static_cast<uint32_t>(slot_of.size())).first->second;
  }
  std::vector<Eigen::Vector3d> sum(slot_of.size(), Eigen::Vector3d::Zero());
  for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
    const unsigned* i = mesh.mFaces[f].mIndices;
    const Eigen::Vector3d a = positions[i[0]].cast<double>(), b = positions[i[1]].cast<double>(),
                          c = positions[i[2]].cast<double>();
    const Eigen::Vector3d n = (b - a).cross(c - a);  // |n| = twice the area
    for (int k = 0; k < 3; ++k) sum[slot[i[k]]] += n;
  }
  std::vector<Vector3f> normals(positions.size());
  for (size_t v = 0; v < positions.size(); ++v) {
    const Eigen::Vector3d& n = sum[slot[v]];
    const double len = n.norm();
    normals[v] = len > 0.0 && std::isfinite(len) ? Vector3f((n / len).cast<float>()) : Vector3f::UnitY();
  }
  return normals;
}

void SetNormals(aiMesh* mesh) {
  std::vector<Vector3f> positions(mesh->mNumVertices);
  for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
    positions[v] = Vector3f(mesh->mVertices[v].x, mesh->mVertices[v].y, mesh->mVertices[v].z);
  }
  const std::vector<Vector3f> normals = SmoothNormals(positions, *mesh);
  mesh->mNormals = new aiVector3D[mesh->mNumVertices];
  for (unsigned v = 0; v < mesh->mNumVertices; ++v)
    mesh->mNormals[v] = aiVector3D(normals[v].x(), normals[v].y(), normals[v].z());
}

// ---------------------------------------------------------------------------------------------
// Track baking to LINEAR keys (the only interpolation Assimp's glTF writer emits).

template <typename V>
V CubicValue(const skinning::Track<V>& tr, size_t i, float u) {
  const float dt = tr.times_s[i + 1] - tr.times_s[i];
  const float u2 = u * u, u3 = u2 * u;
  const float h00 = 2 * u3 - 3 * u2 + 1, h10 = u3 - 2 * u2 + u, h01 = -2 * u3 + 3 * u2, h11 = u3 - u2;
  if constexpr (std::is_same_v<V, Quatf>) {
    const Vec4f c = h00 * tr.values[3 * i + 1].coeffs() + h10 * dt * tr.values[3 * i + 2].coeffs() +
                    h01 * tr.values[3 * (i + 1) + 1].coeffs() + h11 * dt * tr.values[3 * (i + 1)].coeffs();
    return Quatf(c.normalized());
  } else {
    return h00 * tr.values[3 * i + 1] + h10 * dt * tr.values[3 * i + 2] + h01 * tr.values[3 * (i + 1) + 1] +
           h11 * dt * tr.values[3 * (i + 1)];
  }
}

template <typename V>
std::vector<std::pair<float, V>> BakeLinear(const skinning::Track<V>& tr) {
  std::vector<std::pair<float, V>> keys;
  const size_t n = tr.times_s.size();
  switch (tr.interpolation) {
    case Interpolation::kLinear:
      for (size_t i = 0; i < n; ++i) keys.emplace_back(tr.times_s[i], tr.values[i]);
      break;
    case Interpolation::kStep:
      for (size_t i = 0; i < n; ++i) {
        keys.emplace_back(tr.times_s[i], tr.values[i]);
        if (i + 1 < n) {
          const float hold = tr.times_s[i + 1] - kStepBakeEpsilon_s;
          if (hold > tr.times_s[i]) keys.emplace_back(hold, tr.values[i]);
        }
      }
      break;
    case Interpolation::kCubicSpline:
      for (size_t i = 0; i < n; ++i) {
        keys.emplace_back(tr.times_s[i], tr.values[3 * i + 1]);
        if (i + 1 < n) {
          for (int s = 1; s < kCubicBakeSubdivisions; ++s) {
            const float u = static_cast<float>(s) / kCubicBakeSubdivisions;
            keys.emplace_back(tr.times_s[i] + u * (tr.times_s[i + 1] - tr.times_s[i]), CubicValue(tr, i, u));
          }
        }
      }
      break;
  }
  return keys;
}

aiVector3D ToAi(const Vector3f& v) { return aiVector3D(v.x(), v.y(), v.z()); }
aiQuaternion ToAi(const Quatf& q) { return aiQuaternion(q.w(), q.x(), q.y(), q.z()); }

template <typename Key, typename V>
Key* MakeKeys(const std::vector<std::pair<float, V>>& keys) {
  Key* out = new Key[keys.size()];
  for (size_t i = 0; i < keys.size(); ++i) {
    out[i].mTime = static_cast<double>(keys[i].first);  // ticks, with mTicksPerSecond = 1
    out[i].mValue = ToAi(keys[i].second);
  }
  return out;
}

aiNodeAnim* MakeChannel(const std::string& node, const std::vector<std::pair<float, Vector3f>>& t,
                        const std::vector<std::pair<float, Quatf>>& r,
                        const std::vector<std::pair<float, Vector3f>>& s) {
  auto* ch = new aiNodeAnim();
  ch->mNodeName = aiString(node);
  ch->mNumPositionKeys = static_cast<unsigned>(t.size());
  ch->mPositionKeys = MakeKeys<aiVectorKey>(t);
  ch->mNumRotationKeys = static_cast<unsigned>(r.size());
  ch->mRotationKeys = MakeKeys<aiQuatKey>(r);
  ch->mNumScalingKeys = static_cast<unsigned>(s.size());
  ch->mScalingKeys = MakeKeys<aiVectorKey>(s);
  return ch;
}

// ---------------------------------------------------------------------------------------------

// Over the function-size limit of .clang-tidy: to be split into one stage per section of the file.
// NOLINTNEXTLINE(readability-function-size)
std::optional<Error> Validate(const RawCharacter& c, const GlbExtras& e, const std::filesystem::path& path) {
  // The rules every stage relies on (skeleton, triangle indices, skin arrays, bind entries).
  if (auto invalid = c.Validate()) return Invalid(path, invalid->message);
  const auto& sk = c.skeleton;
  const auto& s = c.skin;
  const size_t nv = c.positions_rest.size();
  // Beyond them, the GLB needs a skin even without vertices (Validate skips an empty one): one
  // entry per rest position, arrays that agree, bind entries on joints (checked below).
  if (s.positions_bind.size() != nv) return Invalid(path, "skin.positions_bind size differs from positions_rest");
  if (s.influence_offsets.size() != nv + 1 || s.influence_offsets.front() != 0 ||
      s.influence_offsets.back() != s.influence_binds.size() ||
      s.influence_weights.size() != s.influence_binds.size()) {
    return Invalid(path, "skin influence arrays are inconsistent (CSR offsets / binds / weights)");
  }
  for (float w : s.influence_weights) {
    if (w < 0.0f) return Invalid(path, "influence weight is negative");
  }
  std::map<int32_t, Mat4f> ibm;
  for (const auto& b : s.binds) {
    if (b.joint < 0 || static_cast<size_t>(b.joint) >= sk.size()) return Invalid(path, "bind entry joint out of range");
    if (!b.inverse_bind.allFinite()) return Invalid(path, "inverse bind matrix is not finite");
    auto [it, fresh] = ibm.emplace(b.joint, b.inverse_bind);
    if (!fresh && !it->second.isApprox(b.inverse_bind, 1e-5f)) {
      return Invalid(path, "joint '" + sk.joint_names[b.joint] +
                               "' has two bind entries with different inverse bind matrices (one glTF skin "
                               "holds one per joint)");
    }
  }
  for (const auto& p : c.positions_rest) {
    if (!p.allFinite()) return Invalid(path, "a rest position is not finite");
  }
  for (const auto& m : c.meshes) {
    if (uint64_t{m.first_vertex} + m.vertex_count > nv ||
        uint64_t{m.first_triangle} + m.triangle_count > c.triangles.size()) {
      return Invalid(path, "mesh range '" + m.name + "' exceeds the vertex or triangle arrays");
    }
    for (uint32_t t = m.first_triangle; t < m.first_triangle + m.triangle_count; ++t) {
      for (int k = 0; k < 3; ++k) {
        const int64_t i = c.triangles[t][k];
        if (i < m.first_vertex || i >= int64_t{m.first_vertex} + m.vertex_count) {
          return Invalid(path,
                         "triangle " + std::to_string(t) + " of mesh '" + m.name + "' uses a vertex outside the mesh");
        }
      }
    }
    if (!m.skinned && m.rigid_joint >= static_cast<int32_t>(sk.size())) {
      return Invalid(path, "rigid mesh '" + m.name + "' follows a missing joint");
    }
  }
  for (const auto& clip : c.clips) {
    for (const auto& tr : clip.tracks) {
      if (tr.joint < 0 || static_cast<size_t>(tr.joint) >= sk.size()) {
        return Invalid(path, "clip '" + clip.name + "' has a track for a missing joint");
      }
      auto bad = [](const auto& track) {
        const size_t per = track.interpolation == Interpolation::kCubicSpline ? 3 : 1;
        if (track.values.size() != per * track.times_s.size()) return true;
        for (size_t k = 1; k < track.times_s.size(); ++k) {
          if (!(track.times_s[k] > track.times_s[k - 1])) return true;
        }
        return false;
      };
      if (bad(tr.translation) || bad(tr.rotation) || bad(tr.scale)) {
        return Invalid(path, "clip '" + clip.name + "' track of joint '" + sk.joint_names[tr.joint] +
                                 "' has unordered times or a wrong value count");
      }
    }
  }
  if (!e.spheres.empty()) {
    if (e.frame_times_s.empty()) return Invalid(path, "extras: spheres given without frame times");
    for (size_t k = 1; k < e.frame_times_s.size(); ++k) {
      if (!(e.frame_times_s[k] > e.frame_times_s[k - 1])) return Invalid(path, "extras: frame times not increasing");
    }
    for (size_t i = 0; i < e.spheres.size(); ++i) {
      if (e.spheres[i].per_frame_xyzr.size() != e.frame_times_s.size()) {
        return Invalid(path, "extras: sphere " + std::to_string(i) + " has " +
                                 std::to_string(e.spheres[i].per_frame_xyzr.size()) + " frames, expected " +
                                 std::to_string(e.frame_times_s.size()));
      }
      for (const auto& f : e.spheres[i].per_frame_xyzr) {
        if (!f.allFinite() || f.w() < 0.0f)
          return Invalid(path, "extras: sphere " + std::to_string(i) + " has a bad frame");
      }
    }
    if (e.sphere_segments < 3 || e.sphere_rings < 2) return Invalid(path, "extras: sphere resolution too low");
    if (e.clip_name.empty()) return Invalid(path, "extras: empty clip name");
  }
  return std::nullopt;
}

void AttachChildren(aiNode* parent, const std::vector<aiNode*>& children) {
  if (children.empty()) return;
  parent->mNumChildren = static_cast<unsigned>(children.size());
  parent->mChildren = new aiNode*[children.size()];
  for (size_t i = 0; i < children.size(); ++i) {
    parent->mChildren[i] = children[i];
    children[i]->mParent = parent;
  }
}

void SetFaces(aiMesh* mesh, const std::vector<Eigen::Vector3i>& tris, uint32_t first, uint32_t count, uint32_t base) {
  mesh->mNumFaces = count;
  mesh->mFaces = new aiFace[count];
  for (uint32_t t = 0; t < count; ++t) {
    aiFace& f = mesh->mFaces[t];
    f.mNumIndices = 3;
    f.mIndices = new unsigned int[3];
    for (int k = 0; k < 3; ++k) f.mIndices[k] = static_cast<unsigned>(tris[first + t][k]) - base;
  }
}

aiMesh* UnitSphereMesh(int segments, int rings) {
  std::vector<Vector3f> v;
  std::vector<Eigen::Vector3i> tris;
  v.emplace_back(0.0f, -1.0f, 0.0f);
  for (int r = 1; r <= rings; ++r) {
    const float phi = std::numbers::pi_v<float> * static_cast<float>(r) / static_cast<float>(rings + 1);
    for (int k = 0; k < segments; ++k) {
      const float th = 2.0f * std::numbers::pi_v<float> * static_cast<float>(k) / static_cast<float>(segments);
      v.emplace_back(std::sin(phi) * std::cos(th), -std::cos(phi), -std::sin(phi) * std::sin(th));
    }
  }
  v.emplace_back(0.0f, 1.0f, 0.0f);
  const int top = static_cast<int>(v.size()) - 1;
  auto ring = [&](int r, int k) { return 1 + r * segments + (k % segments); };
  for (int k = 0; k < segments; ++k) tris.emplace_back(0, ring(0, k), ring(0, k + 1));
  for (int r = 0; r + 1 < rings; ++r) {
    for (int k = 0; k < segments; ++k) {
      tris.emplace_back(ring(r, k), ring(r + 1, k), ring(r + 1, k + 1));
      tris.emplace_back(ring(r, k), ring(r + 1, k + 1), ring(r, k + 1));
    }
  }
  for (int k = 0; k < segments; ++k) tris.emplace_back(top, ring(rings - 1, k + 1), ring(rings - 1, k));
  // Outward orientation for any convention above: flip if the signed volume is negative.
  double vol = 0;
  for (const auto& t : tris) vol += v[t[0]].cast<double>().dot(v[t[1]].cast<double>().cross(v[t[2]].cast<double>()));
  if (vol < 0) {
    for (auto& t : tris) std::swap(t[1], t[2]);
  }
  auto* mesh = new aiMesh();
  mesh->mName = aiString(std::string("unit_sphere"));
  mesh->mPrimitiveTypes = aiPrimitiveType_TRIANGLE;
  mesh->mMaterialIndex = 0;
  mesh->mNumVertices = static_cast<unsigned>(v.size());
  mesh->mVertices = new aiVector3D[v.size()];
  mesh->mNormals = new aiVector3D[v.size()];
  for (size_t i = 0; i < v.size(); ++i) mesh->mVertices[i] = mesh->mNormals[i] = ToAi(v[i]);  // unit sphere
  SetFaces(mesh, tris, 0, static_cast<uint32_t>(tris.size()), 0);
  return mesh;
}

struct BuiltScene {
  std::unique_ptr<aiScene> scene;
  GlbExportSummary summary;
};

// The whole aiScene for `c` (see glb_exporter.h for what it holds); `path` only names errors.
// Over the function-size limit of .clang-tidy: to be split into one stage per section of the file.
// NOLINTNEXTLINE(readability-function-size)
Result<BuiltScene> BuildScene(const RawCharacter& c, const std::filesystem::path& path, const GlbExtras& extras) {
  if (auto err = Validate(c, extras, path)) return *err;
  const auto& sk = c.skeleton;
  std::vector<Mat4f> rest_world(sk.size());
  sk.RestWorld(rest_world);

  auto scene = std::make_unique<aiScene>();
  GlbExportSummary summary;

  // Node names: Assimp's writer binds bones and channels by name, so every joint gets a unique,
  // non-empty one (a repeated name, which glTF allows, gets "_2", "_3", ...).
  std::vector<std::string> joint_names(sk.size());
  {
    std::set<std::string> taken(sk.joint_names.begin(), sk.joint_names.end()), given;
    for (size_t j = 0; j < sk.size(); ++j) {
      const std::string base = sk.joint_names[j].empty() ? "joint_" + std::to_string(j) : sk.joint_names[j];
      std::string n = base;
      for (int k = 2; given.count(n) || (n != sk.joint_names[j] && taken.count(n)); ++k)
        n = base + "_" + std::to_string(k);
      given.insert(n);
      joint_names[j] = n;
    }
  }

  // ---- node tree from the skeleton
  std::vector<aiNode*> joint_nodes(sk.size());
  std::vector<std::vector<aiNode*>> children(sk.size());
  std::vector<aiNode*> roots;
  for (size_t j = 0; j < sk.size(); ++j) {
    joint_nodes[j] = new aiNode(joint_names[j]);
    joint_nodes[j]->mTransformation = ToAi(sk.rest_local[j].ToMatrix());
  }
  for (size_t j = 0; j < sk.size(); ++j) {
    if (sk.parents[j] < 0) {
      roots.push_back(joint_nodes[j]);
    } else {
      children[sk.parents[j]].push_back(joint_nodes[j]);
    }
  }
  bool root_animated = false;
  for (const auto& clip : c.clips) {
    for (const auto& tr : clip.tracks) root_animated |= (tr.joint == 0);
  }
  // Mesh and sphere nodes hang under the scene root, whose world transform must be the identity.
  const bool joint_is_root =
      roots.size() == 1 && sk.parents[0] < 0 && rest_world[0].isIdentity(1e-6f) && !root_animated;
  aiNode* root = joint_is_root ? joint_nodes[0] : new aiNode("Root");
  std::vector<aiNode*> root_children = joint_is_root ? children[0] : roots;
  std::set<std::string> used(joint_names.begin(), joint_names.end());
  if (!joint_is_root) used.insert("Root");
  auto unique_name = [&](std::string base) {
    if (base.empty()) base = "mesh";
    std::string n = base;
    for (int k = 1; used.count(n); ++k) n = base + "_" + std::to_string(k);
    used.insert(n);
    return n;
  };

  // ---- meshes
  std::vector<aiMesh*> meshes;
  bool first_skinned = true;
  for (const MeshRange& range : c.meshes) {
    auto* mesh = new aiMesh();
    meshes.push_back(mesh);
    const unsigned mesh_index = static_cast<unsigned>(meshes.size() - 1);
    const std::string node_name = unique_name(range.name);
    summary.mesh_node_names.push_back(node_name);
    mesh->mName = aiString(node_name);
    mesh->mPrimitiveTypes = aiPrimitiveType_TRIANGLE;
    mesh->mMaterialIndex = 0;
    mesh->mNumVertices = range.vertex_count;
    mesh->mVertices = new aiVector3D[range.vertex_count];
    SetFaces(mesh, c.triangles, range.first_triangle, range.triangle_count, range.first_vertex);
    auto* node = new aiNode(node_name);
    node->mNumMeshes = 1;
    node->mMeshes = new unsigned int[1]{mesh_index};
    if (range.skinned) {
      for (uint32_t v = 0; v < range.vertex_count; ++v)
        mesh->mVertices[v] = ToAi(c.skin.positions_bind[range.first_vertex + v]);
      // Per vertex: merge entries of the same joint, keep the 4 largest, renormalise.
      std::map<int32_t, std::vector<aiVertexWeight>> per_joint;
      std::vector<std::pair<float, int32_t>> inf;
      for (uint32_t v = 0; v < range.vertex_count; ++v) {
        const uint32_t gv = range.first_vertex + v;
        inf.clear();
        for (uint32_t k = c.skin.influence_offsets[gv]; k < c.skin.influence_offsets[gv + 1]; ++k) {
          const int32_t joint = c.skin.binds[c.skin.influence_binds[k]].joint;
          auto it = std::find_if(inf.begin(), inf.end(), [&](const auto& p) { return p.second == joint; });
          if (it != inf.end()) {
            it->first += c.skin.influence_weights[k];
          } else {
            inf.emplace_back(c.skin.influence_weights[k], joint);
          }
        }
        std::stable_sort(inf.begin(), inf.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
        if (inf.size() > 4) inf.resize(4);
        float sum = 0;
        for (const auto& p : inf) sum += p.first;
        for (const auto& p : inf) {
          if (p.first > 0.0f && sum > 0.0f) per_joint[p.second].push_back(aiVertexWeight(v, p.first / sum));
        }
      }
      // Bones in bind-entry order (the glTF skin's joint order follows first appearance). The
      // first skinned mesh also carries weightless bones for every other bind entry, so every
      // joint the skin binds (even one no vertex uses, like a *_End joint) stays a skin joint.
      std::vector<int32_t> order;
      for (const auto& b : c.skin.binds) {
        if ((per_joint.count(b.joint) || first_skinned) &&
            std::find(order.begin(), order.end(), b.joint) == order.end()) {
          order.push_back(b.joint);
        }
      }
      first_skinned = false;
      if (!order.empty()) {
        mesh->mNumBones = static_cast<unsigned>(order.size());
        mesh->mBones = new aiBone*[order.size()];
        for (size_t i = 0; i < order.size(); ++i) {
          const int32_t joint = order[i];
          auto* bone = new aiBone();
          bone->mName = aiString(joint_names[joint]);
          const auto ibm =
              std::find_if(c.skin.binds.begin(), c.skin.binds.end(), [&](const auto& b) { return b.joint == joint; });
          bone->mOffsetMatrix = ToAi(ibm->inverse_bind);
          const auto& w = per_joint[joint];
          bone->mNumWeights = static_cast<unsigned>(w.size());
          if (!w.empty()) {
            bone->mWeights = new aiVertexWeight[w.size()];
            std::copy(w.begin(), w.end(), bone->mWeights);
          }
          mesh->mBones[i] = bone;
        }
      }
      SetNormals(mesh);
      root_children.push_back(node);
    } else {
      // Rigid: vertices in the followed joint's rest space, node under that joint.
      const Mat4f to_local =
          range.rigid_joint >= 0 ? Mat4f(rest_world[range.rigid_joint].inverse()) : Mat4f(Mat4f::Identity());
      for (uint32_t v = 0; v < range.vertex_count; ++v) {
        const Vec4f p = to_local * c.positions_rest[range.first_vertex + v].homogeneous();
        mesh->mVertices[v] = ToAi(Vector3f(p.head<3>()));
      }
      SetNormals(mesh);
      if (range.rigid_joint >= 0) {
        children[range.rigid_joint].push_back(node);
      } else {
        root_children.push_back(node);
      }
    }
  }

  // ---- sphere meshes (one shared unit sphere) and their nodes
  std::vector<std::string> sphere_nodes;
  if (!extras.spheres.empty()) {
    meshes.push_back(UnitSphereMesh(extras.sphere_segments, extras.sphere_rings));
    const unsigned sphere_mesh = static_cast<unsigned>(meshes.size() - 1);
    for (size_t i = 0; i < extras.spheres.size(); ++i) {
      const std::string name = unique_name("sphere_" + std::to_string(i));
      sphere_nodes.push_back(name);
      auto* node = new aiNode(name);
      const Vec4f& f = extras.spheres[i].per_frame_xyzr.front();
      node->mTransformation = aiMatrix4x4(f.w(), 0, 0, f.x(), 0, f.w(), 0, f.y(), 0, 0, f.w(), f.z(), 0, 0, 0, 1);
      node->mNumMeshes = 1;
      node->mMeshes = new unsigned int[1]{sphere_mesh};
      root_children.push_back(node);
    }
  }

  for (size_t j = 0; j < sk.size(); ++j) {
    if (!(joint_is_root && j == 0)) AttachChildren(joint_nodes[j], children[j]);
  }
  AttachChildren(root, root_children);
  scene->mRootNode = root;

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

  // ---- animations
  std::vector<aiAnimation*> anims;
  for (const auto& clip : c.clips) {
    // Later tracks of the same joint override earlier ones channel by channel.
    std::map<int32_t, skinning::JointTrack> by_joint;
    for (const auto& tr : clip.tracks) {
      auto& dst = by_joint[tr.joint];
      dst.joint = tr.joint;
      if (!tr.translation.empty()) dst.translation = tr.translation;
      if (!tr.rotation.empty()) dst.rotation = tr.rotation;
      if (!tr.scale.empty()) dst.scale = tr.scale;
    }
    std::vector<aiNodeAnim*> channels;
    for (const auto& [joint, tr] : by_joint) {
      if (tr.translation.empty() && tr.rotation.empty() && tr.scale.empty()) continue;
      const auto& rest = sk.rest_local[joint];
      auto t = tr.translation.empty() ? std::vector<std::pair<float, Vector3f>>{{0.0f, rest.translation}}
                                      : BakeLinear(tr.translation);
      auto r =
          tr.rotation.empty() ? std::vector<std::pair<float, Quatf>>{{0.0f, rest.rotation}} : BakeLinear(tr.rotation);
      auto s = tr.scale.empty() ? std::vector<std::pair<float, Vector3f>>{{0.0f, rest.scale}} : BakeLinear(tr.scale);
      channels.push_back(MakeChannel(joint_names[joint], t, r, s));
    }
    auto* anim = new aiAnimation();
    anim->mName = aiString(clip.name);
    anim->mTicksPerSecond = 1.0;
    anim->mDuration = clip.duration_s;
    anim->mNumChannels = static_cast<unsigned>(channels.size());
    anim->mChannels = new aiNodeAnim*[std::max<size_t>(channels.size(), 1)];
    std::copy(channels.begin(), channels.end(), anim->mChannels);
    anims.push_back(anim);
  }
  if (!extras.spheres.empty()) {
    std::vector<aiNodeAnim*> channels;
    // The character's clip of that name, if any, also moves the spheres.
    aiAnimation* host = nullptr;
    for (aiAnimation* a : anims) {
      if (!host && extras.clip_name == a->mName.C_Str()) host = a;
    }
    for (size_t i = 0; i < extras.spheres.size(); ++i) {
      std::vector<std::pair<float, Vector3f>> t, s;
      for (size_t f = 0; f < extras.frame_times_s.size(); ++f) {
        const Vec4f& xyzr = extras.spheres[i].per_frame_xyzr[f];
        t.emplace_back(extras.frame_times_s[f], xyzr.head<3>());
        s.emplace_back(extras.frame_times_s[f], Vector3f::Constant(xyzr.w()));
      }
      channels.push_back(MakeChannel(sphere_nodes[i], t, {{extras.frame_times_s.front(), Quatf::Identity()}}, s));
    }
    if (host != nullptr) {
      auto** merged = new aiNodeAnim*[host->mNumChannels + channels.size()];
      std::copy(host->mChannels, host->mChannels + host->mNumChannels, merged);
      std::copy(channels.begin(), channels.end(), merged + host->mNumChannels);
      delete[] host->mChannels;
      host->mChannels = merged;
      host->mNumChannels += static_cast<unsigned>(channels.size());
      host->mDuration = std::max<double>(host->mDuration, extras.frame_times_s.back());
    } else {
      auto* anim = new aiAnimation();
      anim->mName = aiString(extras.clip_name);
      anim->mTicksPerSecond = 1.0;
      anim->mDuration = extras.frame_times_s.back();
      anim->mNumChannels = static_cast<unsigned>(channels.size());
      anim->mChannels = new aiNodeAnim*[channels.size()];
      std::copy(channels.begin(), channels.end(), anim->mChannels);
      anims.push_back(anim);
    }
  }
  if (!anims.empty()) {
    scene->mNumAnimations = static_cast<unsigned>(anims.size());
    scene->mAnimations = new aiAnimation*[anims.size()];
    std::copy(anims.begin(), anims.end(), scene->mAnimations);
  }

  summary.mesh_count = static_cast<uint32_t>(meshes.size());
  summary.animation_count = static_cast<uint32_t>(anims.size());
  summary.node_count =
      static_cast<uint32_t>(sk.size() + c.meshes.size() + extras.spheres.size() + (joint_is_root ? 0 : 1));
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
