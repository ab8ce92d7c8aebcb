// Tests for ImportCharacter's glTF 2.0 reader (lib/src/io/importer_gltf*.cc, gltf_document.cc; sparse
// accessors: gltf_sparse_tests.cc; Assimp's path: assimp_import_tests.cc, clip files:
// clip_import_tests.cc, hostile files: hostile_input_tests.cc).
// Oracles are independent of the importer: the shared characters' GLB JSON and binary chunk are
// parsed here again (vertex/triangle counts from the accessors, rest positions recomputed in
// double precision from the node tree), and small glTF files are written at test time for the
// edge cases (NaN, zero weights, joint out of range, no triangles, STEP/CUBICSPLINE samplers).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <set>

#include "lib/tiny_gltf.h"
#include "skinspheres/lib/io/importer.h"
#include "test_support.h"

namespace skinspheres::lib {
namespace {

using nlohmann::json;

// ---------------------------------------------------------------------------------------------
// An independent GLB reader (float/ubyte/ushort accessors only, which is what the assets use).
struct Glb {
  json j;
  std::vector<uint8_t> bin;

  static Glb Load(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    uint32_t json_length = 0, bin_length = 0;
    std::memcpy(&json_length, bytes.data() + 12, 4);
    Glb g;
    g.j = json::parse(bytes.begin() + 20, bytes.begin() + 20 + json_length);
    const size_t bin_at = 20 + json_length;
    std::memcpy(&bin_length, bytes.data() + bin_at, 4);
    g.bin.assign(bytes.begin() + static_cast<std::ptrdiff_t>(bin_at + 8),
                 bytes.begin() + static_cast<std::ptrdiff_t>(bin_at + 8 + bin_length));
    return g;
  }
  size_t Count(int accessor) const { return j["accessors"][accessor]["count"].get<size_t>(); }
  // Element e, component c of an accessor, as double.
  std::vector<double> Read(int accessor) const {
    const json& a = j["accessors"][accessor];
    const json& bv = j["bufferViews"][a["bufferView"].get<int>()];
    const std::map<std::string, int> comps = {{"SCALAR", 1}, {"VEC2", 2}, {"VEC3", 3}, {"VEC4", 4}, {"MAT4", 16}};
    const int n = comps.at(a["type"].get<std::string>());
    const int type = a["componentType"].get<int>();
    const int size = type == 5126 || type == 5125 ? 4 : type == 5123 || type == 5122 ? 2 : 1;
    const size_t stride = bv.value("byteStride", static_cast<size_t>(n * size));
    const uint8_t* base = bin.data() + bv.value("byteOffset", size_t{0}) + a.value("byteOffset", size_t{0});
    std::vector<double> out;
    for (size_t e = 0; e < a["count"].get<size_t>(); ++e) {
      for (int c = 0; c < n; ++c) {
        const uint8_t* p = base + e * stride + static_cast<size_t>(c * size);
        if (type == 5126) {
          float f;
          std::memcpy(&f, p, 4);
          out.push_back(f);
        } else if (type == 5125) {
          uint32_t u;
          std::memcpy(&u, p, 4);
          out.push_back(u);
        } else if (type == 5123) {
          uint16_t u;
          std::memcpy(&u, p, 2);
          out.push_back(a.value("normalized", false) ? u / 65535.0 : u);
        } else if (type == 5121) {
          out.push_back(a.value("normalized", false) ? *p / 255.0 : *p);
        } else
          ADD_FAILURE() << "componentType " << type << " not handled by the test reader";
      }
    }
    return out;
  }
};

// World matrices of all nodes, in double, straight from the JSON.
std::vector<Eigen::Matrix4d> NodeWorld(const json& j) {
  const size_t n = j["nodes"].size();
  std::vector<int> parent(n, -1);
  for (size_t i = 0; i < n; ++i)
    for (const auto& c : j["nodes"][i].value("children", json::array())) parent[c.get<size_t>()] = static_cast<int>(i);
  std::vector<Eigen::Matrix4d> local(n), world(n);
  for (size_t i = 0; i < n; ++i) {
    const json& node = j["nodes"][i];
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    if (node.contains("matrix")) {
      for (int k = 0; k < 16; ++k) m(k % 4, k / 4) = node["matrix"][k].get<double>();
    } else {
      Eigen::Affine3d a = Eigen::Affine3d::Identity();
      if (node.contains("translation"))
        a.translate(Eigen::Vector3d(node["translation"][0], node["translation"][1], node["translation"][2]));
      if (node.contains("rotation"))
        a.rotate(Eigen::Quaterniond(node["rotation"][3], node["rotation"][0], node["rotation"][1], node["rotation"][2])
                     .normalized());
      if (node.contains("scale")) a.scale(Eigen::Vector3d(node["scale"][0], node["scale"][1], node["scale"][2]));
      m = a.matrix();
    }
    local[i] = m;
  }
  std::function<Eigen::Matrix4d(size_t)> w = [&](size_t i) -> Eigen::Matrix4d {
    return parent[i] < 0 ? local[i] : Eigen::Matrix4d(w(static_cast<size_t>(parent[i])) * local[i]);
  };
  for (size_t i = 0; i < n; ++i) world[i] = w(i);
  return world;
}

// Rest positions of every vertex, in the importer's documented order (meshes in file order,
// each once per node using it, primitives in order), computed from the file alone.
std::vector<Eigen::Vector3d> OracleRestPositions(const Glb& g, size_t* triangles) {
  const auto world = NodeWorld(g.j);
  std::vector<Eigen::Vector3d> out;
  *triangles = 0;
  for (size_t m = 0; m < g.j["meshes"].size(); ++m) {
    for (size_t n = 0; n < g.j["nodes"].size(); ++n) {
      const json& node = g.j["nodes"][n];
      if (node.value("mesh", -1) != static_cast<int>(m)) continue;
      for (const json& prim : g.j["meshes"][m]["primitives"]) {
        const auto pos = g.Read(prim["attributes"]["POSITION"].get<int>());
        *triangles += prim.contains("indices") ? g.Count(prim["indices"].get<int>()) / 3 : pos.size() / 9;
        const size_t nv = pos.size() / 3;
        if (!node.contains("skin")) {
          for (size_t v = 0; v < nv; ++v)
            out.push_back((world[n] * Eigen::Vector4d(pos[3 * v], pos[3 * v + 1], pos[3 * v + 2], 1)).head<3>());
          continue;
        }
        const json& skin = g.j["skins"][node["skin"].get<int>()];
        const auto ibm = g.Read(skin["inverseBindMatrices"].get<int>());
        const auto joints = g.Read(prim["attributes"]["JOINTS_0"].get<int>());
        const auto weights = g.Read(prim["attributes"]["WEIGHTS_0"].get<int>());
        for (size_t v = 0; v < nv; ++v) {
          Eigen::Vector4d p = Eigen::Vector4d::Zero();
          double sum = 0;
          for (int k = 0; k < 4; ++k) {
            const double w = weights[4 * v + k];
            if (w == 0) continue;
            const int ji = static_cast<int>(joints[4 * v + k]);
            const Eigen::Matrix4d inv = Eigen::Map<const Eigen::Matrix4d>(ibm.data() + 16 * ji);
            p += w * world[skin["joints"][ji].get<size_t>()] * inv *
                 Eigen::Vector4d(pos[3 * v], pos[3 * v + 1], pos[3 * v + 2], 1);
            sum += w;
          }
          out.push_back(p.head<3>() / sum);
        }
      }
    }
  }
  return out;
}

struct Expect {
  std::string file;
  size_t triangles;
  double height;
};
const std::vector<Expect>& Characters() {
  static const std::vector<Expect> e = {{"Xbot.glb", 49112, 1.81},
                                        {"Soldier.glb", 11376, 0.206},
                                        {"CesiumMan.glb", 4672, 1.5},
                                        {"RobotExpressive.glb", 3237, 4.44}};
  return e;
}

class SharedCharacter : public ::testing::TestWithParam<Expect> {};

TEST_P(SharedCharacter, MatchesTheFileAccessorsAndRestPose) {
  SKINSPHERES_REQUIRE_ASSET(path, GetParam().file);
  const Result<RawCharacter> r = ImportCharacter(path);
  ASSERT_TRUE(r.ok()) << r.error().message;
  const RawCharacter& c = *r;
  const Glb g = Glb::Load(path);
  size_t file_triangles = 0;
  const auto oracle = OracleRestPositions(g, &file_triangles);

  // Counts: the file's own vertices and triangles (README figure too), nothing welded or dropped.
  EXPECT_EQ(c.triangle_count(), GetParam().triangles);
  EXPECT_EQ(c.triangle_count(), file_triangles);
  ASSERT_EQ(c.vertex_count(), oracle.size());
  EXPECT_EQ(c.skin.vertex_count(), c.vertex_count());
  uint32_t v_sum = 0, t_sum = 0;
  for (const MeshRange& m : c.meshes) {
    EXPECT_EQ(m.first_vertex, v_sum);
    EXPECT_EQ(m.first_triangle, t_sum);
    v_sum += m.vertex_count;
    t_sum += m.triangle_count;
  }
  EXPECT_EQ(v_sum, c.vertex_count());
  EXPECT_EQ(t_sum, c.triangle_count());

  // Rest positions against the double-precision oracle, relative to the character's size.
  const double tol = 2e-4 * GetParam().height;
  double worst = 0;
  for (size_t v = 0; v < oracle.size(); ++v)
    worst = std::max(worst, (c.positions_rest[v].cast<double>() - oracle[v]).norm());
  EXPECT_LT(worst, tol) << "largest rest-position difference";

  // And against the importer's own skeleton and binds: Σ w·(G·IBM)·p_bind.
  std::vector<skinspheres::Mat4f> G(c.skeleton.size());
  ASSERT_TRUE(c.skeleton.Validate());
  c.skeleton.RestWorld(G);
  ASSERT_EQ(c.skin.influence_offsets.size(), c.vertex_count() + 1);
  for (size_t v = 0; v < c.vertex_count(); ++v) {
    double sum = 0;
    skinspheres::Vec4f p = skinspheres::Vec4f::Zero();
    for (uint32_t k = c.skin.influence_offsets[v]; k < c.skin.influence_offsets[v + 1]; ++k) {
      const float w = c.skin.influence_weights[k];
      ASSERT_GT(w, 0.0f);
      ASSERT_LT(c.skin.influence_binds[k], c.skin.binds.size());
      const auto& b = c.skin.binds[c.skin.influence_binds[k]];
      ASSERT_GE(b.joint, 0);
      ASSERT_LT(b.joint, static_cast<int32_t>(c.skeleton.size()));
      p += w * (G[static_cast<size_t>(b.joint)] * b.inverse_bind * c.skin.positions_bind[v].homogeneous());
      sum += w;
    }
    ASSERT_NEAR(sum, 1.0, 1e-5) << "weights of vertex " << v << " are not normalised";
    ASSERT_LT((p.head<3>() - c.positions_rest[v]).norm(), tol) << "vertex " << v;
  }
  for (const auto& t : c.triangles) {
    ASSERT_GE(t.minCoeff(), 0);
    ASSERT_LT(t.maxCoeff(), static_cast<int>(c.vertex_count()));
  }

  // Height, +Y up, standing on y = 0 (units kept: no rescaling).
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(1e30f), hi = -lo;
  for (const auto& p : c.positions_rest) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Eigen::Vector3f extent = hi - lo;
  EXPECT_NEAR(extent.y(), GetParam().height, 0.03 * GetParam().height);
  EXPECT_GT(extent.y(), 1.5f * extent.z());  // RobotExpressive is the stoutest: 4.46 tall, 2.68 deep
  EXPECT_NEAR(lo.y(), 0.0, 0.02 * GetParam().height);

  // Bind entries: distinct (joint node, IBM) pairs of the file's skins, plus one per rigid mesh.
  std::set<std::pair<int, std::vector<double>>> distinct;
  for (const json& skin : g.j["skins"]) {
    const auto ibm = g.Read(skin["inverseBindMatrices"].get<int>());
    for (size_t k = 0; k < skin["joints"].size(); ++k) {
      std::vector<double> m(ibm.begin() + static_cast<std::ptrdiff_t>(16 * k),
                            ibm.begin() + static_cast<std::ptrdiff_t>(16 * k + 16));
      distinct.insert({skin["joints"][k].get<int>(), m});
    }
  }
  size_t rigid = 0;
  for (const MeshRange& m : c.meshes) rigid += !m.skinned;
  const size_t rigid_nodes = [&] {
    std::set<int> nodes_with_rigid_mesh;
    for (size_t n = 0; n < g.j["nodes"].size(); ++n)
      if (g.j["nodes"][n].contains("mesh") && !g.j["nodes"][n].contains("skin"))
        nodes_with_rigid_mesh.insert(static_cast<int>(n));
    return nodes_with_rigid_mesh.size();
  }();
  EXPECT_EQ(c.skin.binds.size(), distinct.size() + rigid_nodes);
  EXPECT_EQ(c.source_file, path.string());
  std::printf(
      "%s: %zu vertices, %zu triangles, %zu joints, %zu bind entries, %zu clips, %zu meshes (%zu rigid), height %.3f\n",
      GetParam().file.c_str(), c.vertex_count(), c.triangle_count(), c.skeleton.size(), c.skin.binds.size(),
      c.clips.size(), c.meshes.size(), rigid, extent.y());

  // Clips: durations cover the keys; times strictly increasing; tracks on valid joints.
  for (const auto& clip : c.clips) {
    EXPECT_FALSE(clip.name.empty());
    for (const auto& t : clip.tracks) {
      ASSERT_GE(t.joint, 0);
      ASSERT_LT(t.joint, static_cast<int32_t>(c.skeleton.size()));
      for (const auto* times : {&t.translation.times_s, &t.rotation.times_s, &t.scale.times_s}) {
        for (size_t k = 1; k < times->size(); ++k) ASSERT_LT((*times)[k - 1], (*times)[k]);
        if (!times->empty()) {
          EXPECT_LE(times->back(), clip.duration_s + 1e-6f);
        }
      }
      EXPECT_EQ(t.rotation.values.size(), t.rotation.times_s.size());
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Assets, SharedCharacter, ::testing::ValuesIn(Characters()),
                         [](const ::testing::TestParamInfo<Expect>& param_info) {
                           return param_info.param.file.substr(0, param_info.param.file.find('.'));
                         });

TEST(ImporterAssets, SoldierClipsAndScale) {
  SKINSPHERES_REQUIRE_ASSET(path, "Soldier.glb");
  const auto r = ImportCharacter(path);
  ASSERT_TRUE(r.ok()) << r.error().message;
  std::vector<std::string> names;
  for (const auto& clip : r->clips) names.push_back(clip.name);
  EXPECT_EQ(names, (std::vector<std::string>{"Idle", "Run", "TPose", "Walk"}));
  for (const auto& clip : r->clips) {
    if (clip.name != "TPose") {
      EXPECT_GT(clip.duration_s, 0.5f) << clip.name;
    }
    for (const auto& t : clip.tracks) EXPECT_EQ(t.rotation.interpolation, skinning::Interpolation::kLinear);
  }
  EXPECT_EQ(r->meshes.size(), 2u);  // body + visor, both skinned on one skeleton
  EXPECT_TRUE(r->meshes[0].skinned && r->meshes[1].skinned);
}

TEST(ImporterAssets, XbotClipIsStep) {
  SKINSPHERES_REQUIRE_ASSET(path, "Xbot.glb");
  const auto r = ImportCharacter(path);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->clips.size(), 1u);
  EXPECT_NEAR(r->clips[0].duration_s, 0.0667f, 0.001f);
  ASSERT_FALSE(r->clips[0].tracks.empty());
  EXPECT_EQ(r->clips[0].tracks[0].rotation.interpolation, skinning::Interpolation::kStep);
}

TEST(ImporterAssets, CesiumManKeepsTheZUpNodeAboveTheSkeleton) {
  SKINSPHERES_REQUIRE_ASSET(path, "CesiumMan.glb");
  const auto r = ImportCharacter(path);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->skeleton.joint_names[0], "Z_UP");
  EXPECT_EQ(r->skeleton.parents[0], -1);
  EXPECT_EQ(r->skeleton.size(), 19u + 2u);  // 19 skin joints + Z_UP + Armature
  ASSERT_EQ(r->clips.size(), 1u);
  EXPECT_NEAR(r->clips[0].duration_s, 2.0f, 0.01f);
}

TEST(ImporterAssets, RobotExpressiveRigidPartsFollowJoints) {
  SKINSPHERES_REQUIRE_ASSET(path, "RobotExpressive.glb");
  const auto r = ImportCharacter(path);
  ASSERT_TRUE(r.ok()) << r.error().message;
  const RawCharacter& c = *r;
  EXPECT_EQ(c.clips.size(), 14u);
  std::set<std::string> names;
  for (const auto& clip : c.clips) names.insert(clip.name);
  for (const char* n : {"Dance", "Punch", "Wave", "Idle", "Walking"}) EXPECT_TRUE(names.count(n)) << n;
  std::vector<skinspheres::Mat4f> G(c.skeleton.size());
  c.skeleton.RestWorld(G);
  size_t rigid = 0;
  for (const MeshRange& m : c.meshes) {
    if (m.skinned) continue;
    ++rigid;
    ASSERT_GE(m.rigid_joint, 0) << m.name;
    // The rigid part's node hangs under a skin joint (its parent is a joint of the skeleton).
    EXPECT_GE(c.skeleton.parents[static_cast<size_t>(m.rigid_joint)], 0) << m.name;
    for (uint32_t v = m.first_vertex; v < m.first_vertex + m.vertex_count; ++v) {
      const uint32_t k = c.skin.influence_offsets[v];
      ASSERT_EQ(c.skin.influence_offsets[v + 1], k + 1) << m.name;
      const auto& b = c.skin.binds[c.skin.influence_binds[k]];
      ASSERT_EQ(b.joint, m.rigid_joint);
      ASSERT_FLOAT_EQ(c.skin.influence_weights[k], 1.0f);
      ASSERT_LT((c.skin.positions_bind[v] - c.positions_rest[v]).norm(), 1e-4f);  // baked to world rest
    }
    const auto& b = c.skin.binds[c.skin.influence_binds[c.skin.influence_offsets[m.first_vertex]]];
    EXPECT_TRUE((G[static_cast<size_t>(m.rigid_joint)] * b.inverse_bind).isIdentity(1e-3f)) << m.name;
  }
  EXPECT_EQ(rigid, 15u);  // 12 rigid mesh nodes, 15 primitives
  // The Head mesh node is animated (Dance, ...) although no skin lists it: it is a joint.
  const int32_t head = c.skeleton.Find("Head");
  ASSERT_GE(head, 0);
  bool head_animated = false;
  for (const auto& clip : c.clips)
    for (const auto& t : clip.tracks) head_animated |= t.joint == head;
  EXPECT_TRUE(head_animated);
}

// Small glTF files written at test time: tiny_gltf.h.

TEST(ImporterTiny, ValidSkinnedTriangleRestPose) {
  const auto dir = test::TempDir("importer_valid");
  const auto path = Write(dir, "tiny.gltf", MakeTiny({}).dump());
  const auto r = ImportCharacter(path);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->vertex_count(), 4u);
  ASSERT_EQ(r->triangle_count(), 2u);
  EXPECT_EQ(r->triangles[1], Eigen::Vector3i(2, 1, 3));
  EXPECT_EQ(r->skeleton.size(), 2u);
  EXPECT_TRUE(r->positions_rest[3].isApprox(Eigen::Vector3f(1, 2, 1)));
  EXPECT_TRUE(r->skin.positions_bind[3].isApprox(Eigen::Vector3f(1, 1, 1)));
  // The same file as GLB imports identically.
  const auto glb = ImportCharacter(Write(dir, "tiny.glb", ToGlb(MakeTiny({}))));
  ASSERT_TRUE(glb.ok()) << glb.error().message;
  EXPECT_EQ(glb->positions_rest, r->positions_rest);
}

// A weight that normalises to 0 in float beside the vertex's others (1.5e-43 beside 1e25) is
// dropped like a zero weight: no stored influence has weight 0 (found by fuzzing).
TEST(ImporterTiny, WeightVanishingWhenNormalisedIsDropped) {
  TinyOptions o;
  o.weights.assign(16, 0.0f);
  for (int v = 0; v < 4; ++v) {
    o.weights[4 * v] = 1e25f;         // joint 1
    o.weights[4 * v + 1] = 1.5e-43f;  // joint 0
  }
  const auto r = ImportCharacter(Write(test::TempDir("importer_vanishing_weight"), "tiny.gltf", MakeTiny(o).dump()));
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->skin.influence_offsets, (std::vector<uint32_t>{0, 1, 2, 3, 4}));
  for (size_t k = 0; k < 4; ++k) {
    EXPECT_EQ(r->skin.influence_weights[k], 1.0f);
    EXPECT_EQ(r->skin.binds[r->skin.influence_binds[k]].joint, 1);
  }
}

