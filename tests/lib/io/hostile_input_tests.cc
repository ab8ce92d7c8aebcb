// Hostile input to the character readers: what a user (or an attacker) can hand ImportCharacter
// beyond a malformed file. Each case is a regression test for a crash, hang, unbounded read or
// silent acceptance found by probing or fuzzing; all files are generated here (tiny_gltf.h).
//
// Oracles: the error code and the one-line message naming the file and the problem; for the
// cases that used to hang or take quadratic time, the import runs on another thread and must
// finish within a minute (the fixed code takes milliseconds; the old one blocked forever or ran
// for minutes), so a regression fails instead of stalling CTest.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <functional>
#include <future>

#include "lib/tiny_gltf.h"
#include "skinspheres/lib/io/importer.h"
#include "test_support.h"

namespace skinspheres::lib {
namespace {

// Imports on another thread; fails (and unblocks a FIFO reader, if `fifo` is set) when it takes
// more than a minute.
Result<RawCharacter> ImportWithin60s(const std::filesystem::path& path, const std::filesystem::path& fifo = {}) {
  auto future = std::async(std::launch::async, [path] { return ImportCharacter(path); });
  if (future.wait_for(std::chrono::seconds(60)) != std::future_status::ready) {
    ADD_FAILURE() << path << ": import still running after 60 s (blocked or super-linear)";
    if (!fifo.empty()) {
      const int fd = ::open(fifo.c_str(), O_WRONLY);  // lets a reader blocked in open() go on
      if (fd >= 0) ::close(fd);
    }
  }
  return future.get();
}

void ExpectRefused(const Result<RawCharacter>& r, const std::filesystem::path& path, ErrorCode code,
                   const std::string& needle) {
  ASSERT_FALSE(r.ok()) << path << " imported";
  EXPECT_EQ(r.error().code, code) << r.error().message;
  EXPECT_EQ(r.error().message.rfind(path.string() + ": ", 0), 0u) << r.error().message;
  EXPECT_EQ(r.error().message.find('\n'), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find(needle), std::string::npos) << r.error().message;
}

TEST(HostileFiles, NonRegularFilesAreRefusedWithoutReading) {
  const auto dir = test::TempDir("hostile_files");
  const auto fifo = dir / "pipe.glb";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  ExpectRefused(ImportWithin60s(fifo, fifo), fifo, ErrorCode::kFileUnreadable, "FIFO");
  ExpectRefused(ImportWithin60s("/dev/zero"), "/dev/zero", ErrorCode::kFileUnreadable, "device");
  ExpectRefused(ImportWithin60s(dir), dir, ErrorCode::kFileUnreadable, "directory");
}

TEST(HostileFiles, AFileBeyondTheSizeLimitIsRefusedFromItsSize) {
  const auto path = test::TempDir("hostile_size") / "huge.glb";
  { std::ofstream(path, std::ios::binary) << "glTF"; }
  // A sparse file: no disk used, nothing read.
  ASSERT_EQ(::truncate(path.c_str(), static_cast<off_t>(kMaxCharacterFileBytes + 1)), 0);
  ExpectRefused(ImportWithin60s(path), path, ErrorCode::kFormatRejected, "may be at most 1073741824 bytes");
}

TEST(HostileFiles, ExternalBuffersMustBeRegularFiles) {
  const auto dir = test::TempDir("hostile_buffers");
  ASSERT_EQ(::mkfifo((dir / "pipe.bin").c_str(), 0600), 0);
  json j = MakeTiny({});
  j["buffers"][0]["uri"] = "pipe.bin";
  const auto path = Write(dir, "pipe_buffer.gltf", j.dump());
  ExpectRefused(ImportWithin60s(path, dir / "pipe.bin"), path, ErrorCode::kFileUnreadable, "FIFO");
  // A buffer file shorter than its byteLength: refused from its size.
  Write(dir, "short.bin", "abcd");
  j["buffers"][0]["uri"] = "short.bin";
  const auto short_path = Write(dir, "short_buffer.gltf", j.dump());
  ExpectRefused(ImportWithin60s(short_path), short_path, ErrorCode::kFormatRejected, "shorter than");
}

// ------------------------------------------------------------------------------------------
// Structure: recursion and super-linear work must not depend on the file.

TEST(HostileStructure, DeeplyNestedJsonIsRefusedBeforeParsing) {
  const auto dir = test::TempDir("hostile_deep_json");
  for (const size_t depth : {size_t{200}, size_t{100000}}) {
    std::string text = MakeTiny({}).dump();
    text.pop_back();  // the closing brace: append "extras" nested `depth` deep
    text += ",\"extras\":" + std::string(depth, '[') + std::string(depth, ']') + "}";
    const auto path = Write(dir, "deep.gltf", text);
    ExpectRefused(ImportWithin60s(path), path, ErrorCode::kFormatRejected,
                  "nests " + std::to_string(depth + 1) + " deep");
  }
  // The limit itself is fine: extras nested 120 deep import.
  std::string text = MakeTiny({}).dump();
  text.pop_back();
  text += ",\"extras\":" + std::string(120, '[') + std::string(120, ']') + "}";
  const auto ok = ImportWithin60s(Write(dir, "deep_ok.gltf", text));
  EXPECT_TRUE(ok.ok()) << ok.error().message;
}

// The tiny character with `n` empty nodes chained under joint 1 (`below`) or above the root joint.
json WithChain(int n, bool below) {
  TinyOptions o;
  o.edit = [n, below](TinyGltf& t) {
    json& nodes = t.j["nodes"];
    const int first = static_cast<int>(nodes.size());
    for (int k = 0; k < n; ++k) {
      json node = json::object();
      if (k + 1 < n) node["children"] = {first + k + 1};
      nodes.push_back(std::move(node));
    }
    if (below) {
      nodes[1]["children"] = {first};
    } else {
      nodes[first + n - 1]["children"] = {0};
      t.j["scenes"][0]["nodes"] = {first, 2};
    }
  };
  return MakeTiny(o);
}

TEST(HostileStructure, ADeepChainOfNodesImportsInLinearTime) {
  // 300,000 nodes under a joint: the old cycle check walked to the root from every node (over 30 s).
  const auto dir = test::TempDir("hostile_chain");
  const auto path = Write(dir, "chain.gltf", WithChain(300000, /*below=*/true).dump());
  const auto r = ImportWithin60s(path);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->skeleton.size(), 2u);  // the chain holds no joint: not part of the skeleton
  // A cycle anywhere in such a chain is still found.
  json cycle = WithChain(300000, true);
  cycle["nodes"][3 + 299999]["children"] = {3 + 1000};
  cycle["nodes"][1].erase("children");
  const auto cycle_path = Write(dir, "cycle.gltf", cycle.dump());
  ExpectRefused(ImportWithin60s(cycle_path), cycle_path, ErrorCode::kFormatRejected, "cycle");
}

TEST(HostileStructure, ASkeletonBeyondTheJointLimitIsRefused) {
  const auto dir = test::TempDir("hostile_joints");
  // 5,000 nodes above the root joint are all on its path: 5,002 joints.
  const auto path = Write(dir, "tall.gltf", WithChain(5000, /*below=*/false).dump());
  ExpectRefused(ImportWithin60s(path), path, ErrorCode::kInvalidData, "5002 joints");
  // 4,000 above: within the limit, imported.
  const auto r = ImportWithin60s(Write(dir, "tall_ok.gltf", WithChain(4000, false).dump()));
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->skeleton.size(), 4002u);
}

