// Tests for ImportCharacter's glTF 2.0 reader (lib/src/io/importer_gltf.cc, gltf_document.cc; Assimp's
// path: assimp_import_tests.cc, clip files: clip_import_tests.cc, hostile files: hostile_input_tests.cc).
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

// Every prefix of `glb` is refused naming the file; 300 random 4-byte flips (seeded) never crash,
// and any refusal names the file.
void ExpectFuzzRefusedWithoutCrashing(const std::filesystem::path& dir, const std::string& glb, unsigned seed) {
  for (size_t n = 1; n < glb.size(); n += 3) {
    const auto r = ImportCharacter(Write(dir, "prefix.glb", glb.substr(0, n)));
    ASSERT_FALSE(r.ok()) << "prefix of " << n << " bytes imported";
    ASSERT_NE(r.error().message.find("prefix.glb"), std::string::npos);
  }
  std::mt19937 rng(seed);
  for (int trial = 0; trial < 300; ++trial) {
    std::string bytes = glb;
    for (int k = 0; k < 4; ++k) bytes[rng() % bytes.size()] = static_cast<char>(rng());
    const auto r = ImportCharacter(Write(dir, "flipped.glb", bytes));
    if (!r.ok()) {
      ASSERT_NE(r.error().message.find("flipped.glb"), std::string::npos) << r.error().message;
    }
  }
}

TEST(ImporterBadInput, EveryPrefixOfAGlbIsRefusedWithoutCrashing) {
  ExpectFuzzRefusedWithoutCrashing(test::TempDir("importer_prefix"), ToGlb(MakeTiny({})), 11);
}

// ---------------------------------------------------------------------------------------------
// Sparse accessors (glTF 2.0 §3.6.2.3). Oracle: the same tiny file written with the dense
// values imports identically (same floats in, so exactly equal), plus analytic expectations.

int Attr(const TinyGltf& t, const char* attribute) {
  return t.j["meshes"][0]["primitives"][0]["attributes"][attribute].get<int>();
}

void ExpectSameCharacter(const RawCharacter& a, const RawCharacter& b) {
  EXPECT_EQ(a.positions_rest, b.positions_rest);
  EXPECT_EQ(a.skin.positions_bind, b.skin.positions_bind);
  EXPECT_EQ(a.triangles, b.triangles);
  EXPECT_EQ(a.skeleton.parents, b.skeleton.parents);
  EXPECT_EQ(a.skin.influence_offsets, b.skin.influence_offsets);
  EXPECT_EQ(a.skin.influence_binds, b.skin.influence_binds);
  EXPECT_EQ(a.skin.influence_weights, b.skin.influence_weights);
  ASSERT_EQ(a.skin.binds.size(), b.skin.binds.size());
  for (size_t k = 0; k < a.skin.binds.size(); ++k) {
    EXPECT_EQ(a.skin.binds[k].joint, b.skin.binds[k].joint);
    EXPECT_EQ(a.skin.binds[k].inverse_bind, b.skin.binds[k].inverse_bind);
  }
  ASSERT_EQ(a.clips.size(), b.clips.size());
  for (size_t c = 0; c < a.clips.size(); ++c) {
    EXPECT_EQ(a.clips[c].duration_s, b.clips[c].duration_s);
    ASSERT_EQ(a.clips[c].tracks.size(), b.clips[c].tracks.size());
    for (size_t k = 0; k < a.clips[c].tracks.size(); ++k) {
      const auto& ta = a.clips[c].tracks[k];
      const auto& tb = b.clips[c].tracks[k];
      EXPECT_EQ(ta.joint, tb.joint);
      EXPECT_EQ(ta.translation.times_s, tb.translation.times_s);
      EXPECT_EQ(ta.translation.values, tb.translation.values);
      EXPECT_EQ(ta.scale.values, tb.scale.values);
      EXPECT_EQ(ta.rotation.times_s, tb.rotation.times_s);
      ASSERT_EQ(ta.rotation.values.size(), tb.rotation.values.size());
      for (size_t q = 0; q < ta.rotation.values.size(); ++q)
        EXPECT_EQ(ta.rotation.values[q].coeffs(), tb.rotation.values[q].coeffs());
    }
  }
}

