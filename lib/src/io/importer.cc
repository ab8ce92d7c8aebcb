// ImportCharacter: reads the file, picks a reader (our glTF 2.0 reader for .gltf/.glb, Assimp
// for everything else), then the shared final pass (rest positions and the checks every
// character passes). See importer.h for the contract.
#include "skinspheres/lib/io/importer.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <new>
#include <nlohmann/json.hpp>
#include <system_error>

#include "gltf_document.h"
#include "importer_internal.h"
#include "skinspheres/lib/io/clip_import.h"
#include "skinspheres/runtime/format/file_io.h"
#include "skinspheres/runtime/format/json_shape.h"

namespace skinspheres::lib {
namespace detail {

Error ImportError(ErrorCode code, const std::filesystem::path& file, const std::string& problem) {
  std::string message = file.string() + ": " + problem;
  std::replace(message.begin(), message.end(), '\n', ' ');
  std::replace(message.begin(), message.end(), '\r', ' ');
  return MakeError(code, std::move(message));
}

int32_t FindOrAddBind(skinning::SkinnedMesh& skin, int32_t joint, const Mat4f& ibm) {
  for (size_t b = 0; b < skin.binds.size(); ++b) {
    if (skin.binds[b].joint == joint && skin.binds[b].inverse_bind == ibm) return static_cast<int32_t>(b);
  }
  if (skin.binds.size() >= 65536) return -1;  // influence_binds are uint16_t
  skin.binds.push_back({joint, ibm});
  return static_cast<int32_t>(skin.binds.size() - 1);
}

std::optional<std::string> AppendVertex(skinning::SkinnedMesh& skin, const Eigen::Vector3f& p_bind,
                                        std::vector<Influence>& influences) {
  // Merge repeated binds (a joint listed twice in JOINTS_n), drop zero weights.
  std::vector<Influence> merged;
  merged.reserve(influences.size());
  double sum = 0.0;
  for (const Influence& in : influences) {
    if (!std::isfinite(in.weight)) return std::string("a skin weight is NaN or infinite");
    if (in.weight < 0.0f) return "a skin weight is negative (" + std::to_string(in.weight) + ")";
    if (in.weight == 0.0f) continue;
    auto it = std::find_if(merged.begin(), merged.end(), [&](const Influence& m) { return m.bind == in.bind; });
    if (it != merged.end())
      it->weight += in.weight;
    else
      merged.push_back(in);
    sum += in.weight;
  }
  if (merged.empty() || !(sum > 0.0)) return std::string("skin weights sum to zero");
  if (skin.influence_offsets.empty()) skin.influence_offsets.push_back(0);
  for (const Influence& m : merged) {
    // A weight so far below the vertex's largest (1e-43 beside 1e25) that it normalises to 0 in
    // float moves nothing: it is dropped like a zero weight, never stored as an influence of 0.
    const float w = static_cast<float>(m.weight / sum);
    if (w == 0.0f) continue;
    skin.influence_binds.push_back(static_cast<uint16_t>(m.bind));
    skin.influence_weights.push_back(w);
  }
  skin.influence_offsets.push_back(static_cast<uint32_t>(skin.influence_binds.size()));
  skin.positions_bind.push_back(p_bind);
  return std::nullopt;
}

std::optional<Error> FinishCharacter(RawCharacter& c, const std::filesystem::path& file) {
  const skinning::Skeleton& skeleton = c.skeleton;
  const skinning::SkinnedMesh& skin = c.skin;
  if (skeleton.size() == 0 || !skeleton.Validate()) {
    return ImportError(ErrorCode::kInvalidData, file, "the skeleton is empty or not ordered parents-first");
  }
  if (c.triangles.empty())
    return ImportError(ErrorCode::kInvalidData, file, "no triangles (no triangle primitive in the scene)");
  // The limits of importer.h, for every reader (the glTF reader checks them before allocating).
  if (skeleton.size() > kMaxJoints) {
    return ImportError(ErrorCode::kInvalidData, file,
                       "the skeleton has " + std::to_string(skeleton.size()) + " joints; at most " +
                           std::to_string(kMaxJoints) + " are read");
  }
  if (skin.vertex_count() > kMaxVertices || c.triangles.size() > kMaxTriangles) {
    return ImportError(ErrorCode::kInvalidData, file,
                       std::to_string(skin.vertex_count()) + " vertices and " + std::to_string(c.triangles.size()) +
                           " triangles; at most " + std::to_string(kMaxVertices) + " and " +
                           std::to_string(kMaxTriangles) + " are read");
  }
  if (skin.influence_offsets.size() != skin.vertex_count() + 1) {
    return ImportError(ErrorCode::kInvalidData, file, "internal: influence table does not match the vertices");
  }
  std::vector<Mat4f> world(skeleton.size());
  skeleton.RestWorld(world);
  std::vector<Mat4f> skinning_matrices(skin.binds.size());  // G_j · IBM_b
  for (size_t b = 0; b < skin.binds.size(); ++b) {
    const int32_t j = skin.binds[b].joint;
    if (j < 0 || j >= static_cast<int32_t>(skeleton.size())) {
      return ImportError(ErrorCode::kInvalidData, file, "internal: bind entry " + std::to_string(b) + " has no joint");
    }
    skinning_matrices[b] = world[static_cast<size_t>(j)] * skin.binds[b].inverse_bind;
  }
  c.positions_rest.resize(skin.vertex_count());
  for (size_t v = 0; v < skin.vertex_count(); ++v) {
    Vec4f p = Vec4f::Zero();
    const Vec4f p_bind = skin.positions_bind[v].homogeneous();
    for (uint32_t k = skin.influence_offsets[v]; k < skin.influence_offsets[v + 1]; ++k) {
      p += skin.influence_weights[k] * (skinning_matrices[skin.influence_binds[k]] * p_bind);
    }
    c.positions_rest[v] = p.head<3>();
    if (!c.positions_rest[v].allFinite()) {
      return ImportError(ErrorCode::kInvalidData, file,
                         "vertex " + std::to_string(v) +
                             " has a non-finite rest position (NaN/Inf in a node transform or inverse bind matrix)");
    }
  }
  const int64_t n = static_cast<int64_t>(c.positions_rest.size());
  for (size_t t = 0; t < c.triangles.size(); ++t) {
    const Eigen::Vector3i& tri = c.triangles[t];
    if (tri.minCoeff() < 0 || tri.maxCoeff() >= n) {
      return ImportError(ErrorCode::kInvalidData, file,
                         "triangle " + std::to_string(t) + " has a vertex index out of range");
    }
  }
  return std::nullopt;
}

bool LooksLikeGltf2(const std::filesystem::path& file, std::span<const uint8_t> bytes) {
  if (bytes.size() >= 8 && std::equal(bytes.begin(), bytes.begin() + 4, "glTF")) {
    return bytes[4] == 2;  // GLB version 1 goes to Assimp
  }
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char ch) { return std::tolower(ch); });
  if (ext == ".glb") return true;  // not GLB magic: our reader reports what is wrong
  if (ext != ".gltf") return false;
  // glTF 1.0 JSON goes to Assimp; anything else that says .gltf is ours (errors included). Text
  // too deep or too large to parse safely is ours too: our reader refuses it, naming the limit.
  const runtime::JsonShape shape =
      runtime::ScanJson(std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
  if (shape.depth > runtime::kMaxJsonDepth || shape.values > kMaxGltfJsonValues) return true;
  const auto json = nlohmann::json::parse(bytes.begin(), bytes.end(), nullptr, false);
  if (json.is_object() && json.contains("asset") && json["asset"].is_object()) {
    const auto it = json["asset"].find("version");
    if (it != json["asset"].end() && it->is_string() && !it->get<std::string>().empty() &&
        it->get<std::string>()[0] == '1') {
      return false;
    }
  }
  return true;
}

Result<std::vector<uint8_t>> ReadFileBytes(const std::filesystem::path& file) {
  // Regular files only (a FIFO would block, /dev/zero never ends), at most kMaxCharacterFileBytes,
  // refused from the size before anything is allocated (runtime/file_io.h). Its messages are
  // "<file>: <problem>"; ImportError keeps them on one line.
  Result<std::string> read = runtime::ReadRegularFile(file, kMaxCharacterFileBytes, "character file");
  if (!read.ok()) return ImportError(read.error().code, file, read.error().message.substr(file.string().size() + 2));
  if (read->empty()) return ImportError(ErrorCode::kFormatRejected, file, "the file is empty");
  return std::vector<uint8_t>(read->begin(), read->end());
}

}  // namespace detail