// ------------------------------------------------------------------------------------------
// glTF 2.0 rules the reader used to let through.

TEST(GltfRules, ANodeWithBothMatrixAndTrsIsRefused) {
  json j = MakeTiny({});
  j["nodes"][1]["matrix"] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 1, 0, 1};  // node 1 also has a translation
  const auto path = Write(test::TempDir("gltf_matrix_trs"), "matrix_trs.gltf", j.dump());
  ExpectError(path, ErrorCode::kFormatRejected, "node 1 has both a matrix and a translation");
  j["nodes"][1].erase("translation");
  EXPECT_TRUE(ImportCharacter(Write(path.parent_path(), "matrix_only.gltf", j.dump())).ok());
}

TEST(GltfRules, DuplicatedSkinJointsAreRefused) {
  json j = MakeTiny({});
  j["skins"][0]["joints"] = {0, 1, 1};
  ExpectError(Write(test::TempDir("gltf_dup_joints"), "dup.gltf", j.dump()), ErrorCode::kInvalidData,
              "skin 0 lists joint node 1 twice");
}

TEST(GltfRules, IntegerPropertiesMustBeIntegers) {
  // glTF 2.0 §5 (JSON schema): indices, counts, offsets, lengths and enums are integers. fuzz_gltf
  // found a byteLength of 8.9e23 (converting it to int64 was undefined behaviour); 3.5 used to be
  // truncated to 3 without a word.
  const auto dir = test::TempDir("gltf_integers");
  struct Case {
    std::function<void(json&)> edit;
    const char* needle;
  };
  const Case cases[] = {
      {[](json& j) { j["bufferViews"][0]["byteLength"] = 8.888888888888889e23; }, "\"byteLength\" is 8.88"},
      {[](json& j) { j["accessors"][0]["count"] = 3.5; }, "\"count\" is 3.5, not an integer"},
      {[](json& j) { j["accessors"][0]["componentType"] = "5126"; }, "\"componentType\" is \"5126\", not an integer"},
      {[](json& j) { j["nodes"][2]["mesh"] = 1e300; }, "\"mesh\" is 1e+300, not an integer"},
      {[](json& j) { j["nodes"][0]["children"] = {1.5}; }, "\"children\" lists 1.5, not an integer"},
      {[](json& j) {
         j["skins"][0]["joints"] = {0, -0.5};
       },
       "\"joints\" lists -0.5, not an integer"},
  };
  for (const Case& c : cases) {
    json j = MakeTiny({});
    c.edit(j);
    ExpectError(Write(dir, "float.gltf", j.dump()), ErrorCode::kFormatRejected, c.needle);
  }
  // A whole number written as a float is an integer by value (JSON Schema): 2.0 reads as 2.
  const auto reference = ImportCharacter(Write(dir, "reference.gltf", MakeTiny({}).dump()));
  ASSERT_TRUE(reference.ok()) << reference.error().message;
  json j = MakeTiny({});
  for (auto& a : j["accessors"]) a["count"] = static_cast<double>(a["count"].get<int64_t>());
  j["nodes"][2]["mesh"] = 0.0;
  const auto r = ImportCharacter(Write(dir, "whole.gltf", j.dump()));
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->positions_rest.size(), reference->positions_rest.size());
  EXPECT_EQ(r->triangles.size(), reference->triangles.size());
}