RawCharacter ImportOk(const std::filesystem::path& path) {
  auto r = ImportCharacter(path);
  EXPECT_TRUE(r.ok()) << r.error().message;
  return r.ok() ? std::move(*r) : RawCharacter{};
}

// Vertices 1 and 3 of the tiny triangle pair moved (raw positions; rest adds (0, 1, 0)).
const std::vector<float> kMoved = {2, 0.5f, 0, 1, 3, 1};
std::vector<float> MovedDensePositions() {
  std::vector<float> p(std::begin(kTinyPositions), std::end(kTinyPositions));
  std::copy(kMoved.begin(), kMoved.begin() + 3, p.begin() + 3);
  std::copy(kMoved.begin() + 3, kMoved.end(), p.begin() + 9);
  return p;
}

TEST(ImporterSparse, SparsePositionsImportLikeTheDenseFile) {
  const auto dir = test::TempDir("importer_sparse_pos");
  TinyOptions dense;
  dense.positions = MovedDensePositions();
  dense.animations = true;
  const RawCharacter want = ImportOk(Write(dir, "dense.gltf", MakeTiny(dense).dump()));
  ASSERT_EQ(want.vertex_count(), 4u);
  EXPECT_TRUE(want.positions_rest[1].isApprox(Eigen::Vector3f(2, 1.5f, 0)));
  EXPECT_TRUE(want.positions_rest[3].isApprox(Eigen::Vector3f(1, 4, 1)));

  for (int index_type : {5121, 5123, 5125}) {
    SCOPED_TRACE(index_type);
    TinyOptions o;
    o.animations = true;
    o.edit = [&](TinyGltf& t) {
      t.MakeSparse(Attr(t, "POSITION"), {1, 3}, index_type, kMoved.data(), kMoved.size() * 4,
                   index_type == 5123 ? 8 : 0);
    };
    const json file = MakeTiny(o);
    const RawCharacter got = ImportOk(Write(dir, "sparse.gltf", file.dump()));
    ExpectSameCharacter(got, want);
    ExpectSameCharacter(ImportOk(Write(dir, "sparse.glb", ToGlb(file))), want);
  }

  // The base comes from an interleaved bufferView (byteStride 16, a junk float after each vertex).
  TinyOptions strided;
  strided.animations = true;
  strided.edit = [&](TinyGltf& t) {
    std::vector<float> padded;
    for (int v = 0; v < 4; ++v) {
      for (int c = 0; c < 3; ++c) padded.push_back(kTinyPositions[3 * v + c]);
      padded.push_back(99.0f);
    }
    const int a = Attr(t, "POSITION");
    t.j["accessors"][a]["bufferView"] = t.AddView(padded.data(), padded.size() * 4, 16);
    t.MakeSparse(a, {1, 3}, 5123, kMoved.data(), kMoved.size() * 4);
  };
  ExpectSameCharacter(ImportOk(Write(dir, "strided.gltf", MakeTiny(strided).dump())), want);
}

TEST(ImporterSparse, WithoutBufferViewTheBaseIsZeros) {
  const auto dir = test::TempDir("importer_sparse_zero");
  // Vertices 1..3 given over a zero base (vertex 0 is the origin anyway): the plain tiny file.
  TinyOptions all;
  all.edit = [](TinyGltf& t) {
    const int a = Attr(t, "POSITION");
    t.j["accessors"][a].erase("bufferView");
    t.MakeSparse(a, {1, 2, 3}, 5125, kTinyPositions + 3, 9 * 4);
  };
  ExpectSameCharacter(ImportOk(Write(dir, "all.gltf", MakeTiny(all).dump())),
                      ImportOk(Write(dir, "dense.gltf", MakeTiny({}).dump())));

  // Only vertices 1 and 3 given: vertex 2 stays at the raw origin (rest (0, 1, 0)).
  TinyOptions some;
  const std::vector<float> values = {1, 0, 0, 1, 1, 1};
  some.edit = [&](TinyGltf& t) {
    const int a = Attr(t, "POSITION");
    t.j["accessors"][a].erase("bufferView");
    t.MakeSparse(a, {1, 3}, 5121, values.data(), values.size() * 4);
  };
  TinyOptions dense;
  dense.positions = {0, 0, 0, 1, 0, 0, 0, 0, 0, 1, 1, 1};
  const RawCharacter got = ImportOk(Write(dir, "some.gltf", MakeTiny(some).dump()));
  ExpectSameCharacter(got, ImportOk(Write(dir, "some_dense.gltf", MakeTiny(dense).dump())));
  ASSERT_EQ(got.vertex_count(), 4u);
  EXPECT_TRUE(got.positions_rest[2].isApprox(Eigen::Vector3f(0, 1, 0)));
  EXPECT_TRUE(got.skin.positions_bind[2].isZero());
}

