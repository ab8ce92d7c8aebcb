// The glTF reader's geometry (glTF 2.0 §3.7: meshes, primitive modes): mesh instance by mesh
// instance, primitive by primitive, the file's vertex and triangle order kept exactly, the
// influences from every JOINTS_n/WEIGHTS_n pair (§3.7.3.3); a rigid mesh is bound to its node's
// joint (a skinned file) or baked at its node's world transform (a static file).
#include <Eigen/Geometry>
#include <cmath>

#include "importer_gltf_stages.h"

namespace skinspheres::lib::detail {
namespace {

using nlohmann::json;

// How a mesh instance's vertices are bound: through its node's skin, or rigidly to one bind entry.
struct MeshBinding {
  bool skinned = false;
  const std::vector<int32_t>* skin_binds = nullptr;  // the skin's bind entries (skinned)
  int64_t skin = -1;
  int32_t rigid_bind = -1;
  int32_t rigid_joint = -1;
  Mat4f rigid_world = Mat4f::Identity();  // file -> bind space of a rigid mesh
};

// Buffers reused from primitive to primitive.
struct PrimitiveBuffers {
  std::vector<Influence> influences;
  std::vector<float> positions, weights;
  std::vector<uint32_t> indices, joints;
  std::vector<std::vector<uint32_t>> joint_sets;
  std::vector<std::vector<float>> weight_sets;
};

// One primitive being read: "mesh '<name>' primitive <p>", its mode and its vertices' place in c.
struct Primitive {
  const json& prim;
  std::string where;
  int64_t mode = 4;
  size_t n_verts = 0;
  uint64_t first_vertex = 0;
};

std::optional<Error> BindMeshInstance(const GltfReadContext& ctx, const GltfScene& scene, const GltfMeshInstance& inst,
                                      RawCharacter* c, MeshBinding* b) {
  const GltfNode& node = scene.nodes[static_cast<size_t>(inst.node)];
  b->skinned = node.skin >= 0;
  b->skin = node.skin;
  if (b->skinned) {
    b->skin_binds = &scene.skin_bind[static_cast<size_t>(node.skin)];
    return std::nullopt;
  }
  const int32_t joint = scene.skinned_file ? scene.joint_of_node[static_cast<size_t>(inst.node)] : 0;
  b->rigid_joint = joint;
  b->rigid_world = scene.skinned_file ? scene.joint_world[static_cast<size_t>(joint)]
                                      : scene.node_world[static_cast<size_t>(inst.node)];
  Mat4f ibm = Mat4f::Identity();
  if (scene.skinned_file) {
    const float det = b->rigid_world.topLeftCorner<3, 3>().determinant();
    if (!(std::abs(det) > 0.0f) || !std::isfinite(det))
      return ctx.Invalid(NodeLabel(scene.nodes, inst.node) + " has a singular world transform");
    ibm = b->rigid_world.inverse();  // IBM = G_joint(rest)^-1: at rest G·IBM = I
  }
  b->rigid_bind = FindOrAddBind(c->skin, joint, ibm);
  if (b->rigid_bind < 0) return ctx.Invalid("more than 65536 distinct bind entries");
  return std::nullopt;
}

// POSITION and the indices (0, 1, 2, ... without an "indices" accessor), checked: finite
// positions, indices below the vertex count, the vertex limit.
std::optional<Error> ReadPositionsAndIndices(const GltfReadContext& ctx, const RawCharacter& c, Primitive* p,
                                             PrimitiveBuffers* buf) {
  const json& prim = p->prim;
  const std::string& where = p->where;
  if (!prim.contains("attributes") || !prim["attributes"].contains("POSITION"))
    return ctx.Invalid(where + " has no POSITION");
  const json& attrs = prim["attributes"];
  if (std::string e = ReadAccessorFloats(ctx.doc, Integer(attrs, "POSITION", -1), 3, &buf->positions); !e.empty()) {
    return ctx.Rejected(where + " POSITION: " + e);
  }
  const std::vector<float>& positions = buf->positions;
  std::vector<uint32_t>& indices = buf->indices;
  p->n_verts = positions.size() / 3;
  p->first_vertex = c.skin.vertex_count();
  const size_t n_verts = p->n_verts;
  if (p->first_vertex + n_verts > kMaxVertices) {
    return ctx.Invalid("more than " + std::to_string(kMaxVertices) + " vertices (at most that many are read)");
  }
  if (prim.contains("indices")) {
    if (std::string e = ReadAccessorUints(ctx.doc, Integer(prim, "indices", -1), 1, &indices); !e.empty()) {
      return ctx.Rejected(where + " indices: " + e);
    }
  } else {
    indices.resize(n_verts);
    for (size_t v = 0; v < n_verts; ++v) indices[v] = static_cast<uint32_t>(v);
  }
  for (size_t k = 0; k < indices.size(); ++k) {
    if (indices[k] >= n_verts) {
      return ctx.Invalid(where + " index " + std::to_string(k) + " is " + std::to_string(indices[k]) +
                         ", the primitive has " + std::to_string(n_verts) + " vertices");
    }
  }
  for (size_t v = 0; v < n_verts; ++v) {
    if (!std::isfinite(positions[3 * v]) || !std::isfinite(positions[3 * v + 1]) ||
        !std::isfinite(positions[3 * v + 2])) {
      return ctx.Invalid(where + " POSITION of vertex " + std::to_string(v) + " is NaN or infinite");
    }
  }
  return std::nullopt;
}

// Influences of a skinned primitive: every JOINTS_n/WEIGHTS_n pair (glTF §3.7.3.3), 4 per set.
std::optional<Error> ReadInfluenceSets(const GltfReadContext& ctx, const Primitive& p, PrimitiveBuffers* buf) {
  const json& attrs = p.prim["attributes"];
  buf->joint_sets.clear();
  buf->weight_sets.clear();
  for (int set = 0;; ++set) {
    const std::string jn = "JOINTS_" + std::to_string(set), wn = "WEIGHTS_" + std::to_string(set);
    if (!attrs.contains(jn) || !attrs.contains(wn)) break;
    if (std::string e = ReadAccessorUints(ctx.doc, Integer(attrs, jn.c_str(), -1), 4, &buf->joints); !e.empty()) {
      return ctx.Rejected(p.where + " " + jn + ": " + e);
    }
    if (std::string e = ReadAccessorFloats(ctx.doc, Integer(attrs, wn.c_str(), -1), 4, &buf->weights); !e.empty()) {
      return ctx.Rejected(p.where + " " + wn + ": " + e);
    }
    if (buf->joints.size() != 4 * p.n_verts || buf->weights.size() != 4 * p.n_verts) {
      return ctx.Invalid(p.where + " " + jn + "/" + wn + " count differs from POSITION's");
    }
    buf->joint_sets.push_back(buf->joints);
    buf->weight_sets.push_back(buf->weights);
  }
  if (buf->joint_sets.empty()) return ctx.Invalid(p.where + " belongs to a skinned node but has no JOINTS_0/WEIGHTS_0");
  return std::nullopt;
}

// The primitive's vertices with their influences, appended to c->skin.
std::optional<Error> AppendVertices(const GltfReadContext& ctx, const Primitive& p, const MeshBinding& b,
                                    PrimitiveBuffers* buf, RawCharacter* c) {
  const std::vector<float>& positions = buf->positions;
  std::vector<Influence>& influences = buf->influences;
  for (size_t v = 0; v < p.n_verts; ++v) {
    const Eigen::Vector3f p_file(positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]);
    influences.clear();
    if (b.skinned) {
      const std::vector<int32_t>& binds_of_skin = *b.skin_binds;
      for (size_t set = 0; set < buf->joint_sets.size(); ++set) {
        for (int k = 0; k < 4; ++k) {
          const uint32_t joint = buf->joint_sets[set][4 * v + k];
          const float w = buf->weight_sets[set][4 * v + k];
          if (w == 0.0f) continue;  // padding; its joint index does not matter
          if (joint >= binds_of_skin.size()) {
            return ctx.Invalid(p.where + " vertex " + std::to_string(v) + " uses joint index " + std::to_string(joint) +
                               " but skin " + std::to_string(b.skin) + " has " + std::to_string(binds_of_skin.size()) +
                               " joints");
          }
          influences.push_back({static_cast<uint32_t>(binds_of_skin[joint]), w});
        }
      }
      if (auto e = AppendVertex(c->skin, p_file, influences))
        return ctx.Invalid(p.where + " vertex " + std::to_string(v) + ": " + *e);
    } else {
      influences.push_back({static_cast<uint32_t>(b.rigid_bind), 1.0f});
      const Eigen::Vector3f p_world = (b.rigid_world * p_file.homogeneous()).head<3>();
      if (auto e = AppendVertex(c->skin, p_world, influences))
        return ctx.Invalid(p.where + " vertex " + std::to_string(v) + ": " + *e);
    }
  }
  return std::nullopt;
}

// Triangles (glTF §3.7.2.1): list, strip (odd triangles flipped), fan.
std::optional<Error> AppendTriangles(const GltfReadContext& ctx, const Primitive& p,
                                     const std::vector<uint32_t>& indices, RawCharacter* c) {
  auto add = [&](uint32_t a, uint32_t b, uint32_t d) {
    c->triangles.emplace_back(static_cast<int>(p.first_vertex + indices[a]),
                              static_cast<int>(p.first_vertex + indices[b]),
                              static_cast<int>(p.first_vertex + indices[d]));
  };
  const size_t ni = indices.size();
  const uint64_t new_triangles = p.mode == 4 ? ni / 3 : (ni >= 3 ? ni - 2 : 0);
  if (c->triangles.size() + new_triangles > kMaxTriangles) {
    return ctx.Invalid("more than " + std::to_string(kMaxTriangles) + " triangles (at most that many are read)");
  }
  if (p.mode == 4) {
    for (size_t t = 0; t + 2 < ni; t += 3)
      add(static_cast<uint32_t>(t), static_cast<uint32_t>(t + 1), static_cast<uint32_t>(t + 2));
  } else if (p.mode == 5) {
    for (size_t t = 0; t + 2 < ni; ++t) {
      const uint32_t i = static_cast<uint32_t>(t);
      if (t % 2 == 0)
        add(i, i + 1, i + 2);
      else
        add(i + 1, i, i + 2);
    }
  } else {
    for (size_t t = 0; t + 2 < ni; ++t) add(static_cast<uint32_t>(t + 1), static_cast<uint32_t>(t + 2), 0);
  }
  return std::nullopt;
}

// One primitive: its vertices, influences and triangles, and its MeshRange named `range_name`.
std::optional<Error> ReadPrimitive(const GltfReadContext& ctx, const MeshBinding& b, Primitive* p,
                                   const std::string& range_name, PrimitiveBuffers* buf, RawCharacter* c) {
  if (auto e = ReadPositionsAndIndices(ctx, *c, p, buf)) return e;
  if (b.skinned) {
    if (auto e = ReadInfluenceSets(ctx, *p, buf)) return e;
  }
  if (auto e = AppendVertices(ctx, *p, b, buf, c)) return e;
  const uint32_t first_triangle = static_cast<uint32_t>(c->triangles.size());
  if (auto e = AppendTriangles(ctx, *p, buf->indices, c)) return e;
  MeshRange range;
  range.name = range_name;
  range.first_vertex = static_cast<uint32_t>(p->first_vertex);
  range.vertex_count = static_cast<uint32_t>(p->n_verts);
  range.first_triangle = first_triangle;
  range.triangle_count = static_cast<uint32_t>(c->triangles.size() - first_triangle);
  range.skinned = b.skinned;
  range.rigid_joint = b.skinned ? -1 : b.rigid_joint;
  c->meshes.push_back(std::move(range));
  return std::nullopt;
}

}  // namespace

