// The collider writers: json (our list), vrm1 / vrm0 (the character's glTF with VRM spring-bone
// colliders), godot (.tscn), unity (C# editor script), usd (.usda). docs/COLLIDERS.md describes
// each format's conventions; the comments here say only what the code relies on.
#include <Eigen/Geometry>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <sstream>

#include "colliders.h"
#include "skinspheres/lib/io/glb_exporter.h"
#include "skinspheres/runtime/format/file_io.h"

namespace skinspheres::tool {

namespace {

using nlohmann::json;

// A collider in one joint's frames at rest: `local` (the joint's node space, scale included, as
// glTF, VRM and Unity place children) and `rigid` (rotation and translation only, model units).
struct Placed {
  Eigen::Vector3f head_local, tail_local, head_rigid, tail_rigid;
  float head_radius, tail_radius;
  float scale;  // the joint's world scale at rest (mean of its axes)
};

Placed Place(const lib::Collider& c, const Mat4f& rest_world) {
  const Mat4f rigid = lib::RigidFrame(rest_world);
  const Mat4f to_local = rest_world.inverse() * rigid;
  auto local = [&](const Eigen::Vector3f& p) { return Eigen::Vector3f((to_local * p.homogeneous()).head<3>()); };
  const float scale = (rest_world.block<3, 1>(0, 0).norm() + rest_world.block<3, 1>(0, 1).norm() +
                       rest_world.block<3, 1>(0, 2).norm()) /
                      3.0f;
  return Placed{local(c.head), local(c.tail), c.head, c.tail, c.head_radius, c.tail_radius, scale};
}

json Vec(const Eigen::Vector3f& v) { return json::array({v.x(), v.y(), v.z()}); }

std::string Num(double x) {
  char b[32];
  std::snprintf(b, sizeof(b), "%.9g", std::abs(x) < 1e-30 ? 0.0 : x);
  return b;
}

std::string Safe(const std::string& s) {
  std::string out;
  for (char ch : s) out += std::isalnum(static_cast<unsigned char>(ch)) ? ch : '_';
  return out;
}

// A string literal for C#, Godot and USD ("..." with \ and " escaped, controls dropped).
std::string Quoted(const std::string& s) {
  std::string out = "\"";
  for (char ch : s) {
    if (ch == '"' || ch == '\\') out += '\\';
    if (static_cast<unsigned char>(ch) >= 0x20) out += ch;
  }
  return out + "\"";
}

// The rotation taking +Y (Godot, Unity capsules) or +Z (USD) onto the capsule's axis.
Eigen::Quaternionf AxisRotation(const Eigen::Vector3f& from, const Eigen::Vector3f& head, const Eigen::Vector3f& tail) {
  const Eigen::Vector3f d = tail - head;
  if (d.norm() <= 0.0f) return Eigen::Quaternionf::Identity();
  return Eigen::Quaternionf::FromTwoVectors(from, d.normalized());
}

std::optional<std::string> WriteJson(const ColliderOutput& o, const std::string& path) {
  json shapes = json::array();
  for (const auto& c : o.colliders) {
    const Placed p = Place(c, o.rest_world[c.joint]);
    shapes.push_back({{"joint", o.character->skeleton.joint_names[c.joint]},
                      {"joint_index", c.joint},
                      {"part", c.part},
                      {"shape", c.is_sphere() ? "sphere" : "capsule"},
                      {"offset", Vec(p.head_local)},
                      {"tail", Vec(p.tail_local)},
                      {"radius", c.head_radius},
                      {"tail_radius", c.tail_radius},
                      {"rigid_offset", Vec(p.head_rigid)},
                      {"rigid_tail", Vec(p.tail_rigid)}});
  }
  json doc = {{"format", "skinspheres.collider_shapes"},
              {"version", 1},
              {"units",
               "offset/tail: the joint's node space at rest (scale included); rigid_*: the joint's rotation and "
               "translation only, model units; radii: model units"},
              {"colliders", shapes},
              {"report", o.report}};
  if (auto err = runtime::WriteWholeFile(path, doc.dump(1) + "\n")) return err->message;
  return std::nullopt;
}

// ---------------------------------------------------------------------------------------------
// glTF: the document as JSON plus its binary chunk (empty for a .gltf).

struct Gltf {
  json doc;
  std::string bin;
};

uint32_t Le32(const std::string& s, size_t at) {
  uint32_t v = 0;
  std::memcpy(&v, s.data() + at, 4);
  return v;
}

// A GLB's JSON and binary chunks; errors name `label`.
std::optional<std::string> ParseGlb(const std::string& s, const std::string& label, Gltf* out) {
  try {
    if (s.size() < 20 || s.compare(0, 4, "glTF") != 0) return label + ": not a binary glTF (GLB) file";
    const uint32_t json_len = Le32(s, 12);
    if (Le32(s, 16) != 0x4E4F534A || 20 + static_cast<size_t>(json_len) > s.size())
      return label + ": a GLB without a JSON chunk first";
    out->doc = json::parse(s.substr(20, json_len));
    const size_t at = 20 + json_len;
    if (at + 8 <= s.size()) {
      const uint32_t bin_len = Le32(s, at);
      if (Le32(s, at + 4) == 0x004E4942 && at + 8 + bin_len <= s.size()) out->bin = s.substr(at + 8, bin_len);
    }
  } catch (const json::exception& e) {
    return label + ": not a glTF document (" + e.what() + ")";
  }
  if (!out->doc.is_object() || !out->doc.contains("nodes") || !out->doc["nodes"].is_array())
    return label + ": a glTF without nodes";
  return std::nullopt;
}

std::optional<std::string> ReadGltf(const std::string& path, Gltf* out) {
  auto bytes = runtime::ReadRegularFileBytes(path, uint64_t{1} << 31, "glTF file");
  if (!bytes.ok()) return bytes.error().message;
  return ParseGlb(std::string(reinterpret_cast<const char*>(bytes->data()), bytes->size()), path, out);
}

std::string GlbBytes(const Gltf& g) {
  std::string text = g.doc.dump();
  while (text.size() % 4) text += ' ';
  std::string bin = g.bin;
  while (bin.size() % 4) bin += '\0';
  auto le = [](uint32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); };
  const uint32_t total =
      12 + 8 + static_cast<uint32_t>(text.size()) + (bin.empty() ? 0 : 8 + static_cast<uint32_t>(bin.size()));
  std::string out = "glTF" + le(2) + le(total) + le(static_cast<uint32_t>(text.size())) + le(0x4E4F534A) + text;
  if (!bin.empty()) out += le(static_cast<uint32_t>(bin.size())) + le(0x004E4942) + bin;
  return out;
}

// The glTF node of each skeleton joint: the node named as the importer names the joint ("node_N"
// for an unnamed node N) whose ancestors are named as the joint's ancestors (a mesh node may share a
// bone's name). An error when that leaves two.
std::optional<std::string> NodesOfJoints(const Gltf& g, const lib::RawCharacter& ch, std::vector<int>* out) {
  const json& nodes = g.doc["nodes"];
  std::vector<std::string> names(nodes.size());
  std::vector<int> parent(nodes.size(), -1);
  std::map<std::string, std::vector<int>> by_name;
  for (size_t n = 0; n < nodes.size(); ++n) {
    const json& node = nodes[n];
    names[n] = node.is_object() && node.contains("name") && node["name"].is_string() ? node["name"].get<std::string>()
                                                                                     : "node_" + std::to_string(n);
    by_name[names[n]].push_back(static_cast<int>(n));
    if (!node.is_object() || !node.contains("children") || !node["children"].is_array()) continue;
    for (const json& c : node["children"]) {
      if (c.is_number_integer() && c.get<int64_t>() >= 0 && c.get<size_t>() < nodes.size())
        parent[c.get<size_t>()] = static_cast<int>(n);
    }
  }
  const auto& sk = ch.skeleton;
  auto same_path = [&](int node, int32_t joint) {
    for (int guard = 0; node >= 0 && joint >= 0 && guard < 100000; ++guard) {
      if (names[static_cast<size_t>(node)] != sk.joint_names[static_cast<size_t>(joint)]) return false;
      node = parent[static_cast<size_t>(node)];
      joint = sk.parents[static_cast<size_t>(joint)];
    }
    return node < 0 && joint < 0;
  };
  out->assign(sk.size(), -1);
  for (size_t j = 0; j < sk.size(); ++j) {
    const auto it = by_name.find(sk.joint_names[j]);
    if (it == by_name.end()) continue;
    for (int n : it->second) {
      if (!same_path(n, static_cast<int32_t>(j))) continue;
      if ((*out)[j] >= 0)
        return "two nodes named '" + it->first + "' under the same path: colliders cannot name their node";
      (*out)[j] = n;
    }
  }
  return std::nullopt;
}

void UseExtension(json* doc, const std::string& name) {
  json& used = (*doc)["extensionsUsed"];
  if (!used.is_array()) used = json::array();
  for (const auto& u : used) {
    if (u == name) return;
  }
  used.push_back(name);
}

// The character as glTF: a GLB's (or .vrm's) own bytes, so that what it holds besides stays as it
// is; any other file (a .gltf, FBX, ...) as our GLB export of the character.
std::optional<std::string> CharacterGltf(const lib::RawCharacter& ch, Gltf* g) {
  std::string ext = std::filesystem::path(ch.source_file).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (!ch.source_file.empty() && (ext == ".glb" || ext == ".vrm")) return ReadGltf(ch.source_file, g);
  auto blob = lib::ExportGlbToMemory(ch, ch.Name());
  if (!blob.ok()) return blob.error().message;
  return ParseGlb(std::string(reinterpret_cast<const char*>(blob->bytes.data()), blob->bytes.size()),
                  ch.Name() + " (our GLB export)", g);
}

std::optional<std::string> WriteVrm(const ColliderOutput& o, const std::string& path, bool v0) {
  Gltf g;
  if (auto err = CharacterGltf(*o.character, &g)) return err;
  std::vector<int> node;
  if (auto err = NodesOfJoints(g, *o.character, &node)) return o.character->Name() + ": " + *err;
  std::map<std::string, std::vector<size_t>> by_part;  // vrm1: groups per body part
  std::map<uint32_t, std::vector<size_t>> by_joint;    // vrm0: groups per node
  for (size_t s = 0; s < o.colliders.size(); ++s) {
    const auto& c = o.colliders[s];
    if (node[c.joint] < 0)
      return o.character->Name() + ": joint '" + o.character->skeleton.joint_names[c.joint] + "' has no glTF node";
    by_part[c.part].push_back(s);
    by_joint[c.joint].push_back(s);
  }
  json& ext = g.doc["extensions"];
  if (!ext.is_object()) ext = json::object();
  if (!v0) {
    json& spring = ext["VRMC_springBone"];
    if (!spring.is_object()) spring = {{"specVersion", "1.0"}};
    json& colliders = spring["colliders"];
    if (!colliders.is_array()) colliders = json::array();
    json& groups = spring["colliderGroups"];
    if (!groups.is_array()) groups = json::array();
    const size_t first = colliders.size();
    for (const auto& c : o.colliders) {
      const Placed p = Place(c, o.rest_world[c.joint]);
      json shape = c.is_sphere() ? json{{"sphere", {{"offset", Vec(p.head_local)}, {"radius", c.head_radius}}}}
                                 : json{{"capsule",
                                         {{"offset", Vec(p.head_local)},
                                          {"radius", std::max(c.head_radius, c.tail_radius)},
                                          {"tail", Vec(p.tail_local)}}}};
      colliders.push_back({{"node", node[c.joint]}, {"shape", shape}});
    }
    for (const auto& [part, list] : by_part) {
      json idx = json::array();
      for (size_t s : list) idx.push_back(first + s);
      groups.push_back({{"name", "skinspheres " + part}, {"colliders", idx}});
    }
    UseExtension(&g.doc, "VRMC_springBone");
  } else {
    json& vrm = ext["VRM"];
    if (!vrm.is_object()) vrm = {{"exporterVersion", "skinspheres"}, {"specVersion", "0.0"}};
    json& secondary = vrm["secondaryAnimation"];
    if (!secondary.is_object()) secondary = json::object();
    if (!secondary["boneGroups"].is_array()) secondary["boneGroups"] = json::array();
    json& groups = secondary["colliderGroups"];
    if (!groups.is_array()) groups = json::array();
    for (const auto& [joint, list] : by_joint) {
      json cs = json::array();
      for (size_t s : list) {
        const auto& c = o.colliders[s];
        const Placed p = Place(c, o.rest_world[c.joint]);
        // VRM 0.x stores z negated (as UniVRM wrote it; three-vrm negates it back).
        cs.push_back({{"offset", {{"x", p.head_local.x()}, {"y", p.head_local.y()}, {"z", -p.head_local.z()}}},
                      {"radius", c.head_radius}});
      }
      groups.push_back({{"node", node[joint]}, {"colliders", cs}});
    }
    UseExtension(&g.doc, "VRM");
  }
  if (auto err = runtime::WriteWholeFile(path, GlbBytes(g))) return err->message;
  return std::nullopt;
}

// ---------------------------------------------------------------------------------------------
// Godot 4 (4.4+): a SpringBoneSimulator3D holding one SpringBoneCollision*3D per shape, to put
// under the character's Skeleton3D. Offsets in the bone's rigid frame (Godot's spring bones expect
// unscaled bones); a capsule's axis is its node's +Y.

std::optional<std::string> WriteGodot(const ColliderOutput& o, const std::string& path) {
  std::ostringstream t;
  t << "[gd_scene format=3]\n\n[node name=\"SkinspheresColliders\" type=\"SpringBoneSimulator3D\"]\n";
  for (size_t s = 0; s < o.colliders.size(); ++s) {
    const auto& c = o.colliders[s];
    const std::string& bone = o.character->skeleton.joint_names[c.joint];
    const Placed p = Place(c, o.rest_world[c.joint]);
    const Eigen::Vector3f mid = 0.5f * (p.head_rigid + p.tail_rigid);
    const Eigen::Quaternionf q = AxisRotation(Eigen::Vector3f::UnitY(), p.head_rigid, p.tail_rigid);
    t << "\n[node name=" << Quoted("c" + std::to_string(s) + "_" + Safe(bone)) << " type=\"SpringBoneCollision"
      << (c.is_sphere() ? "Sphere" : "Capsule") << "3D\" parent=\".\"]\n";
    t << "bone_name = " << Quoted(bone) << "\nbone = " << c.joint << "\n";
    t << "position_offset = Vector3(" << Num(mid.x()) << ", " << Num(mid.y()) << ", " << Num(mid.z()) << ")\n";
    t << "rotation_offset = Quaternion(" << Num(q.x()) << ", " << Num(q.y()) << ", " << Num(q.z()) << ", " << Num(q.w())
      << ")\n";
    const float r = std::max(c.head_radius, c.tail_radius);
    t << "radius = " << Num(r) << "\n";
    if (!c.is_sphere()) t << "height = " << Num((p.tail_rigid - p.head_rigid).norm() + 2.0f * r) << "\n";
  }
  if (auto err = runtime::WriteWholeFile(path, t.str())) return err->message;
  return std::nullopt;
}

// ---------------------------------------------------------------------------------------------
// Unity: an editor script. Each shape is a child GameObject of its bone holding SphereColliders
// (two for a capsule: a tapered ClothSphereColliderPair), in the bone's local space with x negated
// (glTF importers for Unity mirror x), radii divided by the bone's scale (Unity scales colliders).

std::optional<std::string> WriteUnity(const ColliderOutput& o, const std::string& path) {
  std::ostringstream t;
  t << "// Written by skinspheres colliders. Put in an Editor folder, select the character's root and run\n"
       "// Tools > skinspheres > Add colliders. Adds one child per shape under its bone and, when the selection\n"
       "// holds a Cloth, sets its sphere colliders (Unity reads at most 32 pairs).\n"
       "using System.Collections.Generic;\nusing UnityEditor;\nusing UnityEngine;\n\n"
       "public static class SkinspheresColliders\n{\n"
       "    struct Shape { public string bone; public Vector3 head, tail; public float headRadius, tailRadius; public "
       "bool sphere; }\n\n"
       "    static readonly Shape[] Shapes =\n    {\n";
  for (const auto& c : o.colliders) {
    const Placed p = Place(c, o.rest_world[c.joint]);
    auto v = [](const Eigen::Vector3f& x) {
      return "new Vector3(" + Num(-x.x()) + "f, " + Num(x.y()) + "f, " + Num(x.z()) + "f)";
    };
    t << "        new Shape { bone = " << Quoted(o.character->skeleton.joint_names[c.joint])
      << ", head = " << v(p.head_local) << ", tail = " << v(p.tail_local)
      << ", headRadius = " << Num(c.head_radius / p.scale) << "f, tailRadius = " << Num(c.tail_radius / p.scale)
      << "f, sphere = " << (c.is_sphere() ? "true" : "false") << " },\n";
  }
  t << "    };\n\n"
       "    static Transform Find(Transform root, string name)\n    {\n"
       "        if (root.name == name) return root;\n"
       "        foreach (Transform child in root) { var hit = Find(child, name); if (hit != null) return hit; }\n"
       "        return null;\n    }\n\n"
       "    static SphereCollider Ball(Transform bone, string name, Vector3 at, float radius)\n    {\n"
       "        var go = new GameObject(name);\n        Undo.RegisterCreatedObjectUndo(go, \"skinspheres "
       "colliders\");\n"
       "        go.transform.SetParent(bone, false);\n        go.transform.localPosition = at;\n"
       "        var sc = go.AddComponent<SphereCollider>();\n        sc.radius = radius;\n        return sc;\n    }\n\n"
       "    [MenuItem(\"Tools/skinspheres/Add colliders\")]\n    public static void Add()\n    {\n"
       "        var root = Selection.activeTransform;\n"
       "        if (root == null) { Debug.LogError(\"skinspheres: select the character's root first\"); return; }\n"
       "        var pairs = new List<ClothSphereColliderPair>();\n        int i = 0;\n"
       "        foreach (var s in Shapes)\n        {\n"
       "            var bone = Find(root, s.bone);\n"
       "            if (bone == null) { Debug.LogError(\"skinspheres: no bone named \" + s.bone); continue; }\n"
       "            var a = Ball(bone, \"skinspheres_\" + i + \"_head\", s.head, s.headRadius);\n"
       "            var b = s.sphere ? null : Ball(bone, \"skinspheres_\" + i + \"_tail\", s.tail, s.tailRadius);\n"
       "            pairs.Add(b == null ? new ClothSphereColliderPair(a) : new ClothSphereColliderPair(a, b));\n"
       "            ++i;\n        }\n"
       "        var cloth = root.GetComponentInChildren<Cloth>();\n"
       "        if (cloth != null) { Undo.RecordObject(cloth, \"skinspheres colliders\"); cloth.sphereColliders = "
       "pairs.ToArray(); }\n"
       "        Debug.Log(\"skinspheres: added \" + i + \" colliders\");\n    }\n}\n";
  if (auto err = runtime::WriteWholeFile(path, t.str())) return err->message;
  return std::nullopt;
}

// ---------------------------------------------------------------------------------------------
// USD: per shape an Xform at its joint's rigid frame at rest holding a Sphere, Capsule (radius) or
// Capsule_1 (radiusTop at the tail, radiusBottom at the head), axis Z, with PhysicsCollisionAPI.

std::string UsdMatrix(const Mat4f& m) {
  std::string s = "( ";
  for (int r = 0; r < 4; ++r) {  // USD rows are the transposed columns (row vectors)
    s += "(";
    for (int c = 0; c < 4; ++c) s += Num(m(c, r)) + (c < 3 ? ", " : "");
    s += r < 3 ? "), " : ") ";
  }
  return s + ")";
}

std::optional<std::string> WriteUsd(const ColliderOutput& o, const std::string& path) {
  std::ostringstream t;
  t << "#usda 1.0\n(\n    defaultPrim = \"SkinspheresColliders\"\n    metersPerUnit = 1\n    upAxis = \"Y\"\n)\n\n"
       "def Xform \"SkinspheresColliders\"\n{\n";
  for (size_t s = 0; s < o.colliders.size(); ++s) {
    const auto& c = o.colliders[s];
    const Placed p = Place(c, o.rest_world[c.joint]);
    const std::string name = "c" + std::to_string(s) + "_" + Safe(o.character->skeleton.joint_names[c.joint]);
    t << "    def Xform " << Quoted(name) << "\n    {\n";
    t << "        custom string skinspheres:joint = " << Quoted(o.character->skeleton.joint_names[c.joint]) << "\n";
    t << "        custom string skinspheres:part = " << Quoted(c.part) << "\n";
    t << "        matrix4d xformOp:transform = " << UsdMatrix(lib::RigidFrame(o.rest_world[c.joint])) << "\n";
    t << "        uniform token[] xformOpOrder = [\"xformOp:transform\"]\n\n";
    const Eigen::Vector3f mid = 0.5f * (p.head_rigid + p.tail_rigid);
    const Eigen::Quaternionf q = AxisRotation(Eigen::Vector3f::UnitZ(), p.head_rigid, p.tail_rigid);
    const bool tapered = c.head_radius != c.tail_radius;
    const char* type = c.is_sphere() ? "Sphere" : tapered ? "Capsule_1" : "Capsule";
    t << "        def " << type
      << " \"shape\" (\n            prepend apiSchemas = [\"PhysicsCollisionAPI\"]\n        )\n        {\n";
    if (c.is_sphere()) {
      t << "            double radius = " << Num(c.head_radius) << "\n";
    } else {
      t << "            uniform token axis = \"Z\"\n            double height = "
        << Num((p.tail_rigid - p.head_rigid).norm()) << "\n";
      if (tapered) {
        t << "            double radiusBottom = " << Num(c.head_radius)
          << "\n            double radiusTop = " << Num(c.tail_radius) << "\n";
      } else {
        t << "            double radius = " << Num(c.head_radius) << "\n";
      }
    }
    t << "            double3 xformOp:translate = (" << Num(mid.x()) << ", " << Num(mid.y()) << ", " << Num(mid.z())
      << ")\n";
    t << "            quatf xformOp:orient = (" << Num(q.w()) << ", " << Num(q.x()) << ", " << Num(q.y()) << ", "
      << Num(q.z()) << ")\n";
    t << "            uniform token[] xformOpOrder = [\"xformOp:translate\", \"xformOp:orient\"]\n        }\n    }\n";
  }
  t << "}\n";
  if (auto err = runtime::WriteWholeFile(path, t.str())) return err->message;
  return std::nullopt;
}

}  // namespace

std::optional<std::string> WriteColliders(const std::string& format, const ColliderOutput& o, const std::string& path) {
  if (format == "json") return WriteJson(o, path);
  if (format == "vrm1") return WriteVrm(o, path, false);
  if (format == "vrm0") return WriteVrm(o, path, true);
  if (format == "godot") return WriteGodot(o, path);
  if (format == "unity") return WriteUnity(o, path);
  if (format == "usd") return WriteUsd(o, path);
  return "--format: '" + format + "' is not one of vrm1, vrm0, godot, unity, usd, json";
}

}  // namespace skinspheres::tool