TEST(ImporterSparse, OtherAccessorKindsImportLikeTheirDenseFiles) {
  const auto dir = test::TempDir("importer_sparse_kinds");
  // WEIGHTS_0 (float VEC4): vertex 2 split 0.25 on joint slot 0 (joint 1), 0.75 on slot 1 (joint 0).
  {
    const std::vector<float> w2 = {0.25f, 0.75f, 0, 0};
    TinyOptions sparse;
    sparse.edit = [&](TinyGltf& t) { t.MakeSparse(Attr(t, "WEIGHTS_0"), {2}, 5123, w2.data(), 16); };
    TinyOptions dense;
    dense.weights = {1, 0, 0, 0, 1, 0, 0, 0, 0.25f, 0.75f, 0, 0, 1, 0, 0, 0};
    const RawCharacter got = ImportOk(Write(dir, "weights.gltf", MakeTiny(sparse).dump()));
    ExpectSameCharacter(got, ImportOk(Write(dir, "weights_dense.gltf", MakeTiny(dense).dump())));
    ASSERT_EQ(got.skin.influence_offsets.size(), 5u);
    EXPECT_EQ(got.skin.influence_offsets[3] - got.skin.influence_offsets[2], 2u);
    // Rest of vertex 2 (raw (0,0,1)): 0.25 at the child (+1 in y) + 0.75 at the root.
    EXPECT_TRUE(got.positions_rest[2].isApprox(Eigen::Vector3f(0, 0.25f, 1)));
  }
  // Triangle indices (UNSIGNED_SHORT SCALAR, read as unsigned integers): index 5 becomes 0.
  {
    const uint16_t zero = 0;
    TinyOptions o;
    o.edit = [&](TinyGltf& t) {
      t.MakeSparse(t.j["meshes"][0]["primitives"][0]["indices"].get<int>(), {5}, 5121, &zero, 2);
    };
    const RawCharacter got = ImportOk(Write(dir, "indices.gltf", MakeTiny(o).dump()));
    EXPECT_EQ(got.triangles, (std::vector<Eigen::Vector3i>{{0, 1, 2}, {2, 1, 0}}));
  }
  // JOINTS_0 (UNSIGNED_BYTE VEC4): vertex 3 bound to joint 0 (the root) instead of joint 1.
  {
    const uint8_t j3[4] = {0, 0, 0, 0};
    TinyOptions o;
    o.edit = [&](TinyGltf& t) { t.MakeSparse(Attr(t, "JOINTS_0"), {3}, 5125, j3, 4); };
    const RawCharacter got = ImportOk(Write(dir, "joints.gltf", MakeTiny(o).dump()));
    ASSERT_EQ(got.vertex_count(), 4u);
    EXPECT_TRUE(got.positions_rest[3].isApprox(Eigen::Vector3f(1, 1, 1)));  // raw, the root is at the origin
    EXPECT_TRUE(got.positions_rest[2].isApprox(Eigen::Vector3f(0, 1, 1)));  // unchanged
  }
  // Inverse bind matrices (float MAT4): joint 1's IBM becomes a translation by (0, -1, 0), so
  // G_1 · IBM_1 = I and the rest positions are the raw ones.
  {
    std::vector<float> ibm(16, 0.0f);
    for (int i = 0; i < 4; ++i) ibm[5 * i] = 1.0f;
    ibm[13] = -1.0f;  // column-major: column 3, row 1
    TinyOptions o;
    o.edit = [&](TinyGltf& t) {
      t.MakeSparse(t.j["skins"][0]["inverseBindMatrices"].get<int>(), {1}, 5121, ibm.data(), 64);
    };
    const RawCharacter got = ImportOk(Write(dir, "ibm.gltf", MakeTiny(o).dump()));
    ASSERT_EQ(got.vertex_count(), 4u);
    for (int v = 0; v < 4; ++v) {
      EXPECT_TRUE(got.positions_rest[static_cast<size_t>(v)].isApprox(
          Eigen::Vector3f(kTinyPositions[3 * v], kTinyPositions[3 * v + 1], kTinyPositions[3 * v + 2])))
          << v;
    }
  }
  // Animation output (STEP translation, float VEC3): key 2 becomes (0, 3, 0).
  {
    const float key2[3] = {0, 3, 0};
    TinyOptions sparse;
    sparse.animations = true;
    sparse.edit = [&](TinyGltf& t) {
      t.MakeSparse(t.j["animations"][0]["samplers"][0]["output"].get<int>(), {2}, 5123, key2, 12);
    };
    TinyOptions dense;
    dense.animations = true;
    dense.step_out = {0, 0, 0, 0, 1, 0, 0, 3, 0};
    const RawCharacter got = ImportOk(Write(dir, "output.gltf", MakeTiny(sparse).dump()));
    ExpectSameCharacter(got, ImportOk(Write(dir, "output_dense.gltf", MakeTiny(dense).dump())));
    ASSERT_EQ(got.clips.size(), 1u);
    ASSERT_EQ(got.clips[0].tracks.size(), 2u);
    ASSERT_EQ(got.clips[0].tracks[1].translation.values.size(), 3u);
    EXPECT_EQ(got.clips[0].tracks[1].translation.values[2], Eigen::Vector3f(0, 3, 0));
  }
  // Animation input (key times, float SCALAR): the last key moves from 1 s to 2 s.
  {
    const float t2 = 2.0f;
    TinyOptions o;
    o.animations = true;
    o.edit = [&](TinyGltf& t) {
      t.MakeSparse(t.j["animations"][0]["samplers"][0]["input"].get<int>(), {2}, 5121, &t2, 4);
    };
    const RawCharacter got = ImportOk(Write(dir, "input.gltf", MakeTiny(o).dump()));
    ASSERT_EQ(got.clips.size(), 1u);
    EXPECT_FLOAT_EQ(got.clips[0].duration_s, 2.0f);
    ASSERT_EQ(got.clips[0].tracks.size(), 2u);
    EXPECT_EQ(got.clips[0].tracks[1].translation.times_s, (std::vector<float>{0.0f, 0.5f, 2.0f}));
  }
}

