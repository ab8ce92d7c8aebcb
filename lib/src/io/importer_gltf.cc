// glTF 2.0 -> RawCharacter, read from the JSON and binary buffers directly (not through Assimp):
// this keeps the file's vertex and triangle order exactly, validates JOINTS_n/WEIGHTS_n from the
// accessors, and keeps the animation samplers' STEP/LINEAR/CUBICSPLINE interpolation, which
// Assimp 5.2.5 drops (aiNodeAnim has no interpolation field).
// Spec references: glTF 2.0 §3.5 (nodes, TRS/matrix), §3.7 (meshes, primitive modes),
// §3.7.3 (skins: jointMatrix = G_joint · IBM; a skinned mesh node's own transform is ignored),
// §3.11 (animations), and the JSON schema of each object (node.schema.json, skin.schema.json,
// animation.sampler.schema.json) where a rule is stated there.
// Work is linear in the number of nodes (no walk to the root per node) and nothing recurses.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <set>

#include "gltf_document.h"
#include "importer_internal.h"

namespace skinspheres::lib::detail {
namespace {

using nlohmann::json;
using skinning::Transform;

struct Node {
  std::string name;
  int32_t parent = -1;
  std::vector<int32_t> children;
  Transform local;
  int64_t mesh = -1;
  int64_t skin = -1;
  bool has_matrix = false;
};

struct MeshInstance {
  int64_t mesh;
  int32_t node;
};

// A node rotation or rotation key that float arithmetic can normalise (the sampler and the skeleton
// normalise in float): unchanged when its float squared norm lies within [1e-30, 1e30] (every file
// written with unit quaternions, to the bit), else normalised in double, whose range holds the
// square of every finite float (a float squared norm over/underflows past ~1.8e19 and below ~1e-19
// per component, and normalized() then gives zeros or no rotation at all); nullopt when its length
// is zero.
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

std::string NodeLabel(const std::vector<Node>& nodes, int32_t n) {
  return "node " + std::to_string(n) +
         (nodes[static_cast<size_t>(n)].name.empty() ? "" : " '" + nodes[static_cast<size_t>(n)].name + "'");
}

std::string ReadNodes(const json& j, std::vector<Node>* nodes) {
  const json& arr = ArrayOrEmpty(j, "nodes");
  nodes->resize(arr.size());
  const int32_t n_nodes = static_cast<int32_t>(arr.size());
  for (int32_t i = 0; i < n_nodes; ++i) {
    const json& jn = arr[static_cast<size_t>(i)];
    Node& node = (*nodes)[static_cast<size_t>(i)];
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

// Preorder over the node forest: the scene's roots first (in scene order), then every other
// root in index order, so parents always come before children.
std::vector<int32_t> PreorderNodes(const std::vector<Node>& nodes, const std::vector<int32_t>& scene_roots) {
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

// glTF 2.0 §3.11 (animation.sampler.schema.json): key times are >= 0 and strictly increasing;
// a CUBICSPLINE sampler has at least two keys. A sampler that breaks either refuses the file.
template <typename Value>
std::string FillTrack(skinning::Interpolation interpolation, const std::vector<float>& times,
                      const std::vector<Value>& values, skinning::Track<Value>* track) {
  const size_t per_key = interpolation == skinning::Interpolation::kCubicSpline ? 3 : 1;
  if (values.size() != times.size() * per_key) {
    return "a sampler has " + std::to_string(values.size()) + " output values for " + std::to_string(times.size()) +
           " key times";
  }
  if (per_key == 3 && times.size() < 2) return "a CUBICSPLINE sampler has fewer than two keys";
  for (size_t k = 0; k < times.size(); ++k) {
    if (!std::isfinite(times[k])) return "a sampler has a non-finite key time";
    if (k == 0 && times[k] < 0.0f) return "a sampler's first key time is negative (" + std::to_string(times[k]) + ")";
    if (k > 0 && !(times[k] > times[k - 1])) {
      return "a sampler's key times are not strictly increasing (key " + std::to_string(k) + ": " +
             std::to_string(times[k]) + " after " + std::to_string(times[k - 1]) + ")";
    }
  }
  track->interpolation = interpolation;
  track->times_s = times;
  track->values = values;
  return {};
}

std::string ReadClips(const GltfDocument& doc, const std::vector<Node>& nodes,
                      const std::vector<int32_t>& joint_of_node, std::vector<skinning::AnimationClip>* clips) {
  const json& anims = ArrayOrEmpty(doc.json, "animations");
  uint64_t keys = 0;  // over every clip and track, against kMaxAnimationKeys
  for (size_t a = 0; a < anims.size(); ++a) {
    const json& ja = anims[a];
    skinning::AnimationClip clip;
    clip.name = ja.value("name", std::string());
    if (clip.name.empty()) clip.name = "animation_" + std::to_string(a);
    const std::string where = "animation " + std::to_string(a) + " '" + clip.name + "'";
    const json& samplers = ArrayOrEmpty(ja, "samplers");
    std::map<int32_t, size_t> track_of_joint;
    std::set<std::pair<int64_t, std::string>> targets;
    for (const json& ch : ArrayOrEmpty(ja, "channels")) {
      if (!ch.contains("target")) continue;
      const json& target = ch["target"];
      const int64_t node = Integer(target, "node", -1);
      const std::string path = target.value("path", std::string());
      // glTF 2.0 §3.11: within one animation a target (node and path) MUST NOT appear twice, and
      // a node animated in translation, rotation or scale MUST NOT have a matrix.
      if (target.contains("node") && !targets.emplace(node, path).second) {
        return where + " animates node " + std::to_string(node) + " " + path + " twice";
      }
      if (node >= 0 && node < static_cast<int64_t>(nodes.size()) && nodes[static_cast<size_t>(node)].has_matrix &&
          (path == "translation" || path == "rotation" || path == "scale")) {
        return where + " animates the " + path + " of node " + std::to_string(node) + ", which has a matrix";
      }
      // Tracks on nodes outside the skeleton (cameras, props not carrying a mesh, nodes not on a
      // path to a joint) cannot move the character and are dropped, as are morph "weights".
      if (node < 0 || node >= static_cast<int64_t>(joint_of_node.size())) continue;
      const int32_t joint = joint_of_node[static_cast<size_t>(node)];
      if (joint < 0 || (path != "translation" && path != "rotation" && path != "scale")) continue;
      const int64_t s = Integer(ch, "sampler", -1);
      if (s < 0 || s >= static_cast<int64_t>(samplers.size())) return where + " has a channel with a bad sampler index";
      const json& js = samplers[static_cast<size_t>(s)];
      const std::string interp_name = js.value("interpolation", std::string("LINEAR"));
      skinning::Interpolation interpolation;
      if (interp_name == "LINEAR")
        interpolation = skinning::Interpolation::kLinear;
      else if (interp_name == "STEP")
        interpolation = skinning::Interpolation::kStep;
      else if (interp_name == "CUBICSPLINE")
        interpolation = skinning::Interpolation::kCubicSpline;
      else
        return where + " has an unknown interpolation \"" + interp_name + "\"";
      std::vector<float> times, out;
      if (std::string p = ReadAccessorFloats(doc, Integer(js, "input", -1), 1, &times); !p.empty())
        return where + ": " + p;
      const int components = path == "rotation" ? 4 : 3;
      if (std::string p = ReadAccessorFloats(doc, Integer(js, "output", -1), components, &out); !p.empty())
        return where + ": " + p;
      for (float v : out) {
        if (!std::isfinite(v)) return where + " has a non-finite " + path + " value";
      }
      keys += times.size();
      if (keys > kMaxAnimationKeys) {
        return "the animations hold more than " + std::to_string(kMaxAnimationKeys) +
               " keys (at most that many are read)";
      }
      auto [it, inserted] = track_of_joint.emplace(joint, clip.tracks.size());
      if (inserted) {
        clip.tracks.emplace_back();
        clip.tracks.back().joint = joint;
      }
      skinning::JointTrack& track = clip.tracks[it->second];
      std::string problem;
      if (path == "rotation") {
        std::vector<Quatf> q(out.size() / 4);
        for (size_t k = 0; k < q.size(); ++k) q[k] = Quatf(out[4 * k + 3], out[4 * k], out[4 * k + 1], out[4 * k + 2]);
        // A key of zero length is no rotation (the sampler would have to guess one); one too small
        // or too large for float normalisation is normalised in double (UsableRotation).
        // CUBICSPLINE tangents (the first and last of each triple) may be zero and stay as they are.
        const size_t per_key = interpolation == skinning::Interpolation::kCubicSpline ? 3 : 1;
        for (size_t k = per_key / 2; k < q.size(); k += per_key) {
          const auto unit = UsableRotation(q[k]);
          if (!unit) return where + " has a rotation key of zero length (key " + std::to_string(k / per_key) + ")";
          q[k] = *unit;
        }
        problem = FillTrack(interpolation, times, q, &track.rotation);
      } else {
        std::vector<Eigen::Vector3f> v(out.size() / 3);
        for (size_t k = 0; k < v.size(); ++k) v[k] = Eigen::Vector3f(out[3 * k], out[3 * k + 1], out[3 * k + 2]);
        problem = FillTrack(interpolation, times, v, path == "translation" ? &track.translation : &track.scale);
      }
      if (!problem.empty()) return where + ": " + problem;
      if (!times.empty()) clip.duration_s = std::max(clip.duration_s, times.back());
    }
    std::sort(clip.tracks.begin(), clip.tracks.end(),
              [](const skinning::JointTrack& x, const skinning::JointTrack& y) { return x.joint < y.joint; });
    clips->push_back(std::move(clip));
  }
  return {};
}

}  // namespace

// Over the function-size limit of .clang-tidy: to be split into one stage per section of the file.
// NOLINTNEXTLINE(readability-function-size)
Result<RawCharacter> ImportGltf(const std::filesystem::path& file, std::span<const uint8_t> bytes,
                                const ImportOptions& options) {
  Result<GltfDocument> loaded = LoadGltf(file, bytes);
  if (!loaded.ok()) return loaded.error();
  const GltfDocument& doc = *loaded;
  const json& j = doc.json;
  auto invalid = [&](const std::string& problem) { return ImportError(ErrorCode::kInvalidData, file, problem); };

  std::vector<Node> nodes;
  if (std::string p = ReadNodes(j, &nodes); !p.empty()) return ImportError(ErrorCode::kFormatRejected, file, p);
  const int32_t n_nodes = static_cast<int32_t>(nodes.size());

  // The scene: json["scene"], else scene 0, else (no scenes) every root node.
  std::vector<int32_t> scene_roots;
  const json& scenes = ArrayOrEmpty(j, "scenes");
  if (!scenes.empty()) {
    const int64_t s = Integer(j, "scene", 0);
    if (s < 0 || s >= static_cast<int64_t>(scenes.size()))
      return invalid("\"scene\" " + std::to_string(s) + " does not exist");
    for (const auto& r : ArrayOrEmpty(scenes[static_cast<size_t>(s)], "nodes")) {
      const int64_t root = Integer(r, "nodes");
      if (root < 0 || root >= n_nodes || nodes[static_cast<size_t>(root)].parent != -1) {
        return invalid("the scene lists node " + std::to_string(root) + ", which is not a root node");
      }
      scene_roots.push_back(static_cast<int32_t>(root));
    }
  } else {
    for (int32_t n = 0; n < n_nodes; ++n) {
      if (nodes[static_cast<size_t>(n)].parent == -1) scene_roots.push_back(n);
    }
  }
  const std::vector<int32_t> preorder = PreorderNodes(nodes, scene_roots);
  std::vector<char> in_scene(nodes.size(), 0);
  for (int32_t r : scene_roots) in_scene[static_cast<size_t>(r)] = 1;
  for (int32_t n : preorder) {
    const int32_t p = nodes[static_cast<size_t>(n)].parent;
    if (p >= 0 && in_scene[static_cast<size_t>(p)]) in_scene[static_cast<size_t>(n)] = 1;
  }

  // Mesh instances of the scene, in mesh order, then node order.
  const json& meshes = ArrayOrEmpty(j, "meshes");
  const json& skins = ArrayOrEmpty(j, "skins");
  std::vector<MeshInstance> instances;
  for (int32_t n = 0; n < n_nodes; ++n) {
    const Node& node = nodes[static_cast<size_t>(n)];
    if (!in_scene[static_cast<size_t>(n)] || node.mesh < 0) continue;
    if (node.mesh >= static_cast<int64_t>(meshes.size()))
      return invalid(NodeLabel(nodes, n) + " uses a mesh that does not exist");
    if (node.skin >= static_cast<int64_t>(skins.size()))
      return invalid(NodeLabel(nodes, n) + " uses a skin that does not exist");
    instances.push_back({node.mesh, n});
  }
  std::stable_sort(instances.begin(), instances.end(),
                   [](const MeshInstance& x, const MeshInstance& y) { return x.mesh < y.mesh; });
  const bool skinned_file = std::any_of(instances.begin(), instances.end(), [&](const MeshInstance& m) {
    return nodes[static_cast<size_t>(m.node)].skin >= 0;
  });

  // Skeleton: skin joints, plus every rigid mesh's own node in a skinned file, plus all their
  // ancestors, in preorder (parents first).
  std::vector<char> needed(nodes.size(), 0);
  std::vector<std::vector<int32_t>> skin_joints(skins.size());
  std::vector<char> skin_used(skins.size(), 0);
  std::vector<int64_t> in_skin(nodes.size(), -1);  // the last skin listing each node
  for (const MeshInstance& m : instances) {
    const int64_t s = nodes[static_cast<size_t>(m.node)].skin;
    if (s >= 0)
      skin_used[static_cast<size_t>(s)] = 1;
    else if (skinned_file)
      needed[static_cast<size_t>(m.node)] = 1;
  }
  for (size_t s = 0; s < skins.size(); ++s) {
    if (!skin_used[s]) continue;
    // glTF 2.0 §3.7.3 (skin.schema.json): joints are unique node indices.
    for (const auto& jj : ArrayOrEmpty(skins[s], "joints")) {
      const int64_t joint = Integer(jj, "joints");
      if (joint < 0 || joint >= n_nodes)
        return invalid("skin " + std::to_string(s) + " lists joint node " + std::to_string(joint) +
                       ", which does not exist");
      if (in_skin[static_cast<size_t>(joint)] == static_cast<int64_t>(s)) {
        return invalid("skin " + std::to_string(s) + " lists joint node " + std::to_string(joint) +
                       " twice (glTF skin joints are unique)");
      }
      in_skin[static_cast<size_t>(joint)] = static_cast<int64_t>(s);
      skin_joints[s].push_back(static_cast<int32_t>(joint));
      needed[static_cast<size_t>(joint)] = 1;
    }
    if (skin_joints[s].empty()) return invalid("skin " + std::to_string(s) + " has no joints");
  }
  for (int32_t n = 0; n < n_nodes; ++n) {
    if (!needed[static_cast<size_t>(n)]) continue;
    for (int32_t p = nodes[static_cast<size_t>(n)].parent; p >= 0 && !needed[static_cast<size_t>(p)];
         p = nodes[static_cast<size_t>(p)].parent) {
      needed[static_cast<size_t>(p)] = 1;
    }
  }

  const uint64_t joint_count = static_cast<uint64_t>(std::count(needed.begin(), needed.end(), 1));
  if (joint_count > kMaxJoints) {
    return invalid("the skeleton has " + std::to_string(joint_count) +
                   " joints (nodes on the paths to the skins' joints); at most " + std::to_string(kMaxJoints) +
                   " are read");
  }
  RawCharacter c;
  std::vector<int32_t> joint_of_node(nodes.size(), -1);
  if (skinned_file) {
    for (int32_t n : preorder) {
      if (!needed[static_cast<size_t>(n)]) continue;
      const Node& node = nodes[static_cast<size_t>(n)];
      joint_of_node[static_cast<size_t>(n)] = static_cast<int32_t>(c.skeleton.size());
      c.skeleton.joint_names.push_back(node.name.empty() ? "node_" + std::to_string(n) : node.name);
      c.skeleton.parents.push_back(node.parent >= 0 ? joint_of_node[static_cast<size_t>(node.parent)] : -1);
      c.skeleton.rest_local.push_back(node.local);
    }
  } else {
    // Static character: one identity joint, every mesh baked at its node's world transform.
    c.skeleton.joint_names.push_back("root");
    c.skeleton.parents.push_back(-1);
    c.skeleton.rest_local.push_back(Transform{});
  }
  std::vector<Mat4f> joint_world(c.skeleton.size());
  c.skeleton.RestWorld(joint_world);
  // World transform of any node, from the node tree (for rigid meshes of a static file).
  std::vector<Mat4f> node_world(nodes.size());
  for (int32_t n : preorder) {
    const Node& node = nodes[static_cast<size_t>(n)];
    const Mat4f local = node.local.ToMatrix();
    node_world[static_cast<size_t>(n)] =
        node.parent >= 0 ? Mat4f(node_world[static_cast<size_t>(node.parent)] * local) : local;
  }

  // Bind entries of the skins: skin_bind[s][k] for the skin's k-th joint.
  std::vector<std::vector<int32_t>> skin_bind(skins.size());
  for (size_t s = 0; s < skins.size(); ++s) {
    if (!skin_used[s]) continue;
    const size_t n_joints = skin_joints[s].size();
    std::vector<float> ibm;
    if (skins[s].contains("inverseBindMatrices")) {
      if (std::string p = ReadAccessorFloats(doc, Integer(skins[s], "inverseBindMatrices", -1), 16, &ibm); !p.empty()) {
        return ImportError(ErrorCode::kFormatRejected, file, "skin " + std::to_string(s) + ": " + p);
      }
      if (ibm.size() < 16 * n_joints)
        return invalid("skin " + std::to_string(s) + " has fewer inverse bind matrices than joints");
    }
    for (size_t k = 0; k < n_joints; ++k) {
      Mat4f m = Mat4f::Identity();
      if (!ibm.empty()) m = Eigen::Map<const Mat4f>(ibm.data() + 16 * k);  // column-major, as Eigen
      if (!m.allFinite()) return invalid("skin " + std::to_string(s) + " has a non-finite inverse bind matrix");
      const int32_t b = FindOrAddBind(c.skin, joint_of_node[static_cast<size_t>(skin_joints[s][k])], m);
      if (b < 0) return invalid("more than 65536 distinct bind entries");
      skin_bind[s].push_back(b);
    }
  }

  // Geometry, mesh instance by mesh instance, primitive by primitive.
  std::vector<Influence> influences;
  std::vector<float> positions, weights;
  std::vector<uint32_t> indices, joints;
  for (const MeshInstance& inst : instances) {
    const json& mesh = meshes[static_cast<size_t>(inst.mesh)];
    const Node& node = nodes[static_cast<size_t>(inst.node)];
    std::string mesh_name = mesh.value("name", std::string());
    if (mesh_name.empty()) mesh_name = node.name.empty() ? "mesh_" + std::to_string(inst.mesh) : node.name;
    const json& prims = ArrayOrEmpty(mesh, "primitives");
    const bool skinned = node.skin >= 0;
    int32_t rigid_bind = -1;
    Mat4f rigid_world = Mat4f::Identity();
    if (!skinned) {
      const int32_t joint = skinned_file ? joint_of_node[static_cast<size_t>(inst.node)] : 0;
      rigid_world = skinned_file ? joint_world[static_cast<size_t>(joint)] : node_world[static_cast<size_t>(inst.node)];
      Mat4f ibm = Mat4f::Identity();
      if (skinned_file) {
        const float det = rigid_world.topLeftCorner<3, 3>().determinant();
        if (!(std::abs(det) > 0.0f) || !std::isfinite(det))
          return invalid(NodeLabel(nodes, inst.node) + " has a singular world transform");
        ibm = rigid_world.inverse();  // IBM = G_joint(rest)^-1: at rest G·IBM = I
      }
      rigid_bind = FindOrAddBind(c.skin, joint, ibm);
      if (rigid_bind < 0) return invalid("more than 65536 distinct bind entries");
    }
    for (size_t p = 0; p < prims.size(); ++p) {
      const json& prim = prims[p];
      const std::string where = "mesh '" + mesh_name + "' primitive " + std::to_string(p);
      const int64_t mode = Integer(prim, "mode", 4);
      if (mode < 4 || mode > 6) continue;  // POINTS, LINES, LINE_LOOP, LINE_STRIP: not a surface
      if (!prim.contains("attributes") || !prim["attributes"].contains("POSITION"))
        return invalid(where + " has no POSITION");
      const json& attrs = prim["attributes"];
      if (std::string e = ReadAccessorFloats(doc, Integer(attrs, "POSITION", -1), 3, &positions); !e.empty()) {
        return ImportError(ErrorCode::kFormatRejected, file, where + " POSITION: " + e);
      }
      const size_t n_verts = positions.size() / 3;
      const uint64_t first_vertex = c.skin.vertex_count();
      if (first_vertex + n_verts > kMaxVertices) {
        return invalid("more than " + std::to_string(kMaxVertices) + " vertices (at most that many are read)");
      }
      if (prim.contains("indices")) {
        if (std::string e = ReadAccessorUints(doc, Integer(prim, "indices", -1), 1, &indices); !e.empty()) {
          return ImportError(ErrorCode::kFormatRejected, file, where + " indices: " + e);
        }
      } else {
        indices.resize(n_verts);
        for (size_t v = 0; v < n_verts; ++v) indices[v] = static_cast<uint32_t>(v);
      }
      for (size_t k = 0; k < indices.size(); ++k) {
        if (indices[k] >= n_verts) {
          return invalid(where + " index " + std::to_string(k) + " is " + std::to_string(indices[k]) +
                         ", the primitive has " + std::to_string(n_verts) + " vertices");
        }
      }
      for (size_t v = 0; v < n_verts; ++v) {
        if (!std::isfinite(positions[3 * v]) || !std::isfinite(positions[3 * v + 1]) ||
            !std::isfinite(positions[3 * v + 2])) {
          return invalid(where + " POSITION of vertex " + std::to_string(v) + " is NaN or infinite");
        }
      }
      // Influences: every JOINTS_n/WEIGHTS_n pair (glTF §3.7.3.3), 4 per set.
      std::vector<std::vector<uint32_t>> joint_sets;
      std::vector<std::vector<float>> weight_sets;
      if (skinned) {
        for (int set = 0;; ++set) {
          const std::string jn = "JOINTS_" + std::to_string(set), wn = "WEIGHTS_" + std::to_string(set);
          if (!attrs.contains(jn) || !attrs.contains(wn)) break;
          if (std::string e = ReadAccessorUints(doc, Integer(attrs, jn.c_str(), -1), 4, &joints); !e.empty()) {
            return ImportError(ErrorCode::kFormatRejected, file, where + " " + jn + ": " + e);
          }
          if (std::string e = ReadAccessorFloats(doc, Integer(attrs, wn.c_str(), -1), 4, &weights); !e.empty()) {
            return ImportError(ErrorCode::kFormatRejected, file, where + " " + wn + ": " + e);
          }
          if (joints.size() != 4 * n_verts || weights.size() != 4 * n_verts) {
            return invalid(where + " " + jn + "/" + wn + " count differs from POSITION's");
          }
          joint_sets.push_back(joints);
          weight_sets.push_back(weights);
        }
        if (joint_sets.empty()) return invalid(where + " belongs to a skinned node but has no JOINTS_0/WEIGHTS_0");
      }
      static const std::vector<int32_t> kNoBinds;
      const auto& binds_of_skin = skinned ? skin_bind[static_cast<size_t>(node.skin)] : kNoBinds;
      for (size_t v = 0; v < n_verts; ++v) {
        const Eigen::Vector3f p_file(positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]);
        influences.clear();
        if (skinned) {
          for (size_t set = 0; set < joint_sets.size(); ++set) {
            for (int k = 0; k < 4; ++k) {
              const uint32_t joint = joint_sets[set][4 * v + k];
              const float w = weight_sets[set][4 * v + k];
              if (w == 0.0f) continue;  // padding; its joint index does not matter
              if (joint >= binds_of_skin.size()) {
                return invalid(where + " vertex " + std::to_string(v) + " uses joint index " + std::to_string(joint) +
                               " but skin " + std::to_string(node.skin) + " has " +
                               std::to_string(binds_of_skin.size()) + " joints");
              }
              influences.push_back({static_cast<uint32_t>(binds_of_skin[joint]), w});
            }
          }
          if (auto e = AppendVertex(c.skin, p_file, influences))
            return invalid(where + " vertex " + std::to_string(v) + ": " + *e);
        } else {
          influences.push_back({static_cast<uint32_t>(rigid_bind), 1.0f});
          const Eigen::Vector3f p_world = (rigid_world * p_file.homogeneous()).head<3>();
          if (auto e = AppendVertex(c.skin, p_world, influences))
            return invalid(where + " vertex " + std::to_string(v) + ": " + *e);
        }
      }
      // Triangles (glTF §3.7.2.1): list, strip (odd triangles flipped), fan.
      const uint32_t first_triangle = static_cast<uint32_t>(c.triangles.size());
      auto add = [&](uint32_t a, uint32_t b, uint32_t d) {
        c.triangles.emplace_back(static_cast<int>(first_vertex + indices[a]),
                                 static_cast<int>(first_vertex + indices[b]),
                                 static_cast<int>(first_vertex + indices[d]));
      };
      const size_t ni = indices.size();
      const uint64_t new_triangles = mode == 4 ? ni / 3 : (ni >= 3 ? ni - 2 : 0);
      if (c.triangles.size() + new_triangles > kMaxTriangles) {
        return invalid("more than " + std::to_string(kMaxTriangles) + " triangles (at most that many are read)");
      }
      if (mode == 4) {
        for (size_t t = 0; t + 2 < ni; t += 3)
          add(static_cast<uint32_t>(t), static_cast<uint32_t>(t + 1), static_cast<uint32_t>(t + 2));
      } else if (mode == 5) {
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
      MeshRange range;
      range.name = prims.size() > 1 ? mesh_name + "#" + std::to_string(p) : mesh_name;
      range.first_vertex = static_cast<uint32_t>(first_vertex);
      range.vertex_count = static_cast<uint32_t>(n_verts);
      range.first_triangle = first_triangle;
      range.triangle_count = static_cast<uint32_t>(c.triangles.size() - first_triangle);
      range.skinned = skinned;
      range.rigid_joint = skinned ? -1 : (skinned_file ? joint_of_node[static_cast<size_t>(inst.node)] : 0);
      c.meshes.push_back(std::move(range));
    }
  }
  if (c.skin.influence_offsets.empty()) c.skin.influence_offsets.push_back(0);

  if (options.read_clips && skinned_file) {
    if (std::string p = ReadClips(doc, nodes, joint_of_node, &c.clips); !p.empty()) return invalid(p);
  }
  return c;
}

std::string ReadGltfNodeTree(const GltfDocument& doc, skinning::Skeleton* out, std::vector<int32_t>* node_of_joint) {
  std::vector<Node> nodes;
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
    const Node& node = nodes[static_cast<size_t>(n)];
    joint_of_node[static_cast<size_t>(n)] = static_cast<int32_t>(out->size());
    out->joint_names.push_back(node.name.empty() ? "node_" + std::to_string(n) : node.name);
    out->parents.push_back(node.parent >= 0 ? joint_of_node[static_cast<size_t>(node.parent)] : -1);
    out->rest_local.push_back(node.local);
    node_of_joint->push_back(n);
  }
  return {};
}

std::string ReadGltfClips(const GltfDocument& doc, const std::vector<int32_t>& joint_of_node,
                          std::vector<skinning::AnimationClip>* clips) {
  std::vector<Node> nodes;  // which nodes have a matrix (a TRS channel on one is refused)
  if (std::string p = ReadNodes(doc.json, &nodes); !p.empty()) return p;
  return ReadClips(doc, nodes, joint_of_node, clips);
}

}  // namespace skinspheres::lib::detail
