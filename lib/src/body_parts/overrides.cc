// Part overrides: read from a JSON file {"joint name": "part name", ...} and applied last, each
// joint (and so its triangles) moved to the named part. See body_parts.h and split_stages.h.
#include <algorithm>
#include <cctype>
#include <nlohmann/json.hpp>
#include <system_error>

#include "skinspheres/runtime/format/file_io.h"
#include "skinspheres/runtime/format/json_shape.h"
#include "split_stages.h"

namespace skinspheres::lib {
namespace {

bool IsValidPartName(const std::string& name) {
  static const char* kNames[] = {"torso", "head", "arm_l", "arm_r", "leg_l", "leg_r"};
  for (const char* n : kNames) {
    if (name == n) return true;
  }
  if (name.rfind("chain_", 0) == 0 && name.size() > 6) {
    for (size_t i = 6; i < name.size(); ++i) {
      if (!std::isdigit(static_cast<unsigned char>(name[i]))) return false;
    }
    return true;
  }
  return false;
}

}  // namespace

Result<PartOverrides> LoadPartOverrides(const std::filesystem::path& file, const skinning::Skeleton* skeleton) {
  const std::string name = file.string();
  // A regular file only (a FIFO would block, /dev/zero never ends), capped, and nested at most
  // kMaxJsonDepth deep (runtime/file_io.h).
  Result<std::string> text = runtime::ReadRegularFile(file, kMaxPartsFileBytes, "parts file");
  if (!text.ok()) return text.error();
  if (const size_t depth = runtime::ScanJson(*text).depth; depth > runtime::kMaxJsonDepth) {
    return MakeError(ErrorCode::kFormatRejected, name + ": the JSON nests " + std::to_string(depth) +
                                                     " deep (at most " + std::to_string(runtime::kMaxJsonDepth) +
                                                     " is read)");
  }
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(*text);
  } catch (const nlohmann::json::exception& e) {
    return MakeError(ErrorCode::kFormatRejected, name + ": malformed JSON: " + e.what());
  }
  if (!j.is_object()) {
    return MakeError(
        ErrorCode::kFormatRejected,
        name + ": expected a JSON object {\"joint name\": \"part name\", ...}, got " + std::string(j.type_name()));
  }
  PartOverrides out;
  out.source_file = name;
  for (auto it = j.begin(); it != j.end(); ++it) {
    if (!it.value().is_string()) {
      return MakeError(ErrorCode::kFormatRejected, name + ": joint '" + it.key() + "' maps to a " +
                                                       std::string(it.value().type_name()) +
                                                       ", expected a part name string");
    }
    const std::string part = it.value().get<std::string>();
    if (!IsValidPartName(part)) {
      return MakeError(ErrorCode::kInvalidArgument,
                       name + ": joint '" + it.key() + "' -> unknown part '" + part +
                           "' (expected torso, head, arm_l, arm_r, leg_l, leg_r or chain_<k>)");
    }
    if (skeleton != nullptr && skeleton->Find(it.key()) < 0) {
      return MakeError(ErrorCode::kNotFound, name + ": unknown joint '" + it.key() + "' (not in the skeleton)");
    }
    out.joint_to_part[it.key()] = part;
  }
  return out;
}

std::optional<Error> ApplyOverrides(const RawCharacter& ch, const PartOverrides& ov, BodyParts* out) {
  const std::string src = ov.source_file.empty() ? std::string("<overrides>") : ov.source_file;
  for (const auto& [joint_name, part_name] : ov.joint_to_part) {
    const int32_t j = ch.skeleton.Find(joint_name);
    if (j < 0) {
      return MakeError(ErrorCode::kNotFound,
                       src + ": joint '" + joint_name + "' is not in " +
                           (ch.source_file.empty() ? std::string("the character") : ch.source_file));
    }
    const int32_t p = out->Find(part_name);
    if (p < 0) {
      std::string have;
      for (const BodyPart& bp : out->parts) have += (have.empty() ? "" : ", ") + bp.name;
      return MakeError(ErrorCode::kInvalidArgument, src + ": joint '" + joint_name + "' -> part '" + part_name +
                                                        "', which this character does not have (" + have + ")");
    }
    const int32_t old = out->joint_part[j];
    if (old == p) continue;
    if (old >= 0) {
      auto& oj = out->parts[old].joints;
      oj.erase(std::remove(oj.begin(), oj.end(), j), oj.end());
      auto& oc = out->parts[old].chain;
      oc.erase(std::remove(oc.begin(), oc.end(), j), oc.end());
    }
    out->joint_part[j] = p;
    out->parts[p].joints.push_back(j);
  }
  return std::nullopt;
}

}  // namespace skinspheres::lib