namespace {

// Reads `bytes` (the whole file, named `file`) with the reader `gltf_only` or the bytes pick, then
// the final pass; every exception a reader lets out becomes one Error naming the file. Bytes from
// memory (gltf_only) never make it open `file`.
Result<RawCharacter> ImportBytes(const std::filesystem::path& file, std::span<const uint8_t> bytes,
                                 const ImportOptions& options, bool gltf_only) {
  using detail::ImportError;
  try {
    if (bytes.empty()) return ImportError(ErrorCode::kFormatRejected, file, "the file is empty");
    Result<RawCharacter> result = gltf_only || detail::LooksLikeGltf2(file, bytes)
                                      ? detail::ImportGltf(file, bytes, options)
                                      : detail::ImportWithAssimp(file, bytes, options);
    std::optional<Error> error = result.ok() ? detail::FinishCharacter(*result, file) : result.error();
    if (error && !gltf_only && (error->code == ErrorCode::kFormatRejected || error->code == ErrorCode::kInvalidData)) {
      // Say what the file is when it is an animation without a mesh (clip_import.h).
      if (std::string what = DescribeAnimationOnlyFile(file); !what.empty())
        return ImportError(ErrorCode::kFormatRejected, file, what);
    }
    if (error) return *error;
    result->source_file = file.string();
    return result;
  } catch (const detail::NotAnInteger& e) {
    return ImportError(ErrorCode::kFormatRejected, file, std::string("malformed glTF JSON: ") + e.what());
  } catch (const nlohmann::json::exception& e) {
    // A field of the wrong JSON type (e.g. a string where a number belongs).
    return ImportError(ErrorCode::kFormatRejected, file, std::string("malformed glTF JSON: ") + e.what());
  } catch (const std::bad_alloc&) {
    return ImportError(ErrorCode::kFormatRejected, file, "implausible sizes (out of memory while reading)");
  } catch (const std::exception& e) {
    return ImportError(ErrorCode::kFormatRejected, file, std::string("cannot be read: ") + e.what());
  }
}

}  // namespace

Result<RawCharacter> ImportCharacter(const std::filesystem::path& file, const ImportOptions& options) {
  auto read = detail::ReadFileBytes(file);
  if (!read.ok()) return read.error();
  return ImportBytes(file, *read, options, /*gltf_only=*/false);
}

Result<RawCharacter> ImportGltfBytes(std::span<const uint8_t> bytes, const std::filesystem::path& name,
                                     const ImportOptions& options) {
  if (bytes.size() > kMaxCharacterFileBytes) {
    return detail::ImportError(ErrorCode::kFormatRejected, name,
                               "is " + std::to_string(bytes.size()) + " bytes; a character file may be at most " +
                                   std::to_string(kMaxCharacterFileBytes) + " bytes");
  }
  return ImportBytes(name, bytes, options, /*gltf_only=*/true);
}

}  // namespace skinspheres::lib