// A rotation of zero length is no rotation: refused in a node and in a sampler's keys, naming
// them; CUBICSPLINE tangents of zero are fine.
TEST(ImporterTiny, RotationsOfZeroLengthAreRefused) {
  const auto dir = test::TempDir("importer_zero_rotation");
  TinyOptions node;
  node.edit = [](TinyGltf& t) { t.j["nodes"][1]["rotation"] = {0.0, 0.0, 0.0, 0.0}; };
  ExpectError(Write(dir, "node.gltf", MakeTiny(node).dump()), ErrorCode::kFormatRejected,
              "node 1 has a rotation of zero length");
  auto cubic = [](int zero_key, bool zero_tangents) {
    TinyOptions o;
    o.animations = true;
    o.edit = [=](TinyGltf& t) {
      std::vector<float> out;
      for (int k = 0; k < 3; ++k) {
        const float tangent_w = zero_tangents ? 0.0f : 1.0f, value_w = k == zero_key ? 0.0f : 1.0f;
        for (float v : {0.f, 0.f, 0.f, tangent_w}) out.push_back(v);
        for (float v : {0.f, 0.f, 0.f, value_w}) out.push_back(v);
        for (float v : {0.f, 0.f, 0.f, tangent_w}) out.push_back(v);
      }
      t.j["animations"][0]["samplers"][1]["output"] = t.Floats(out, "VEC4", 4);
    };
    return MakeTiny(o).dump();
  };
  ExpectError(Write(dir, "key.gltf", cubic(1, false)), ErrorCode::kInvalidData,
              "has a rotation key of zero length (key 1)");
  // LINEAR and STEP: one zero key refused; keys too small or too large for a float norm
  // (components 1e-25, 1e25) read as unit rotations.
  auto linear = [](const char* interpolation, float scale_of_key_1) {
    TinyOptions o;
    o.animations = true;
    o.edit = [=](TinyGltf& t) {
      std::vector<float> out;
      for (int k = 0; k < 3; ++k) {
        const float s = k == 1 ? scale_of_key_1 : 1.0f;
        for (float v : {0.0f, 0.6f * s, 0.0f, 0.8f * s}) out.push_back(v);
      }
      t.j["animations"][0]["samplers"][1]["output"] = t.Floats(out, "VEC4", 4);
      t.j["animations"][0]["samplers"][1]["interpolation"] = interpolation;
    };
    return MakeTiny(o).dump();
  };
  for (const char* interpolation : {"LINEAR", "STEP"}) {
    SCOPED_TRACE(interpolation);
    ExpectError(Write(dir, "zero.gltf", linear(interpolation, 0.0f)), ErrorCode::kInvalidData,
                "has a rotation key of zero length (key 1)");
    for (float scale : {1e-25f, 1e25f}) {
      const auto r = ImportCharacter(Write(dir, "scaled.gltf", linear(interpolation, scale)));
      ASSERT_TRUE(r.ok()) << r.error().message;
      const auto& q = r->clips[0].tracks[0].rotation.values[1];
      EXPECT_NEAR(q.norm(), 1.0f, 1e-6f) << scale;
      EXPECT_NEAR(q.y(), 0.6f, 1e-6f) << scale;
      EXPECT_NEAR(q.w(), 0.8f, 1e-6f) << scale;
    }
  }
  const auto ok = ImportCharacter(Write(dir, "tangents.gltf", cubic(-1, true)));
  ASSERT_TRUE(ok.ok()) << ok.error().message;
  ASSERT_EQ(ok->clips.size(), 1u);
  EXPECT_EQ(ok->clips[0].tracks[0].rotation.values.size(), 9u);
}

