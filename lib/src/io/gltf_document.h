// Private to the importer: a glTF 2.0 document (.gltf with external or data: buffers, or .glb)
// and typed reads of its accessors, bounds-checked against the buffers (untrusted input): the
// document in gltf_document.cc, the accessors in gltf_accessors.cc.
// Dense and sparse accessors (glTF 2.0 §3.6.2.3) are both read: a sparse accessor is
// materialised (base bufferView elements, or zeros without one, then element indices[i] replaced
// by values[i]); a malformed sparse block is an error naming the accessor and "sparse".
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "skinspheres/runtime/error.h"

namespace skinspheres::lib::detail {

struct GltfDocument {
  nlohmann::json json;
  std::vector<std::vector<uint8_t>> buffers;  // one per json["buffers"] entry
};

// Thrown by Integer(): a property glTF defines as an integer (an index, count, offset, length,
// stride or enum; glTF 2.0 §5 and its JSON schema) holds something else, e.g. 3.5, 1e24 or a
// string. The importers report it as the file's one-line error. Converting such a value with
// nlohmann's get<int64_t>() would truncate it silently, or be undefined behaviour out of range.
struct NotAnInteger : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// obj[key] as an integer: `fallback` when absent; throws NotAnInteger when present and not a JSON
// integer. An unsigned value above INT64_MAX gives -1 (every caller refuses negative values).
int64_t Integer(const nlohmann::json& obj, const char* key, int64_t fallback);
// `v`, an element of the array `array_name`, as an integer (NotAnInteger when it is not one).
int64_t Integer(const nlohmann::json& v, const char* array_name);
// obj[key] as an integer into *out without throwing: false when present but not an integer
// (absent gives `fallback`).
bool IntField(const nlohmann::json& obj, const char* key, int64_t fallback, int64_t* out);

// Parses `bytes` (the whole file): GLB = 12-byte header + JSON chunk + optional BIN chunk;
// otherwise JSON text. Buffers come from the BIN chunk, base64 data: URIs or files next to
// `file`. Errors name the file: kFormatRejected (bad header, truncated, bad JSON, missing or
// short buffer), kFileUnreadable (an external buffer file that cannot be read).
Result<GltfDocument> LoadGltf(const std::filesystem::path& file, std::span<const uint8_t> bytes);

// Reads accessor `index` into `out` as count * components floats (normalised integers scaled
// to [0,1] / [-1,1] as glTF defines, other integers converted). `components` must match the
// accessor's type (SCALAR 1, VEC2 2, VEC3 3, VEC4 4, MAT4 16). Sparse accessors are applied:
// sparse.count in 1..count, indices UNSIGNED_BYTE/SHORT/INT strictly increasing and < count,
// indices and values tightly packed inside their bufferViews (else an error). Without a
// bufferView (zeros, sparse or not) count is capped at 2^20 so a tiny file cannot ask for gigabytes.
// Returns an empty string on success, else the problem (without the file name).
std::string ReadAccessorFloats(const GltfDocument& doc, int64_t index, int components, std::vector<float>* out);
// Same for unsigned integer accessors (indices, JOINTS_n): UNSIGNED_BYTE/SHORT/INT only
// (sparse ones included).
std::string ReadAccessorUints(const GltfDocument& doc, int64_t index, int components, std::vector<uint32_t>* out);
// The accessor's element count, or -1 when `index` is not a valid accessor.
int64_t AccessorCount(const GltfDocument& doc, int64_t index);

}  // namespace skinspheres::lib::detail
