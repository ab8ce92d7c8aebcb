// glTF 2.0 container and accessor reading (spec sections 3.6 "Binary data storage" and 4.4 GLB).
// Everything here treats the file as untrusted: every offset, stride and count is checked
// against the buffer it points into before a byte is read.
#include "gltf_document.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <memory>
#include <optional>

#include "skinspheres/lib/io/importer.h"
#include "skinspheres/runtime/format/file_io.h"
#include "skinspheres/runtime/format/json_shape.h"

namespace skinspheres::lib::detail {
namespace {

using nlohmann::json;

constexpr uint32_t kGlbMagic = 0x46546C67;   // "glTF"
constexpr uint32_t kChunkJson = 0x4E4F534A;  // "JSON"
constexpr uint32_t kChunkBin = 0x004E4942;   // "BIN\0"

Error Fail(ErrorCode code, const std::filesystem::path& file, const std::string& problem) {
  return MakeError(code, file.string() + ": " + problem);
}

uint32_t ReadU32(const uint8_t* p) {
  uint32_t v;
  std::memcpy(&v, p, 4);
  return v;  // GLB is little-endian, as is every platform we build for
}

// RFC 4648 base64; whitespace ignored, stops at '='. False on any other character.
bool DecodeBase64(std::string_view in, std::vector<uint8_t>* out) {
  out->clear();
  out->reserve(in.size() / 4 * 3);
  uint32_t acc = 0;
  int bits = 0;
  for (char c : in) {
    int v;
    if (c >= 'A' && c <= 'Z')
      v = c - 'A';
    else if (c >= 'a' && c <= 'z')
      v = c - 'a' + 26;
    else if (c >= '0' && c <= '9')
      v = c - '0' + 52;
    else if (c == '+' || c == '-')
      v = 62;
    else if (c == '/' || c == '_')
      v = 63;
    else if (c == '=')
      break;
    else if (c == ' ' || c == '\n' || c == '\r' || c == '\t')
      continue;
    else
      return false;
    acc = (acc << 6) | static_cast<uint32_t>(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out->push_back(static_cast<uint8_t>((acc >> bits) & 0xFF));
    }
  }
  return true;
}

std::string PercentDecode(const std::string& s) {
  std::string out;
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '%' && i + 2 < s.size() && std::isxdigit(static_cast<unsigned char>(s[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(s[i + 2]))) {
      out.push_back(static_cast<char>(std::stoi(s.substr(i + 1, 2), nullptr, 16)));
      i += 2;
    } else {
      out.push_back(s[i]);
    }
  }
  return out;
}

// Extensions a file may require of this reader (see LoadGltf): they change only what it does not
// read, or (KHR_mesh_quantization) allow integer attributes, which it converts.
bool IsIgnorableOrReadExtension(const std::string& ext) {
  static const char* const kExact[] = {"KHR_mesh_quantization", "KHR_texture_transform", "KHR_texture_basisu",
                                       "EXT_texture_webp",      "EXT_texture_avif",      "KHR_lights_punctual",
                                       "KHR_xmp_json_ld",       "MSFT_texture_dds"};
  for (const char* e : kExact) {
    if (ext == e) return true;
  }
  return ext.rfind("KHR_materials_", 0) == 0;  // every material extension (variants included)
}

int ComponentsOf(const std::string& type) {
  if (type == "SCALAR") return 1;
  if (type == "VEC2") return 2;
  if (type == "VEC3") return 3;
  if (type == "VEC4") return 4;
  if (type == "MAT2") return 4;
  if (type == "MAT3") return 9;
  if (type == "MAT4") return 16;
  return 0;
}

int ComponentSize(int component_type) {
  switch (component_type) {
    case 5120:
    case 5121: return 1;  // BYTE, UNSIGNED_BYTE
    case 5122:
    case 5123: return 2;  // SHORT, UNSIGNED_SHORT
    case 5125:
    case 5126: return 4;  // UNSIGNED_INT, FLOAT
    default: return 0;
  }
}

template <typename T>
T Load(const uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return v;
}

// A validated view of one accessor: element e, component c is at base + e * stride + c * size.
// Dense accessors point straight into the document's buffers (zero copy); sparse accessors are
// materialised into `owned` (tightly packed) and `base` points into it, so a copy of the view
// keeps its bytes alive.
struct AccessorView {
  const uint8_t* base = nullptr;  // nullptr: no bufferView and not sparse, all zeros (glTF 3.6.2.3)
  uint64_t count = 0;
  uint64_t stride = 0;
  int components = 0;
  int component_type = 0;
  bool normalized = false;
  std::shared_ptr<const std::vector<uint8_t>> owned;  // the materialised sparse accessor, else empty
};

// An accessor may ask for this many elements without a bufferView (all zeros, or a sparse
// accessor's zero base): a 200-byte file must not allocate gigabytes.
constexpr uint64_t kMaxZeroFilledCount = uint64_t{1} << 20;

// `v` as an integer when it is one: a JSON integer (an unsigned one above INT64_MAX gives -1), or
// a number with no fractional part within int64 (glTF's schema says "integer", which JSON Schema
// 2020-12 defines by value: 2.0 is one, 2.5 and 1e24 are not).
std::optional<int64_t> AsInteger(const json& v) {
  if (v.is_number_float()) {
    const double d = v.get<double>();
    if (!(d >= -0x1p63 && d < 0x1p63) || d != std::trunc(d)) return std::nullopt;  // NaN fails too
    return static_cast<int64_t>(d);
  }
  if (!v.is_number_integer()) return std::nullopt;
  return v.is_number_unsigned() && v.get<uint64_t>() > static_cast<uint64_t>(std::numeric_limits<int64_t>::max())
             ? -1
             : v.get<int64_t>();
}

// `key` of `obj` as an integer: false when present but not an integer (absent gives `fallback`).
bool IntField(const json& obj, const char* key, int64_t fallback, int64_t* out) {
  if (!obj.contains(key)) {
    *out = fallback;
    return true;
  }
  const std::optional<int64_t> v = AsInteger(obj[key]);
  if (!v) return false;
  *out = *v;
  return true;
}

// The bytes of bufferView `bv_index` (checked to lie inside its buffer) and its byteStride (0
// when absent). Returns the problem, empty on success.
std::string OpenBufferView(const GltfDocument& doc, int64_t bv_index, std::span<const uint8_t>* bytes,
                           int64_t* stride) {
  const json& j = doc.json;
  if (!j.contains("bufferViews") || !j["bufferViews"].is_array() || bv_index < 0 ||
      bv_index >= static_cast<int64_t>(j["bufferViews"].size())) {
    return "bufferView " + std::to_string(bv_index) + " does not exist";
  }
  const json& bv = j["bufferViews"][static_cast<size_t>(bv_index)];
  const int64_t buffer = Integer(bv, "buffer", -1);
  if (buffer < 0 || buffer >= static_cast<int64_t>(doc.buffers.size())) {
    return "bufferView " + std::to_string(bv_index) + " uses buffer " + std::to_string(buffer) +
           ", which does not exist";
  }
  const std::vector<uint8_t>& data = doc.buffers[static_cast<size_t>(buffer)];
  const int64_t bv_offset = Integer(bv, "byteOffset", 0);
  const int64_t bv_length = Integer(bv, "byteLength", -1);
  *stride = Integer(bv, "byteStride", 0);
  if (bv_offset < 0 || bv_length < 0 || *stride < 0 || static_cast<uint64_t>(bv_offset) > data.size() ||
      static_cast<uint64_t>(bv_length) > data.size() - static_cast<uint64_t>(bv_offset)) {
    return "bufferView " + std::to_string(bv_index) + " lies outside its buffer (" + std::to_string(data.size()) +
           " bytes)";
  }
  *bytes = std::span<const uint8_t>(data.data() + bv_offset, static_cast<size_t>(bv_length));
  return {};
}

// One tightly packed array of a sparse block (`what` is "indices" or "values"): `count`
// elements of `elem_size` bytes at sparse.<what>.byteOffset in sparse.<what>.bufferView.
std::string OpenSparseArray(const GltfDocument& doc, const json& sparse, const std::string& name, const char* what,
                            uint64_t count, uint64_t elem_size, const uint8_t** out) {
  const std::string label = name + " sparse " + what;
  if (!sparse.contains(what) || !sparse[what].is_object()) return label + " is missing (or not an object)";
  const json& s = sparse[what];
  int64_t bv_index = -1, offset = 0;
  if (!s.contains("bufferView") || !IntField(s, "bufferView", -1, &bv_index)) {
    return label + " has no valid bufferView";
  }
  if (!IntField(s, "byteOffset", 0, &offset) || offset < 0) return label + " has an invalid byteOffset";
  std::span<const uint8_t> bytes;
  int64_t stride = 0;
  if (std::string p = OpenBufferView(doc, bv_index, &bytes, &stride); !p.empty()) return label + ": " + p;
  // glTF: these bufferViews MUST NOT define byteStride; one equal to the packed size is harmless.
  if (stride != 0 && static_cast<uint64_t>(stride) != elem_size) {
    return label + " bufferView " + std::to_string(bv_index) + " has a byteStride (sparse data must be tightly packed)";
  }
  // offset + count * elem_size <= length, by division so a huge count cannot wrap the product.
  const uint64_t avail = bytes.size(), off = static_cast<uint64_t>(offset);
  if (off > avail || count > (avail - off) / elem_size) {
    return label + " (" + std::to_string(count) + " elements at byteOffset " + std::to_string(off) +
           ") runs past the end of bufferView " + std::to_string(bv_index);
  }
  *out = bytes.data() + off;
  return {};
}

// glTF 3.6.2.3: copies the base elements (or zeros) into a tightly packed buffer and substitutes
// element indices[i] by values[i]. `view` is the validated dense part (base may be nullptr).
std::string MaterialiseSparse(const GltfDocument& doc, const json& a, const std::string& name, AccessorView* view) {
  const json& sparse = a["sparse"];
  if (!sparse.is_object()) return name + " has a sparse entry that is not an object";
  int64_t count = -1;
  if (!sparse.contains("count") || !IntField(sparse, "count", -1, &count))
    return name + " sparse block has no valid count";
  if (count < 1 || static_cast<uint64_t>(count) > view->count) {
    return name + " sparse count " + std::to_string(count) + " is not in 1.." + std::to_string(view->count) +
           " (the accessor's count)";
  }
  const uint64_t n = static_cast<uint64_t>(count);
  if (!sparse.contains("indices") || !sparse["indices"].is_object())
    return name + " sparse indices are missing (or not an object)";
  int64_t index_type = 0;
  if (!IntField(sparse["indices"], "componentType", 0, &index_type) ||
      (index_type != 5121 && index_type != 5123 && index_type != 5125)) {
    return name + " sparse indices have no valid componentType (UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT)";
  }
  const uint64_t index_size = static_cast<uint64_t>(ComponentSize(static_cast<int>(index_type)));
  const uint64_t elem_size =
      static_cast<uint64_t>(ComponentSize(view->component_type)) * static_cast<uint64_t>(view->components);
  const uint8_t* indices = nullptr;
  const uint8_t* values = nullptr;
  if (std::string p = OpenSparseArray(doc, sparse, name, "indices", n, index_size, &indices); !p.empty()) return p;
  if (std::string p = OpenSparseArray(doc, sparse, name, "values", n, elem_size, &values); !p.empty()) return p;

  // The dense base is bounded by the file (it lies in a bufferView) or by kMaxZeroFilledCount.
  auto owned = std::make_shared<std::vector<uint8_t>>(view->count * elem_size, uint8_t{0});
  if (view->base != nullptr) {
    for (uint64_t e = 0; e < view->count; ++e)
      std::memcpy(owned->data() + e * elem_size, view->base + e * view->stride, elem_size);
  }
  uint64_t previous = 0;
  for (uint64_t i = 0; i < n; ++i) {
    const uint8_t* q = indices + i * index_size;
    const uint64_t target = index_type == 5121   ? Load<uint8_t>(q)
                            : index_type == 5123 ? Load<uint16_t>(q)
                                                 : Load<uint32_t>(q);
    if (target >= view->count) {
      return name + " sparse index " + std::to_string(target) + " (entry " + std::to_string(i) +
             ") is out of range (count " + std::to_string(view->count) + ")";
    }
    if (i > 0 && target <= previous) {
      return name + " sparse indices are not strictly increasing (entry " + std::to_string(i) + ": " +
             std::to_string(target) + " after " + std::to_string(previous) + ")";
    }
    previous = target;
    std::memcpy(owned->data() + target * elem_size, values + i * elem_size, elem_size);
  }
  view->base = owned->data();
  view->stride = elem_size;
  view->owned = std::move(owned);
  return {};
}

std::string OpenAccessor(const GltfDocument& doc, int64_t index, int components, AccessorView* view) {
  const json& j = doc.json;
  const std::string name = "accessor " + std::to_string(index);
  if (!j.contains("accessors") || !j["accessors"].is_array() || index < 0 ||
      index >= static_cast<int64_t>(j["accessors"].size())) {
    return "accessor index " + std::to_string(index) + " is out of range";
  }
  const json& a = j["accessors"][static_cast<size_t>(index)];
  const bool sparse = a.contains("sparse");
  const int type_components = ComponentsOf(a.value("type", std::string()));
  if (type_components != components) {
    return name + " has type " + a.value("type", std::string("?")) + ", expected " + std::to_string(components) +
           " component(s)";
  }
  const int64_t component_type = Integer(a, "componentType", 0);
  view->component_type = component_type > 0 && component_type <= 0xffff ? static_cast<int>(component_type) : 0;
  const int csize = ComponentSize(view->component_type);
  if (csize == 0) return name + " has an unknown componentType " + std::to_string(view->component_type);
  const int64_t count = Integer(a, "count", -1);
  if (count < 0) return name + " has no valid count";
  view->count = static_cast<uint64_t>(count);
  view->components = components;
  view->normalized = a.value("normalized", false);
  const uint64_t elem_size = static_cast<uint64_t>(csize) * static_cast<uint64_t>(components);
  if (!a.contains("bufferView")) {
    // All zeros (then the sparse substitutions, if any). Cap it so a 200-byte file cannot ask for gigabytes.
    if (view->count > kMaxZeroFilledCount) {
      return name + (sparse ? " is sparse with" : " has") + " no bufferView and an implausible count";
    }
    view->base = nullptr;
    view->stride = elem_size;
    return sparse ? MaterialiseSparse(doc, a, name, view) : std::string();
  }
  const int64_t bv_index = Integer(a, "bufferView", -1);
  std::span<const uint8_t> bytes;
  int64_t stride = 0;
  if (std::string p = OpenBufferView(doc, bv_index, &bytes, &stride); !p.empty()) return name + ": " + p;
  const int64_t acc_offset = Integer(a, "byteOffset", 0);
  if (acc_offset < 0) return name + " has a negative byteOffset";
  view->stride = stride > 0 ? static_cast<uint64_t>(stride) : elem_size;
  if (view->stride > 4096) return "bufferView " + std::to_string(bv_index) + " has an implausible byteStride";
  // glTF 3.6.2.4: elements must not overlap (a stride below the element size would read each
  // byte many times over, and make a sparse copy many times the file's size).
  if (view->stride < elem_size) {
    return name + ": bufferView " + std::to_string(bv_index) + " has a byteStride of " + std::to_string(view->stride) +
           ", below the " + std::to_string(elem_size) + "-byte element";
  }
  // (count - 1) * stride + size must fit after the accessor's offset; checked by division so a
  // huge count cannot wrap the product around.
  const uint64_t avail = bytes.size(), off = static_cast<uint64_t>(acc_offset);
  const bool fits =
      off <= avail &&
      (view->count == 0 || (elem_size <= avail - off && view->count - 1 <= (avail - off - elem_size) / view->stride));
  if (!fits) {
    return name + " (" + std::to_string(view->count) + " elements) runs past the end of bufferView " +
           std::to_string(bv_index);
  }
  // Checked before anything is read: a byte accessor becomes 4x its size in floats. (Without a
  // bufferView, kMaxZeroFilledCount is far below this.)
  if (view->count > kMaxAccessorValues / static_cast<uint64_t>(components)) {
    return name + " has " + std::to_string(view->count) + " elements; at most " + std::to_string(kMaxAccessorValues) +
           " values are read from one accessor";
  }
  view->base = bytes.data() + off;
  return sparse ? MaterialiseSparse(doc, a, name, view) : std::string();
}

float ComponentAsFloat(const uint8_t* p, int type, bool normalized) {
  switch (type) {
    case 5120: {
      const float v = Load<int8_t>(p);
      return normalized ? std::max(v / 127.0f, -1.0f) : v;
    }
    case 5121: {
      const float v = Load<uint8_t>(p);
      return normalized ? v / 255.0f : v;
    }
    case 5122: {
      const float v = Load<int16_t>(p);
      return normalized ? std::max(v / 32767.0f, -1.0f) : v;
    }
    case 5123: {
      const float v = Load<uint16_t>(p);
      return normalized ? v / 65535.0f : v;
    }
    case 5125: return static_cast<float>(Load<uint32_t>(p));
    default: return Load<float>(p);
  }
}

}  // namespace

int64_t AccessorCount(const GltfDocument& doc, int64_t index) {
  const json& j = doc.json;
  if (!j.contains("accessors") || index < 0 || index >= static_cast<int64_t>(j["accessors"].size())) return -1;
  return Integer(j["accessors"][static_cast<size_t>(index)], "count", -1);
}

std::string ReadAccessorFloats(const GltfDocument& doc, int64_t index, int components, std::vector<float>* out) {
  AccessorView v;
  if (std::string problem = OpenAccessor(doc, index, components, &v); !problem.empty()) return problem;
  out->assign(v.count * static_cast<uint64_t>(components), 0.0f);
  if (v.base == nullptr) return {};
  const int csize = ComponentSize(v.component_type);
  for (uint64_t e = 0; e < v.count; ++e) {
    const uint8_t* p = v.base + e * v.stride;
    for (int c = 0; c < components; ++c) {
      (*out)[e * components + c] = ComponentAsFloat(p + c * csize, v.component_type, v.normalized);
    }
  }
  return {};
}

std::string ReadAccessorUints(const GltfDocument& doc, int64_t index, int components, std::vector<uint32_t>* out) {
  AccessorView v;
  if (std::string problem = OpenAccessor(doc, index, components, &v); !problem.empty()) return problem;
  if (v.component_type != 5121 && v.component_type != 5123 && v.component_type != 5125) {
    return "accessor " + std::to_string(index) + " should hold unsigned integers, has componentType " +
           std::to_string(v.component_type);
  }
  out->assign(v.count * static_cast<uint64_t>(components), 0u);
  if (v.base == nullptr) return {};
  const int csize = ComponentSize(v.component_type);
  for (uint64_t e = 0; e < v.count; ++e) {
    const uint8_t* p = v.base + e * v.stride;
    for (int c = 0; c < components; ++c) {
      const uint8_t* q = p + c * csize;
      (*out)[e * components + c] = v.component_type == 5121   ? Load<uint8_t>(q)
                                   : v.component_type == 5123 ? Load<uint16_t>(q)
                                                              : Load<uint32_t>(q);
    }
  }
  return {};
}

// Over the function-size limit of .clang-tidy: to be split into one stage per section of the file.
// NOLINTNEXTLINE(readability-function-size)
Result<GltfDocument> LoadGltf(const std::filesystem::path& file, std::span<const uint8_t> bytes) {
  GltfDocument doc;
  std::span<const uint8_t> json_text = bytes;
  std::span<const uint8_t> bin;
  bool has_bin = false;
  if (bytes.size() >= 4 && ReadU32(bytes.data()) == kGlbMagic) {
    if (bytes.size() < 20)
      return Fail(ErrorCode::kFormatRejected, file,
                  "truncated GLB: shorter than its 12-byte header and first chunk header");
    const uint32_t version = ReadU32(bytes.data() + 4);
    const uint32_t length = ReadU32(bytes.data() + 8);
    if (version != 2)
      return Fail(ErrorCode::kFormatRejected, file, "GLB version " + std::to_string(version) + " (only 2 is read)");
    if (length > bytes.size()) {
      return Fail(ErrorCode::kFormatRejected, file,
                  "truncated GLB: header says " + std::to_string(length) + " bytes, the file has " +
                      std::to_string(bytes.size()));
    }
    size_t at = 12;
    bool first = true;
    while (at + 8 <= length) {
      const uint32_t chunk_length = ReadU32(bytes.data() + at);
      const uint32_t chunk_type = ReadU32(bytes.data() + at + 4);
      if (static_cast<uint64_t>(at) + 8 + chunk_length > length) {
        return Fail(ErrorCode::kFormatRejected, file, "truncated GLB: a chunk runs past the end of the file");
      }
      const std::span<const uint8_t> chunk = bytes.subspan(at + 8, chunk_length);
      if (first && chunk_type != kChunkJson)
        return Fail(ErrorCode::kFormatRejected, file, "GLB does not start with a JSON chunk");
      if (first)
        json_text = chunk;
      else if (chunk_type == kChunkBin && !has_bin) {
        bin = chunk;
        has_bin = true;
      }
      first = false;
      at += 8 + ((chunk_length + 3u) & ~3u);
    }
    if (first) return Fail(ErrorCode::kFormatRejected, file, "truncated GLB: no JSON chunk");
  }
  // Depth and size before parsing (runtime/file_io.h): the parse is iterative, but a copy or a
  // dump of a deep value is not, and a value costs ~100 bytes once parsed.
  const runtime::JsonShape shape =
      runtime::ScanJson(std::string_view(reinterpret_cast<const char*>(json_text.data()), json_text.size()));
  if (shape.depth > runtime::kMaxJsonDepth) {
    return Fail(ErrorCode::kFormatRejected, file,
                "the JSON nests " + std::to_string(shape.depth) + " deep (at most " +
                    std::to_string(runtime::kMaxJsonDepth) + " is read)");
  }
  if (shape.values > kMaxGltfJsonValues) {
    return Fail(
        ErrorCode::kFormatRejected, file,
        "the JSON holds more than " + std::to_string(kMaxGltfJsonValues) + " values (at most that many are read)");
  }
  doc.json = json::parse(json_text.begin(), json_text.end(), nullptr, /*allow_exceptions=*/false);
  if (doc.json.is_discarded() || !doc.json.is_object()) {
    return Fail(ErrorCode::kFormatRejected, file, "not a glTF file (the JSON does not parse)");
  }
  if (!doc.json.contains("asset")) return Fail(ErrorCode::kFormatRejected, file, "not a glTF file (no \"asset\")");
  const std::string version = doc.json["asset"].value("version", std::string());
  if (version.empty() || version[0] != '2') {
    return Fail(ErrorCode::kFormatRejected, file, "glTF version \"" + version + "\" (only 2.x is read)");
  }
  // glTF 2.0 §3.12: a loader MUST NOT load an asset that requires an extension it does not
  // support. This reader supports the extensions that change nothing it reads (materials,
  // textures, lights, metadata) and KHR_mesh_quantization (integer attributes, which every
  // accessor read here converts); any other (Draco or meshopt compression, GPU instancing,
  // animation pointers, ...) refuses the file.
  if (doc.json.contains("extensionsRequired")) {
    const json& required = doc.json["extensionsRequired"];
    if (!required.is_array()) return Fail(ErrorCode::kFormatRejected, file, "\"extensionsRequired\" is not an array");
    for (const auto& e : required) {
      if (!e.is_string()) return Fail(ErrorCode::kFormatRejected, file, "\"extensionsRequired\" lists a non-string");
      const std::string ext = e.get<std::string>();
      if (!IsIgnorableOrReadExtension(ext)) {
        return Fail(ErrorCode::kFormatRejected, file,
                    "requires the glTF extension " + ext + ", which is not supported");
      }
    }
  }
  if (doc.json.contains("buffers")) {
    const json& buffers = doc.json["buffers"];
    if (!buffers.is_array()) return Fail(ErrorCode::kFormatRejected, file, "\"buffers\" is not an array");
    uint64_t external_bytes = 0;
    for (size_t b = 0; b < buffers.size(); ++b) {
      const int64_t length = Integer(buffers[b], "byteLength", -1);
      std::vector<uint8_t> data;
      const std::string label = "buffer " + std::to_string(b);
      if (!buffers[b].contains("uri")) {
        if (b != 0 || !has_bin)
          return Fail(ErrorCode::kFormatRejected, file, label + " has no uri and there is no GLB BIN chunk");
        data.assign(bin.begin(), bin.end());
      } else {
        const std::string uri = buffers[b]["uri"].get<std::string>();
        if (uri.rfind("data:", 0) == 0) {
          const size_t comma = uri.find(";base64,");
          if (comma == std::string::npos || !DecodeBase64(std::string_view(uri).substr(comma + 8), &data)) {
            return Fail(ErrorCode::kFormatRejected, file, label + " has a data: uri that is not valid base64");
          }
        } else {
          // Only a regular file beside (or below) the glTF, never a device, a pipe or "..": a
          // file must not make the reader hang or read elsewhere.
          const std::filesystem::path relative = std::filesystem::path(PercentDecode(uri)).lexically_normal();
          if (relative.is_absolute() || relative.empty() || *relative.begin() == "..") {
            return Fail(ErrorCode::kFormatRejected, file, label + " uri \"" + uri + "\" is not a path beside the file");
          }
          const std::filesystem::path external = file.parent_path() / relative;
          if (length < 0) return Fail(ErrorCode::kFormatRejected, file, label + " has no valid byteLength");
          external_bytes += static_cast<uint64_t>(length);
          if (external_bytes > kMaxGltfExternalBufferBytes) {
            return Fail(
                ErrorCode::kFormatRejected, file,
                "the external buffers add up to more than " + std::to_string(kMaxGltfExternalBufferBytes) + " bytes");
          }
          // A regular file only (runtime/file_io.h), checked on the open file itself.
          Result<std::vector<uint8_t>> read = runtime::ReadRegularFilePrefix(external, static_cast<uint64_t>(length));
          if (!read.ok()) {
            const ErrorCode code = read.error().code == ErrorCode::kFormatRejected ? ErrorCode::kFormatRejected
                                                                                   : ErrorCode::kFileUnreadable;
            return Fail(code, file, label + " file " + read.error().message);
          }
          data = std::move(read).value();
        }
      }
      if (length < 0 || static_cast<uint64_t>(length) > data.size()) {
        return Fail(ErrorCode::kFormatRejected, file,
                    label + " holds " + std::to_string(data.size()) + " bytes, fewer than its byteLength " +
                        std::to_string(length));
      }
      doc.buffers.push_back(std::move(data));
    }
  }
  return doc;
}

int64_t Integer(const json& obj, const char* key, int64_t fallback) {
  int64_t out = 0;
  if (!IntField(obj, key, fallback, &out)) {
    throw NotAnInteger("\"" + std::string(key) + "\" is " + obj[key].dump().substr(0, 40) + ", not an integer");
  }
  return out;
}

int64_t Integer(const json& v, const char* array_name) {
  const std::optional<int64_t> out = AsInteger(v);
  if (!out)
    throw NotAnInteger("\"" + std::string(array_name) + "\" lists " + v.dump().substr(0, 40) + ", not an integer");
  return *out;
}

}  // namespace skinspheres::lib::detail
