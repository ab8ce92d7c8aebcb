// Small glTF files written at test time, shared by the importer tests, the hostile-input tests
// and the fuzz seed corpus generator: a two-joint character with one skinned triangle pair
// (MakeTiny), its options, GLB packing (ToGlb) and a checked import expectation (ExpectError).
#pragma once

#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

#include "skinspheres/lib/io/importer.h"

namespace skinspheres::lib {

using nlohmann::json;

inline std::string Base64(const std::vector<uint8_t>& data) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (size_t i = 0; i < data.size(); i += 3) {
    uint32_t v = static_cast<uint32_t>(data[i]) << 16;
    if (i + 1 < data.size()) v |= static_cast<uint32_t>(data[i + 1]) << 8;
    if (i + 2 < data.size()) v |= data[i + 2];
    out += k[(v >> 18) & 63];
    out += k[(v >> 12) & 63];
    out += i + 1 < data.size() ? k[(v >> 6) & 63] : '=';
    out += i + 2 < data.size() ? k[v & 63] : '=';
  }
  return out;
}

struct TinyGltf {
  std::vector<uint8_t> bin;
  json j;
  int AddView(const void* data, size_t bytes, size_t stride = 0) {
    while (bin.size() % 4) bin.push_back(0);
    const size_t offset = bin.size();
    const auto* p = static_cast<const uint8_t*>(data);
    bin.insert(bin.end(), p, p + bytes);
    json view = {{"buffer", 0}, {"byteOffset", offset}, {"byteLength", bytes}};
    if (stride != 0) view["byteStride"] = stride;
    j["bufferViews"].push_back(view);
    return static_cast<int>(j["bufferViews"].size() - 1);
  }
  int AddAccessor(const void* data, size_t bytes, int component_type, const std::string& type, size_t count) {
    const int view = AddView(data, bytes);
    j["accessors"].push_back(
        {{"bufferView", view}, {"componentType", component_type}, {"type", type}, {"count", count}});
    return static_cast<int>(j["accessors"].size() - 1);
  }
  // Makes accessor `a` sparse (glTF §3.6.2.3): element indices[i] becomes the i-th element of
  // `values` (tightly packed, the accessor's type). Indices are stored as `index_type`
  // (5121/5123/5125) in their own bufferView; the values sit `values_offset` bytes into theirs.
  void MakeSparse(int a, const std::vector<uint32_t>& indices, int index_type, const void* values, size_t value_bytes,
                  size_t values_offset = 0) {
    const size_t size = index_type == 5121 ? 1 : index_type == 5123 ? 2 : 4;
    std::vector<uint8_t> packed;
    for (uint32_t i : indices)
      for (size_t b = 0; b < size; ++b) packed.push_back(static_cast<uint8_t>(i >> (8 * b)));  // little-endian
    const int index_view = AddView(packed.data(), packed.size());
    std::vector<uint8_t> value_bytes_at(values_offset, 0xEE);
    const auto* v = static_cast<const uint8_t*>(values);
    value_bytes_at.insert(value_bytes_at.end(), v, v + value_bytes);
    const int value_view = AddView(value_bytes_at.data(), value_bytes_at.size());
    j["accessors"][a]["sparse"] = {{"count", indices.size()},
                                   {"indices", {{"bufferView", index_view}, {"componentType", index_type}}},
                                   {"values", {{"bufferView", value_view}, {"byteOffset", values_offset}}}};
  }
  int Floats(const std::vector<float>& v, const std::string& type, int per) {
    return AddAccessor(v.data(), v.size() * 4, 5126, type, v.size() / static_cast<size_t>(per));
  }
  json Finish() {
    j["buffers"] =
        json::array({{{"byteLength", bin.size()}, {"uri", "data:application/octet-stream;base64," + Base64(bin)}}});
    return j;
  }
};

struct TinyOptions {
  float position_x0 = 0.0f;  // NaN to poison
  float weight = 1.0f;       // 0 for all-zero weights
  uint8_t joint = 1;         // >= 2 is out of range
  int mode = 4;              // 1 = lines (no triangles)
  bool skinned = true;
  bool animations = false;
  std::vector<float> positions;         // non-empty: replaces the 4 POSITION values (12 floats)
  std::vector<float> weights;           // non-empty: replaces WEIGHTS_0 (16 floats)
  std::vector<float> step_out;          // non-empty: replaces the STEP sampler's output (9 floats)
  std::function<void(TinyGltf&)> edit;  // last changes, before the buffer is encoded
};

inline constexpr float kTinyPositions[12] = {0, 0, 0, 1, 0, 0, 0, 0, 1, 1, 1, 1};  // with position_x0 as [0]

