// glTF 2.0 container reading (spec sections 3.6 "Binary data storage" and 4.4 GLB); the accessors
// are read in gltf_accessors.cc.
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

}  // namespace

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

namespace {

// The GLB container (glTF 2.0 §4.4): a 12-byte header, then chunks; the first is the JSON, the
// first BIN chunk after it holds buffer 0. Text (not GLB) is all JSON.
struct Container {
  std::span<const uint8_t> json_text;
  std::span<const uint8_t> bin;
  bool has_bin = false;
};

std::optional<Error> ReadContainer(const std::filesystem::path& file, std::span<const uint8_t> bytes, Container* out) {
  out->json_text = bytes;
  if (bytes.size() < 4 || ReadU32(bytes.data()) != kGlbMagic) return std::nullopt;
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
      out->json_text = chunk;
    else if (chunk_type == kChunkBin && !out->has_bin) {
      out->bin = chunk;
      out->has_bin = true;
    }
    first = false;
    at += 8 + ((chunk_length + 3u) & ~3u);
  }
  if (first) return Fail(ErrorCode::kFormatRejected, file, "truncated GLB: no JSON chunk");
  return std::nullopt;
}

// The JSON, its shape checked before parsing, and its asset version.
std::optional<Error> ParseJson(const std::filesystem::path& file, std::span<const uint8_t> json_text, json* out) {
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
  *out = json::parse(json_text.begin(), json_text.end(), nullptr, /*allow_exceptions=*/false);
  if (out->is_discarded() || !out->is_object()) {
    return Fail(ErrorCode::kFormatRejected, file, "not a glTF file (the JSON does not parse)");
  }
  if (!out->contains("asset")) return Fail(ErrorCode::kFormatRejected, file, "not a glTF file (no \"asset\")");
  const std::string version = (*out)["asset"].value("version", std::string());
  if (version.empty() || version[0] != '2') {
    return Fail(ErrorCode::kFormatRejected, file, "glTF version \"" + version + "\" (only 2.x is read)");
  }
  return std::nullopt;
}

// glTF 2.0 §3.12: a loader MUST NOT load an asset that requires an extension it does not
// support. This reader supports the extensions that change nothing it reads (materials,
// textures, lights, metadata) and KHR_mesh_quantization (integer attributes, which every
// accessor read here converts); any other (Draco or meshopt compression, GPU instancing,
// animation pointers, ...) refuses the file.
std::optional<Error> CheckRequiredExtensions(const std::filesystem::path& file, const json& j) {
  if (!j.contains("extensionsRequired")) return std::nullopt;
  const json& required = j["extensionsRequired"];
  if (!required.is_array()) return Fail(ErrorCode::kFormatRejected, file, "\"extensionsRequired\" is not an array");
  for (const auto& e : required) {
    if (!e.is_string()) return Fail(ErrorCode::kFormatRejected, file, "\"extensionsRequired\" lists a non-string");
    const std::string ext = e.get<std::string>();
    if (!IsIgnorableOrReadExtension(ext)) {
      return Fail(ErrorCode::kFormatRejected, file, "requires the glTF extension " + ext + ", which is not supported");
    }
  }
  return std::nullopt;
}

// An external buffer file: only a regular file beside (or below) the glTF, never a device, a pipe
// or "..": a file must not make the reader hang or read elsewhere. `external_bytes` adds up the
// byteLengths of the external buffers read so far.
std::optional<Error> ReadExternalBuffer(const std::filesystem::path& file, const std::string& label,
                                        const std::string& uri, int64_t length, uint64_t* external_bytes,
                                        std::vector<uint8_t>* data) {
  const std::filesystem::path relative = std::filesystem::path(PercentDecode(uri)).lexically_normal();
  if (relative.is_absolute() || relative.empty() || *relative.begin() == "..") {
    return Fail(ErrorCode::kFormatRejected, file, label + " uri \"" + uri + "\" is not a path beside the file");
  }
  const std::filesystem::path external = file.parent_path() / relative;
  if (length < 0) return Fail(ErrorCode::kFormatRejected, file, label + " has no valid byteLength");
  *external_bytes += static_cast<uint64_t>(length);
  if (*external_bytes > kMaxGltfExternalBufferBytes) {
    return Fail(ErrorCode::kFormatRejected, file,
                "the external buffers add up to more than " + std::to_string(kMaxGltfExternalBufferBytes) + " bytes");
  }
  // A regular file only (runtime/file_io.h), checked on the open file itself.
  Result<std::vector<uint8_t>> read = runtime::ReadRegularFilePrefix(external, static_cast<uint64_t>(length));
  if (!read.ok()) {
    const ErrorCode code =
        read.error().code == ErrorCode::kFormatRejected ? ErrorCode::kFormatRejected : ErrorCode::kFileUnreadable;
    return Fail(code, file, label + " file " + read.error().message);
  }
  *data = std::move(read).value();
  return std::nullopt;
}

// Every json["buffers"] entry: the GLB BIN chunk (buffer 0 without a uri), a base64 data: uri or
// an external file, each at least its byteLength long.
std::optional<Error> ReadBuffers(const std::filesystem::path& file, const Container& container, GltfDocument* doc) {
  if (!doc->json.contains("buffers")) return std::nullopt;
  const json& buffers = doc->json["buffers"];
  if (!buffers.is_array()) return Fail(ErrorCode::kFormatRejected, file, "\"buffers\" is not an array");
  uint64_t external_bytes = 0;
  for (size_t b = 0; b < buffers.size(); ++b) {
    const int64_t length = Integer(buffers[b], "byteLength", -1);
    std::vector<uint8_t> data;
    const std::string label = "buffer " + std::to_string(b);
    if (!buffers[b].contains("uri")) {
      if (b != 0 || !container.has_bin)
        return Fail(ErrorCode::kFormatRejected, file, label + " has no uri and there is no GLB BIN chunk");
      data.assign(container.bin.begin(), container.bin.end());
    } else {
      const std::string uri = buffers[b]["uri"].get<std::string>();
      if (uri.rfind("data:", 0) == 0) {
        const size_t comma = uri.find(";base64,");
        if (comma == std::string::npos || !DecodeBase64(std::string_view(uri).substr(comma + 8), &data)) {
          return Fail(ErrorCode::kFormatRejected, file, label + " has a data: uri that is not valid base64");
        }
      } else if (auto e = ReadExternalBuffer(file, label, uri, length, &external_bytes, &data)) {
        return e;
      }
    }
    if (length < 0 || static_cast<uint64_t>(length) > data.size()) {
      return Fail(ErrorCode::kFormatRejected, file,
                  label + " holds " + std::to_string(data.size()) + " bytes, fewer than its byteLength " +
                      std::to_string(length));
    }
    doc->buffers.push_back(std::move(data));
  }
  return std::nullopt;
}

}  // namespace

Result<GltfDocument> LoadGltf(const std::filesystem::path& file, std::span<const uint8_t> bytes) {
  GltfDocument doc;
  Container container;
  if (auto e = ReadContainer(file, bytes, &container)) return *e;
  if (auto e = ParseJson(file, container.json_text, &doc.json)) return *e;
  if (auto e = CheckRequiredExtensions(file, doc.json)) return *e;
  if (auto e = ReadBuffers(file, container, &doc)) return *e;
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