// A malformed sparse block on POSITION (accessor 0): kFormatRejected, like every other accessor
// problem of a mesh, naming the file, the accessor, "sparse" and the problem.
void ExpectSparseError(const std::filesystem::path& dir, const std::string& label,
                       const std::function<void(TinyGltf&)>& edit, const std::string& needle) {
  SCOPED_TRACE(label);
  TinyOptions o;
  o.edit = edit;
  const auto path = Write(dir, "bad_sparse.gltf", MakeTiny(o).dump());
  ExpectError(path, ErrorCode::kFormatRejected, needle);
  const auto r = ImportCharacter(path);
  if (!r.ok()) {
    EXPECT_NE(r.error().message.find("accessor 0"), std::string::npos) << r.error().message;
    EXPECT_NE(r.error().message.find("sparse"), std::string::npos) << r.error().message;
  }
}

TEST(ImporterSparse, EachMalformedSparseBlockGivesItsError) {
  const auto dir = test::TempDir("importer_sparse_bad");
  // A valid block on POSITION (vertices 1 and 3), then one thing broken per case.
  auto valid = [](TinyGltf& t) { t.MakeSparse(0, {1, 3}, 5123, kMoved.data(), kMoved.size() * 4); };
  auto with = [&](std::function<void(json & sparse, TinyGltf & t)> f) {
    return [valid, f](TinyGltf& t) {
      valid(t);
      f(t.j["accessors"][0]["sparse"], t);
    };
  };
  {
    TinyOptions o;
    o.edit = valid;
    ASSERT_TRUE(ImportCharacter(Write(dir, "valid.gltf", MakeTiny(o).dump())).ok());
  }
  ExpectSparseError(dir, "not an object", with([](json& s, TinyGltf&) { s = 3; }), "not an object");
  ExpectSparseError(dir, "no count", with([](json& s, TinyGltf&) { s.erase("count"); }), "no valid count");
  ExpectSparseError(dir, "count string", with([](json& s, TinyGltf&) { s["count"] = "2"; }), "no valid count");
  ExpectSparseError(dir, "count float", with([](json& s, TinyGltf&) { s["count"] = 2.5; }), "no valid count");
  ExpectSparseError(dir, "count 0", with([](json& s, TinyGltf&) { s["count"] = 0; }), "sparse count 0 is not in 1..4");
  ExpectSparseError(dir, "count -1", with([](json& s, TinyGltf&) { s["count"] = -1; }), "is not in 1..4");
  ExpectSparseError(dir, "count > accessor", with([](json& s, TinyGltf&) { s["count"] = 5; }),
                    "sparse count 5 is not in 1..4");
  ExpectSparseError(dir, "count 2^64-1",
                    with([](json& s, TinyGltf&) { s["count"] = std::numeric_limits<uint64_t>::max(); }),
                    "is not in 1..4");
  ExpectSparseError(dir, "no indices", with([](json& s, TinyGltf&) { s.erase("indices"); }),
                    "sparse indices are missing");
  ExpectSparseError(dir, "float indices", with([](json& s, TinyGltf&) { s["indices"]["componentType"] = 5126; }),
                    "componentType");
  ExpectSparseError(dir, "signed indices", with([](json& s, TinyGltf&) { s["indices"]["componentType"] = 5120; }),
                    "componentType");
  ExpectSparseError(dir, "no index type", with([](json& s, TinyGltf&) { s["indices"].erase("componentType"); }),
                    "componentType");
  ExpectSparseError(
      dir, "decreasing",
      [](TinyGltf& t) {
        t.MakeSparse(0, {3, 1}, 5123, kMoved.data(), 24);
      },
      "not strictly increasing");
  ExpectSparseError(
      dir, "duplicate",
      [](TinyGltf& t) {
        t.MakeSparse(0, {1, 1}, 5121, kMoved.data(), 24);
      },
      "not strictly increasing");
  ExpectSparseError(
      dir, "index = count",
      [](TinyGltf& t) {
        t.MakeSparse(0, {1, 4}, 5123, kMoved.data(), 24);
      },
      "sparse index 4 (entry 1) is out of range");
  ExpectSparseError(
      dir, "index 2^32-1",
      [](TinyGltf& t) {
        t.MakeSparse(0, {1, 0xFFFFFFFFu}, 5125, kMoved.data(), 24);
      },
      "out of range");
  ExpectSparseError(dir, "indices view 99", with([](json& s, TinyGltf&) { s["indices"]["bufferView"] = 99; }),
                    "bufferView 99 does not exist");
  ExpectSparseError(dir, "indices view -1", with([](json& s, TinyGltf&) { s["indices"]["bufferView"] = -1; }),
                    "does not exist");
  ExpectSparseError(dir, "indices view string", with([](json& s, TinyGltf&) { s["indices"]["bufferView"] = "0"; }),
                    "no valid bufferView");
  ExpectSparseError(dir, "indices no view", with([](json& s, TinyGltf&) { s["indices"].erase("bufferView"); }),
                    "no valid bufferView");
  ExpectSparseError(dir, "indices view too short",
                    with([](json& s, TinyGltf&) { s["indices"]["componentType"] = 5125; }),
                    "sparse indices (2 elements at byteOffset 0) runs past");
  ExpectSparseError(dir, "indices view outside buffer", with([](json& s, TinyGltf& t) {
                      t.j["bufferViews"][s["indices"]["bufferView"].get<size_t>()]["byteLength"] = 1000000;
                    }),
                    "lies outside its buffer");
  ExpectSparseError(dir, "indices strided", with([](json& s, TinyGltf& t) {
                      t.j["bufferViews"][s["indices"]["bufferView"].get<size_t>()]["byteStride"] = 4;
                    }),
                    "byteStride");
  ExpectSparseError(dir, "no values", with([](json& s, TinyGltf&) { s.erase("values"); }), "sparse values is missing");
  ExpectSparseError(dir, "values no view", with([](json& s, TinyGltf&) { s["values"].erase("bufferView"); }),
                    "no valid bufferView");
  ExpectSparseError(
      dir, "values view too short",
      [](TinyGltf& t) {
        t.MakeSparse(0, {1, 3}, 5123, kMoved.data(), 12);
      },
      "sparse values (2 elements at byteOffset 0) runs past");
  ExpectSparseError(dir, "values offset past", with([](json& s, TinyGltf&) { s["values"]["byteOffset"] = 4; }),
                    "runs past");
  ExpectSparseError(dir, "values offset huge",
                    with([](json& s, TinyGltf&) { s["values"]["byteOffset"] = 9223372036854775800ll; }), "runs past");
  ExpectSparseError(dir, "values offset 2^64-1",
                    with([](json& s, TinyGltf&) { s["values"]["byteOffset"] = std::numeric_limits<uint64_t>::max(); }),
                    "invalid byteOffset");
  ExpectSparseError(dir, "values offset negative", with([](json& s, TinyGltf&) { s["values"]["byteOffset"] = -12; }),
                    "invalid byteOffset");
  // Counts that would need gigabytes: a zero base is capped like any accessor without a
  // bufferView (count * size would wrap 64 bits in the first case); a sparse count is at most the
  // accessor's and must fit its indices bufferView (checked by division, no overflow).
  ExpectSparseError(
      dir, "huge count",
      [](TinyGltf& t) {
        t.j["accessors"][0].erase("bufferView");
        t.j["accessors"][0]["count"] = 6148914691236517206ll;
        t.MakeSparse(0, {1, 3}, 5123, kMoved.data(), 24);
        t.j["accessors"][0]["sparse"]["count"] = 6148914691236517206ll;
      },
      "sparse with no bufferView and an implausible count");
  ExpectSparseError(
      dir, "big zero base",
      [](TinyGltf& t) {
        t.j["accessors"][0].erase("bufferView");
        t.j["accessors"][0]["count"] = 268435456;
        t.MakeSparse(0, {1, 3}, 5123, kMoved.data(), 24);
      },
      "implausible count");
  ExpectSparseError(dir, "count past the indices", with([](json& s, TinyGltf& t) {
                      t.j["accessors"][0]["count"] = 4;
                      s["count"] = 4;
                    }),
                    "runs past");
  // In an animation sampler the same problem is an invalid clip (kInvalidData, as for any
  // accessor problem there), still naming "sparse".
  {
    TinyOptions o;
    o.animations = true;
    o.edit = [](TinyGltf& t) {
      const float keys[6] = {0, 3, 0, 0, 4, 0};
      t.MakeSparse(t.j["animations"][0]["samplers"][0]["output"].get<int>(), {2, 1}, 5123, keys, 24);
    };
    ExpectError(Write(dir, "bad_output.gltf", MakeTiny(o).dump()), ErrorCode::kInvalidData,
                "sparse indices are not strictly increasing");
  }
}

TEST(ImporterSparse, PrefixesAndFlippedBytesOfASparseGlbNeverCrash) {
  const auto dir = test::TempDir("importer_sparse_fuzz");
  TinyOptions o;
  o.animations = true;
  o.edit = [](TinyGltf& t) {
    const int a = Attr(t, "POSITION");
    t.j["accessors"][a].erase("bufferView");
    t.MakeSparse(a, {1, 2, 3}, 5121, kTinyPositions + 3, 36);
    const std::vector<float> w2 = {0.25f, 0.75f, 0, 0};
    t.MakeSparse(Attr(t, "WEIGHTS_0"), {2}, 5125, w2.data(), 16);
  };
  const std::string glb = ToGlb(MakeTiny(o));
  ASSERT_TRUE(ImportCharacter(Write(dir, "sparse.glb", glb)).ok());
  ExpectFuzzRefusedWithoutCrashing(dir, glb, 13);
}

}  // namespace
}  // namespace skinspheres::lib