TEST(ImporterTiny, StepAndCubicSplineSamplersAreKept) {
  TinyOptions o;
  o.animations = true;
  const auto path = Write(test::TempDir("importer_anim"), "anim.gltf", MakeTiny(o).dump());
  const auto r = ImportCharacter(path);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->clips.size(), 1u);
  const auto& clip = r->clips[0];
  EXPECT_EQ(clip.name, "wiggle");
  EXPECT_FLOAT_EQ(clip.duration_s, 1.0f);
  ASSERT_EQ(clip.tracks.size(), 2u);  // the track on the mesh node (not a joint) is dropped
  EXPECT_EQ(clip.tracks[0].joint, 0);
  EXPECT_EQ(clip.tracks[0].rotation.interpolation, skinning::Interpolation::kCubicSpline);
  EXPECT_EQ(clip.tracks[0].rotation.times_s.size(), 3u);
  EXPECT_EQ(clip.tracks[0].rotation.values.size(), 9u);
  EXPECT_EQ(clip.tracks[1].joint, 1);
  EXPECT_EQ(clip.tracks[1].translation.interpolation, skinning::Interpolation::kStep);
  ASSERT_EQ(clip.tracks[1].translation.values.size(), 3u);
  EXPECT_TRUE(clip.tracks[1].translation.values[2].isApprox(Eigen::Vector3f(0, 2, 0)));
}

