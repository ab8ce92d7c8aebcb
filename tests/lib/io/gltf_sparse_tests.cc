// Sparse accessors in ImportCharacter's glTF 2.0 reader (glTF 2.0 §3.6.2.3; the rest of the reader:
// gltf_reader_tests.cc). Oracle: the same tiny file written with the dense values imports
// identically (same floats in, so exactly equal), plus analytic expectations; malformed sparse
// blocks each give their error, and prefixes and flipped bytes never crash.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>
#include <random>

#include "lib/tiny_gltf.h"
#include "skinspheres/lib/io/importer.h"
#include "test_support.h"

namespace skinspheres::lib {
namespace {

using nlohmann::json;

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
