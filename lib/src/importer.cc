// ImportCharacter: reads the file, picks a reader (our glTF 2.0 reader for .gltf/.glb, Assimp
// for everything else), then the shared final pass (rest positions and the checks every
// character passes). See importer.h for the contract.
#include "skinspheres/lib/importer.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <new>
#include <nlohmann/json.hpp>
#include <system_error>

#include "importer_internal.h"
#include "skinspheres/lib/clip_import.h"

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
    if (it != merged.end()) it->weight += in.weight;
    else merged.push_back(in);
    sum += in.weight;
  }
  if (merged.empty() || !(sum > 0.0)) return std::string("skin weights sum to zero");
  if (skin.influence_offsets.empty()) skin.influence_offsets.push_back(0);
  for (const Influence& m : merged) {
    skin.influence_binds.push_back(static_cast<uint16_t>(m.bind));
    skin.influence_weights.push_back(static_cast<float>(m.weight / sum));
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
  if (c.triangles.empty()) return ImportError(ErrorCode::kInvalidData, file, "no triangles (no triangle primitive in the scene)");
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
                         "vertex " + std::to_string(v) + " has a non-finite rest position (NaN/Inf in a node transform or inverse bind matrix)");
    }
  }
  const int64_t n = static_cast<int64_t>(c.positions_rest.size());
  for (size_t t = 0; t < c.triangles.size(); ++t) {
    const Eigen::Vector3i& tri = c.triangles[t];
    if (tri.minCoeff() < 0 || tri.maxCoeff() >= n) {
      return ImportError(ErrorCode::kInvalidData, file, "triangle " + std::to_string(t) + " has a vertex index out of range");
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
  // glTF 1.0 JSON goes to Assimp; anything else that says .gltf is ours (errors included).
  const auto json = nlohmann::json::parse(bytes.begin(), bytes.end(), nullptr, false);
  if (json.is_object() && json.contains("asset") && json["asset"].is_object()) {
    const auto it = json["asset"].find("version");
    if (it != json["asset"].end() && it->is_string() && !it->get<std::string>().empty() && it->get<std::string>()[0] == '1') {
      return false;
    }
  }
  return true;
}

Result<std::vector<uint8_t>> ReadFileBytes(const std::filesystem::path& file) {
  std::error_code ec;
  const auto status = std::filesystem::status(file, ec);
  if (!std::filesystem::exists(status)) return ImportError(ErrorCode::kFileNotFound, file, "file not found");
  if (std::filesystem::is_directory(status)) return ImportError(ErrorCode::kFileUnreadable, file, "is a directory, not a file");
  std::ifstream in(file, std::ios::binary);
  if (!in) return ImportError(ErrorCode::kFileUnreadable, file, "cannot be opened for reading");
  std::vector<uint8_t> bytes;
  try {
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  } catch (const std::bad_alloc&) {
    return ImportError(ErrorCode::kFileUnreadable, file, "too large to read (out of memory)");
  }
  if (in.bad()) return ImportError(ErrorCode::kFileUnreadable, file, "read error");
  if (bytes.empty()) return ImportError(ErrorCode::kFormatRejected, file, "the file is empty");
  return bytes;
}

}  // namespace detail

Result<RawCharacter> ImportCharacter(const std::filesystem::path& file, const ImportOptions& options) {
  using detail::ImportError;
  auto read = detail::ReadFileBytes(file);
  if (!read.ok()) return read.error();
  const std::vector<uint8_t>& bytes = *read;
  try {
    Result<RawCharacter> result = detail::LooksLikeGltf2(file, bytes)
                                      ? detail::ImportGltf(file, bytes, options)
                                      : detail::ImportWithAssimp(file, bytes, options);
    std::optional<Error> error = result.ok() ? detail::FinishCharacter(*result, file) : result.error();
    if (error && (error->code == ErrorCode::kFormatRejected || error->code == ErrorCode::kInvalidData)) {
      // Say what the file is when it is an animation without a mesh (clip_import.h).
      if (std::string what = DescribeAnimationOnlyFile(file); !what.empty()) return ImportError(ErrorCode::kFormatRejected, file, what);
    }
    if (error) return *error;
    result->source_file = file.string();
    return result;
  } catch (const nlohmann::json::exception& e) {
    // A field of the wrong JSON type (e.g. a string where a number belongs).
    return ImportError(ErrorCode::kFormatRejected, file, std::string("malformed glTF JSON: ") + e.what());
  } catch (const std::bad_alloc&) {
    return ImportError(ErrorCode::kFormatRejected, file, "implausible sizes (out of memory while reading)");
  } catch (const std::exception& e) {
    return ImportError(ErrorCode::kFormatRejected, file, std::string("cannot be read: ") + e.what());
  }
}

}  // namespace skinspheres::lib
