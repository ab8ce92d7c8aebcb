// The glTF reader's node tree (glTF 2.0 §3.5: nodes, TRS or matrix, one parent each): the nodes
// checked and read, their preorder, and the node tree as a skeleton for the clip reader.
// Work is linear in the number of nodes (no walk to the root per node) and nothing recurses.
#include <Eigen/Geometry>
#include <cmath>

#include "importer_gltf_stages.h"

namespace skinspheres::lib::detail {

using nlohmann::json;
using skinning::Transform;

std::optional<Quatf> UsableRotation(const Quatf& q) {
  const float n2 = q.squaredNorm();
  if (n2 >= 1e-30f && n2 <= 1e30f) return q;
  const Eigen::Vector4d c = q.coeffs().cast<double>();
  const double n = c.norm();
  if (!(n > 0.0)) return std::nullopt;
  return Quatf(Vec4f((c / n).cast<float>()));
}

const json& ArrayOrEmpty(const json& j, const char* key) {
  static const json kEmpty = json::array();
  return j.contains(key) && j[key].is_array() ? j[key] : kEmpty;
}

std::string NodeLabel(const std::vector<GltfNode>& nodes, int32_t n) {
  return "node " + std::to_string(n) +
         (nodes[static_cast<size_t>(n)].name.empty() ? "" : " '" + nodes[static_cast<size_t>(n)].name + "'");
}

std::string ReadNodes(const json& j, std::vector<GltfNode>* nodes) {
  const json& arr = ArrayOrEmpty(j, "nodes");
  nodes->resize(arr.size());
  const int32_t n_nodes = static_cast<int32_t>(arr.size());
  for (int32_t i = 0; i < n_nodes; ++i) {
    const json& jn = arr[static_cast<size_t>(i)];
    GltfNode& node = (*nodes)[static_cast<size_t>(i)];
    node.name = jn.value("name", std::string());
    node.mesh = Integer(jn, "mesh", -1);
    node.skin = Integer(jn, "skin", -1);
    if (jn.contains("matrix")) {
      // glTF 2.0 §3.5.3 (and node.schema.json): a node has a matrix or TRS properties, not both.
      for (const char* trs : {"translation", "rotation", "scale"}) {
        if (jn.contains(trs))
          return "node " + std::to_string(i) + " has both a matrix and a " + trs + " (glTF allows one or the other)";
      }
      node.has_matrix = true;
      const auto& m = jn["matrix"];
      if (!m.is_array() || m.size() != 16) return "node " + std::to_string(i) + " has a matrix without 16 numbers";
      Mat4f mat;
      for (int k = 0; k < 16; ++k) mat(k % 4, k / 4) = m[static_cast<size_t>(k)].get<float>();  // column-major
      if (!mat.allFinite()) return "node " + std::to_string(i) + " has a non-finite matrix";
      node.local = Transform::FromMatrix(mat);
    } else {
      if (jn.contains("translation")) {
        const auto& t = jn["translation"];
        if (!t.is_array() || t.size() != 3) return "node " + std::to_string(i) + " has a bad translation";
        node.local.translation = Eigen::Vector3f(t[0].get<float>(), t[1].get<float>(), t[2].get<float>());
      }
      if (jn.contains("rotation")) {
        const auto& r = jn["rotation"];  // x, y, z, w
        if (!r.is_array() || r.size() != 4) return "node " + std::to_string(i) + " has a bad rotation";
        node.local.rotation = Quatf(r[3].get<float>(), r[0].get<float>(), r[1].get<float>(), r[2].get<float>());
      }
      if (jn.contains("scale")) {
        const auto& s = jn["scale"];
        if (!s.is_array() || s.size() != 3) return "node " + std::to_string(i) + " has a bad scale";
        node.local.scale = Eigen::Vector3f(s[0].get<float>(), s[1].get<float>(), s[2].get<float>());
      }
      if (!node.local.translation.allFinite() || !node.local.rotation.coeffs().allFinite() ||
          !node.local.scale.allFinite()) {
        return "node " + std::to_string(i) + " has a non-finite transform";
      }
      const auto rotation = UsableRotation(node.local.rotation);
      if (!rotation) return "node " + std::to_string(i) + " has a rotation of zero length";
      node.local.rotation = *rotation;
    }
    for (const auto& c : ArrayOrEmpty(jn, "children")) {
      const int64_t child = Integer(c, "children");
      if (child < 0 || child >= n_nodes) return "node " + std::to_string(i) + " has a child index out of range";
      if ((*nodes)[static_cast<size_t>(child)].parent != -1 || child == i) {
        return "node " + std::to_string(child) + " has more than one parent (the node graph is not a tree)";
      }
      (*nodes)[static_cast<size_t>(child)].parent = i;
      node.children.push_back(static_cast<int32_t>(child));
    }
  }
  // With single parents, a node is on or under a cycle exactly when no root reaches it: one
  // iterative walk down from the roots, linear in the nodes (walking up from each node to its root
  // is quadratic on a deep chain).
  std::vector<char> reached(nodes->size(), 0);
  std::vector<int32_t> stack;
  for (int32_t r = 0; r < n_nodes; ++r) {
    if ((*nodes)[static_cast<size_t>(r)].parent != -1) continue;
    stack.push_back(r);
    while (!stack.empty()) {
      const int32_t n = stack.back();
      stack.pop_back();
      reached[static_cast<size_t>(n)] = 1;
      for (int32_t c : (*nodes)[static_cast<size_t>(n)].children) stack.push_back(c);
    }
  }
  for (int32_t i = 0; i < n_nodes; ++i) {
    if (!reached[static_cast<size_t>(i)])
      return "the node hierarchy has a cycle through or above node " + std::to_string(i);
  }
  return {};
}

std::vector<int32_t> PreorderNodes(const std::vector<GltfNode>& nodes, const std::vector<int32_t>& scene_roots) {
  std::vector<int32_t> order;
  std::vector<char> seen(nodes.size(), 0);
  std::vector<int32_t> stack;
  auto visit = [&](int32_t root) {
    stack.push_back(root);
    while (!stack.empty()) {
      const int32_t n = stack.back();
      stack.pop_back();
      if (seen[static_cast<size_t>(n)]) continue;
      seen[static_cast<size_t>(n)] = 1;
      order.push_back(n);
      const auto& ch = nodes[static_cast<size_t>(n)].children;
      for (auto it = ch.rbegin(); it != ch.rend(); ++it) stack.push_back(*it);
    }
  };
  for (int32_t r : scene_roots) visit(r);
  for (size_t n = 0; n < nodes.size(); ++n) {
    if (nodes[n].parent == -1) visit(static_cast<int32_t>(n));
  }
  return order;
}

std::string ReadGltfNodeTree(const GltfDocument& doc, skinning::Skeleton* out, std::vector<int32_t>* node_of_joint) {
  std::vector<GltfNode> nodes;
  if (std::string p = ReadNodes(doc.json, &nodes); !p.empty()) return p;
  std::vector<int32_t> scene_roots;
  const json& scenes = ArrayOrEmpty(doc.json, "scenes");
  const int64_t s = Integer(doc.json, "scene", 0);
  if (s >= 0 && s < static_cast<int64_t>(scenes.size())) {
    for (const auto& r : ArrayOrEmpty(scenes[static_cast<size_t>(s)], "nodes")) {
      const int64_t root = Integer(r, "nodes");
      if (root >= 0 && root < static_cast<int64_t>(nodes.size()) && nodes[static_cast<size_t>(root)].parent == -1) {
        scene_roots.push_back(static_cast<int32_t>(root));
      }
    }
  }
  std::vector<int32_t> joint_of_node(nodes.size(), -1);
  *out = skinning::Skeleton{};
  node_of_joint->clear();
  for (int32_t n : PreorderNodes(nodes, scene_roots)) {
    const GltfNode& node = nodes[static_cast<size_t>(n)];
    joint_of_node[static_cast<size_t>(n)] = static_cast<int32_t>(out->size());
    out->joint_names.push_back(node.name.empty() ? "node_" + std::to_string(n) : node.name);
    out->parents.push_back(node.parent >= 0 ? joint_of_node[static_cast<size_t>(node.parent)] : -1);
    out->rest_local.push_back(node.local);
    node_of_joint->push_back(n);
  }
  return {};
}

}  // namespace skinspheres::lib::detail