TEST(GltfRules, UnsupportedRequiredExtensionsAreRefused) {
  const auto dir = test::TempDir("gltf_extensions");
  for (const char* ext :
       {"KHR_draco_mesh_compression", "EXT_meshopt_compression", "EXT_mesh_gpu_instancing", "VENDOR_unknown"}) {
    json j = MakeTiny({});
    j["extensionsUsed"] = {ext};
    j["extensionsRequired"] = {ext};
    ExpectError(Write(dir, "required.gltf", j.dump()), ErrorCode::kFormatRejected,
                std::string("requires the glTF extension ") + ext + ", which is not supported");
    // Used but not required: the file loads (the extension's data is ignored).
    j.erase("extensionsRequired");
    EXPECT_TRUE(ImportCharacter(Write(dir, "used.gltf", j.dump())).ok()) << ext;
  }
  for (const char* ext : {"KHR_materials_unlit", "KHR_texture_transform", "KHR_mesh_quantization"}) {
    json j = MakeTiny({});
    j["extensionsUsed"] = {ext};
    j["extensionsRequired"] = {ext};
    const auto r = ImportCharacter(Write(dir, "supported.gltf", j.dump()));
    EXPECT_TRUE(r.ok()) << ext << ": " << r.error().message;
  }
}

TEST(GltfRules, KeyTimesMustBeStrictlyIncreasingFromZero) {
  const auto dir = test::TempDir("gltf_key_times");
  struct Case {
    std::vector<float> times;
    const char* needle;
  };
  for (const Case& c : {Case{{0.0f, 0.5f, 0.5f}, "not strictly increasing (key 2: 0.5"},
                        Case{{0.0f, 1.0f, 0.5f}, "not strictly increasing (key 2: 0.5"},
                        Case{{-1.0f, 0.0f, 1.0f}, "first key time is negative"}}) {
    TinyOptions o;
    o.animations = true;
    o.edit = [&c](TinyGltf& t) {
      const int times = t.Floats(c.times, "SCALAR", 1);
      for (auto& s : t.j["animations"][0]["samplers"]) s["input"] = times;
    };
    ExpectError(Write(dir, "times.gltf", MakeTiny(o).dump()), ErrorCode::kInvalidData, c.needle);
  }
}

TEST(GltfRules, ATargetAnimatedTwiceOrAMatrixNodeAnimatedIsRefused) {
  const auto dir = test::TempDir("gltf_targets");
  TinyOptions twice;
  twice.animations = true;
  twice.edit = [](TinyGltf& t) {
    t.j["animations"][0]["channels"].push_back({{"sampler", 0}, {"target", {{"node", 1}, {"path", "translation"}}}});
  };
  ExpectError(Write(dir, "twice.gltf", MakeTiny(twice).dump()), ErrorCode::kInvalidData,
              "animates node 1 translation twice");
  TinyOptions matrix;
  matrix.animations = true;
  matrix.edit = [](TinyGltf& t) {
    t.j["nodes"][1].erase("translation");
    t.j["nodes"][1]["matrix"] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 1, 0, 1};
  };
  ExpectError(Write(dir, "matrix.gltf", MakeTiny(matrix).dump()), ErrorCode::kInvalidData,
              "animates the translation of node 1, which has a matrix");
}

}  // namespace
}  // namespace skinspheres::lib