std::optional<Error> ReadMeshes(const GltfReadContext& ctx, const GltfScene& scene, RawCharacter* c) {
  const json& meshes = ArrayOrEmpty(ctx.doc.json, "meshes");
  PrimitiveBuffers buf;
  for (const GltfMeshInstance& inst : scene.instances) {
    const json& mesh = meshes[static_cast<size_t>(inst.mesh)];
    const GltfNode& node = scene.nodes[static_cast<size_t>(inst.node)];
    std::string mesh_name = mesh.value("name", std::string());
    if (mesh_name.empty()) mesh_name = node.name.empty() ? "mesh_" + std::to_string(inst.mesh) : node.name;
    const json& prims = ArrayOrEmpty(mesh, "primitives");
    MeshBinding binding;
    if (auto e = BindMeshInstance(ctx, scene, inst, c, &binding)) return e;
    for (size_t i = 0; i < prims.size(); ++i) {
      Primitive p{prims[i], "mesh '" + mesh_name + "' primitive " + std::to_string(i)};
      p.mode = Integer(prims[i], "mode", 4);
      if (p.mode < 4 || p.mode > 6) continue;  // POINTS, LINES, LINE_LOOP, LINE_STRIP: not a surface
      const std::string range_name = prims.size() > 1 ? mesh_name + "#" + std::to_string(i) : mesh_name;
      if (auto e = ReadPrimitive(ctx, binding, &p, range_name, &buf, c)) return e;
    }
  }
  if (c->skin.influence_offsets.empty()) c->skin.influence_offsets.push_back(0);
  return std::nullopt;
}

}  // namespace skinspheres::lib::detail
