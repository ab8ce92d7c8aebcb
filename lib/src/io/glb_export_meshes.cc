// The GLB exporter's meshes (glb_export_stages.h): one aiMesh per MeshRange, skinned (bind-space
// vertices, at most 4 weights per vertex as bones) or rigid (the followed joint's rest space),
// with smooth normals; and the unit sphere the extras' sphere nodes share.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <unordered_map>
#include <utility>

#include "glb_export_stages.h"

namespace skinspheres::lib::detail {
namespace {

using Eigen::Vector3f;

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

// Per vertex of a skinned range: the entries of the same joint merged, the 4 largest kept,
// renormalised; as the weights of each joint.
std::map<int32_t, std::vector<aiVertexWeight>> WeightsPerJoint(const RawCharacter& c, const MeshRange& range) {
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
  return per_joint;
}

// A skinned range's vertices (bind space) and bones.
void SetSkinnedVertices(const RawCharacter& c, const MeshRange& range, const std::vector<std::string>& joint_names,
                        bool all_binds, aiMesh* mesh) {
  for (uint32_t v = 0; v < range.vertex_count; ++v)
    mesh->mVertices[v] = ToAi(c.skin.positions_bind[range.first_vertex + v]);
  std::map<int32_t, std::vector<aiVertexWeight>> per_joint = WeightsPerJoint(c, range);
  // Bones in bind-entry order (the glTF skin's joint order follows first appearance). The
  // first skinned mesh also carries weightless bones for every other bind entry, so every
  // joint the skin binds (even one no vertex uses, like a *_End joint) stays a skin joint.
  std::vector<int32_t> order;
  for (const auto& b : c.skin.binds) {
    if ((per_joint.count(b.joint) || all_binds) && std::find(order.begin(), order.end(), b.joint) == order.end()) {
      order.push_back(b.joint);
    }
  }
  if (order.empty()) return;
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

// A rigid range's vertices, in the followed joint's rest space.
void SetRigidVertices(const RawCharacter& c, const MeshRange& range, const std::vector<Mat4f>& rest_world,
                      aiMesh* mesh) {
  const Mat4f to_local =
      range.rigid_joint >= 0 ? Mat4f(rest_world[range.rigid_joint].inverse()) : Mat4f(Mat4f::Identity());
  for (uint32_t v = 0; v < range.vertex_count; ++v) {
    const Vec4f p = to_local * c.positions_rest[range.first_vertex + v].homogeneous();
    mesh->mVertices[v] = ToAi(Vector3f(p.head<3>()));
  }
}

}  // namespace

aiMesh* MakeRangeMesh(const RawCharacter& c, const MeshRange& range, const std::string& name,
                      const std::vector<std::string>& joint_names, const std::vector<Mat4f>& rest_world,
                      bool all_binds) {
  auto* mesh = new aiMesh();
  mesh->mName = aiString(name);
  mesh->mPrimitiveTypes = aiPrimitiveType_TRIANGLE;
  mesh->mMaterialIndex = 0;
  mesh->mNumVertices = range.vertex_count;
  mesh->mVertices = new aiVector3D[range.vertex_count];
  SetFaces(mesh, c.triangles, range.first_triangle, range.triangle_count, range.first_vertex);
  if (range.skinned) {
    SetSkinnedVertices(c, range, joint_names, all_binds, mesh);
  } else {
    SetRigidVertices(c, range, rest_world, mesh);
  }
  SetNormals(mesh);
  return mesh;
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

}  // namespace skinspheres::lib::detail