// Two joints (root at the origin, child raised by 1 in y), one skinned triangle bound to the
// child: rest positions are the raw positions + (0, 1, 0) (identity IBMs).
inline json MakeTiny(const TinyOptions& o) {
  TinyGltf t;
  t.j["asset"] = {{"version", "2.0"}};
  t.j["scene"] = 0;
  t.j["bufferViews"] = json::array();
  t.j["accessors"] = json::array();
  std::vector<float> positions(std::begin(kTinyPositions), std::end(kTinyPositions));
  positions[0] = o.position_x0;
  if (!o.positions.empty()) positions = o.positions;
  const int pos = t.Floats(positions, "VEC3", 3);
  json attrs = {{"POSITION", pos}};
  json prim;
  if (o.skinned) {
    const uint8_t joints[16] = {o.joint, 0, 0, 0, o.joint, 0, 0, 0, o.joint, 0, 0, 0, o.joint, 0, 0, 0};
    attrs["JOINTS_0"] = t.AddAccessor(joints, 16, 5121, "VEC4", 4);
    attrs["WEIGHTS_0"] = t.Floats(o.weights.empty() ? std::vector<float>{o.weight, 0, 0, 0, o.weight, 0, 0, 0, o.weight,
                                                                         0, 0, 0, o.weight, 0, 0, 0}
                                                    : o.weights,
                                  "VEC4", 4);
    std::vector<float> ibm;
    for (int k = 0; k < 2; ++k)
      for (int i = 0; i < 16; ++i) ibm.push_back(i % 5 == 0 ? 1.0f : 0.0f);
    const int ibm_acc = t.Floats(ibm, "MAT4", 16);
    t.j["skins"] = json::array({{{"joints", {0, 1}}, {"inverseBindMatrices", ibm_acc}}});
  }
  const uint16_t indices[6] = {0, 1, 2, 2, 1, 3};
  const int idx = t.AddAccessor(indices, 12, 5123, "SCALAR", 6);
  prim = {{"attributes", attrs}, {"indices", idx}, {"mode", o.mode}};
  t.j["meshes"] = json::array({{{"name", "tri"}, {"primitives", json::array({prim})}}});
  json mesh_node = {{"name", "body"}, {"mesh", 0}};
  if (o.skinned)
    mesh_node["skin"] = 0;
  else
    mesh_node["translation"] = {5, 0, 0};
  t.j["nodes"] =
      json::array({{{"name", "hips"}, {"children", {1}}}, {{"name", "spine"}, {"translation", {0, 1, 0}}}, mesh_node});
  t.j["scenes"] = json::array({{{"nodes", {0, 2}}}});
  if (o.animations) {
    const int times = t.Floats({0.0f, 0.5f, 1.0f}, "SCALAR", 1);
    const int step_out =
        t.Floats(o.step_out.empty() ? std::vector<float>{0, 0, 0, 0, 1, 0, 0, 2, 0} : o.step_out, "VEC3", 3);
    // CUBICSPLINE: (in-tangent, value, out-tangent) per key.
    std::vector<float> cubic;
    for (int k = 0; k < 3; ++k) {
      for (float v : {0.f, 0.f, 0.f, 1.f}) cubic.push_back(v);  // in-tangent
      for (float v : {0.f, 0.f, 0.f, 1.f}) cubic.push_back(v);  // value
      for (float v : {0.f, 0.f, 0.f, 1.f}) cubic.push_back(v);  // out-tangent
    }
    const int cubic_out = t.Floats(cubic, "VEC4", 4);
    t.j["animations"] = json::array(
        {{{"name", "wiggle"},
          {"samplers", json::array({{{"input", times}, {"output", step_out}, {"interpolation", "STEP"}},
                                    {{"input", times}, {"output", cubic_out}, {"interpolation", "CUBICSPLINE"}}})},
          {"channels", json::array({{{"sampler", 0}, {"target", {{"node", 1}, {"path", "translation"}}}},
                                    {{"sampler", 1}, {"target", {{"node", 0}, {"path", "rotation"}}}},
                                    {{"sampler", 0}, {"target", {{"node", 2}, {"path", "translation"}}}}})}}});
  }
  if (o.edit) o.edit(t);
  return t.Finish();
}

inline std::filesystem::path Write(const std::filesystem::path& dir, const std::string& name,
                                   const std::string& content) {
  const auto path = dir / name;
  std::ofstream(path, std::ios::binary) << content;
  return path;
}

inline std::string ToGlb(const json& gltf_with_data_uri) {
  // Move the data: buffer into a BIN chunk.
  json j = gltf_with_data_uri;
  const std::string uri = j["buffers"][0]["uri"];
  j["buffers"][0].erase("uri");
  std::string b64 = uri.substr(uri.find(',') + 1), bin;
  uint32_t acc = 0;
  int bits = 0;
  for (char ch : b64) {
    if (ch == '=') break;
    const int v =
        static_cast<int>(std::string("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/").find(ch));
    acc = (acc << 6) | static_cast<uint32_t>(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      bin.push_back(static_cast<char>((acc >> bits) & 0xFF));
    }
  }
  std::string text = j.dump();
  while (text.size() % 4) text.push_back(' ');
  while (bin.size() % 4) bin.push_back('\0');
  auto u32 = [](uint32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); };
  const uint32_t total = static_cast<uint32_t>(12 + 8 + text.size() + 8 + bin.size());
  return "glTF" + u32(2) + u32(total) + u32(static_cast<uint32_t>(text.size())) + "JSON" + text +
         u32(static_cast<uint32_t>(bin.size())) + std::string("BIN\0", 4) + bin;
}

inline void ExpectError(const std::filesystem::path& path, ErrorCode code, const std::string& needle = "") {
  const auto r = ImportCharacter(path);
  ASSERT_FALSE(r.ok()) << path << " imported";
  EXPECT_EQ(r.error().code, code) << r.error().message;
  EXPECT_NE(r.error().message.find(path.filename().string()), std::string::npos) << r.error().message;
  EXPECT_EQ(r.error().message.find('\n'), std::string::npos) << r.error().message;
  if (!needle.empty()) {
    EXPECT_NE(r.error().message.find(needle), std::string::npos) << r.error().message;
  }
}

// Every prefix of `glb` is refused naming the file; 300 random 4-byte flips (seeded) never crash,
// and any refusal names the file.
inline void ExpectFuzzRefusedWithoutCrashing(const std::filesystem::path& dir, const std::string& glb, unsigned seed) {
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

}  // namespace skinspheres::lib