TEST(ImporterTiny, StaticFileIsOneJointAtTheNodeTransform) {
  TinyOptions o;
  o.skinned = false;
  o.mode = 5;  // triangle strip: 6 indices -> 4 triangles, odd ones flipped
  const auto r = ImportCharacter(Write(test::TempDir("importer_static"), "static.gltf", MakeTiny(o).dump()));
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->skeleton.size(), 1u);
  ASSERT_EQ(r->triangle_count(), 4u);
  EXPECT_EQ(r->triangles[1], Eigen::Vector3i(2, 1, 2));  // degenerate strip triangle kept
  EXPECT_TRUE(r->positions_rest[3].isApprox(Eigen::Vector3f(6, 1, 1)));
  EXPECT_FALSE(r->meshes[0].skinned);
  EXPECT_EQ(r->meshes[0].rigid_joint, 0);
}

TEST(ImporterBadInput, EachProblemGivesItsError) {
  const auto dir = test::TempDir("importer_bad");
  ExpectError(dir / "missing.glb", ErrorCode::kFileNotFound);
  ExpectError(Write(dir, "empty.glb", ""), ErrorCode::kFormatRejected, "empty");
  ExpectError(dir, ErrorCode::kFileUnreadable);
  std::mt19937 rng(7);
  std::string noise(4096, '\0');
  for (char& ch : noise) ch = static_cast<char>(rng());
  ExpectError(Write(dir, "noise.glb", noise), ErrorCode::kFormatRejected);
  ExpectError(Write(dir, "noise.fbx", noise), ErrorCode::kFormatRejected);
  ExpectError(Write(dir, "noise.gltf", noise), ErrorCode::kFormatRejected);
  const std::string glb = ToGlb(MakeTiny({}));
  ExpectError(Write(dir, "truncated.glb", glb.substr(0, glb.size() / 2)), ErrorCode::kFormatRejected, "truncated");

  TinyOptions nan;
  nan.position_x0 = std::numeric_limits<float>::quiet_NaN();
  json nan_json = MakeTiny(nan);
  ExpectError(Write(dir, "nan.gltf", nan_json.dump()), ErrorCode::kInvalidData, "NaN");
  TinyOptions zero;
  zero.weight = 0.0f;
  ExpectError(Write(dir, "zero_weights.gltf", MakeTiny(zero).dump()), ErrorCode::kInvalidData, "sum to zero");
  TinyOptions out_of_range;
  out_of_range.joint = 5;
  ExpectError(Write(dir, "joint_range.gltf", MakeTiny(out_of_range).dump()), ErrorCode::kInvalidData, "joint index 5");
  TinyOptions lines;
  lines.mode = 1;
  ExpectError(Write(dir, "lines.gltf", MakeTiny(lines).dump()), ErrorCode::kInvalidData, "no triangles");
  // Sparse accessors are read (ImporterSparse below); an incomplete sparse block is refused.
  json sparse = MakeTiny({});
  sparse["accessors"][0]["sparse"] = {{"count", 1}};
  ExpectError(Write(dir, "sparse.gltf", sparse.dump()), ErrorCode::kFormatRejected,
              "accessor 0 sparse indices are missing");
  // Overlapping elements (byteStride below the element size) are refused.
  json narrow = MakeTiny({});
  narrow["bufferViews"][narrow["accessors"][0]["bufferView"].get<size_t>()]["byteStride"] = 4;
  ExpectError(Write(dir, "narrow_stride.gltf", narrow.dump()), ErrorCode::kFormatRejected, "below the 12-byte element");
  json wrong_type = MakeTiny({});
  wrong_type["nodes"][1]["translation"] = "up";
  ExpectError(Write(dir, "wrong_type.gltf", wrong_type.dump()), ErrorCode::kFormatRejected);
  json cycle = MakeTiny({});
  cycle["nodes"][1]["children"] = {0};
  ExpectError(Write(dir, "cycle.gltf", cycle.dump()), ErrorCode::kFormatRejected);
  json overrun = MakeTiny({});
  overrun["accessors"][0]["count"] = 1000000;
  ExpectError(Write(dir, "overrun.gltf", overrun.dump()), ErrorCode::kFormatRejected, "runs past");
  // A count whose byte size wraps 64 bits must not pass the bounds check (it crashed once).
  json wrap = MakeTiny({});
  wrap["accessors"][0]["count"] = 6148914691236517206ll;
  ExpectError(Write(dir, "wrap.gltf", wrap.dump()), ErrorCode::kFormatRejected, "runs past");
  // An accessor with no bufferView is zeros; a huge one must not allocate gigabytes.
  json no_view = MakeTiny({});
  no_view["accessors"][0].erase("bufferView");
  no_view["accessors"][0]["count"] = 268435456;
  ExpectError(Write(dir, "no_view.gltf", no_view.dump()), ErrorCode::kFormatRejected, "implausible count");
  // A buffer uri that is a device, absolute, or outside the file's folder is refused (never read).
  for (const char* uri : {"/dev/zero", "../elsewhere.bin", "/etc/hostname"}) {
    json outside = MakeTiny({});
    outside["buffers"][0]["uri"] = uri;
    ExpectError(Write(dir, "outside.gltf", outside.dump()), ErrorCode::kFormatRejected, "not a path beside the file");
  }
  // An "asset" without "version".
  json no_version = MakeTiny({});
  no_version["asset"].erase("version");
  ExpectError(Write(dir, "no_version.gltf", no_version.dump()), ErrorCode::kFormatRejected);
}

TEST(ImporterBadInput, EveryPrefixOfAGlbIsRefusedWithoutCrashing) {
  ExpectFuzzRefusedWithoutCrashing(test::TempDir("importer_prefix"), ToGlb(MakeTiny({})), 11);
}

}  // namespace
}  // namespace skinspheres::lib
