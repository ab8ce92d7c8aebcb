// JointMapping (joint_mapping.h): engine joint names -> set joints, by exact name.
#include "skinspheres/runtime/api/joint_mapping.h"

#include <algorithm>
#include <unordered_map>

namespace skinspheres::runtime {
namespace {

// "a, b, c and 4 more" (at most `shown` names).
std::string NameList(const std::vector<std::string>& names, size_t shown = 8) {
  std::string out;
  for (size_t k = 0; k < names.size() && k < shown; ++k) out += (k ? ", '" : "'") + names[k] + "'";
  if (names.size() > shown) out += " and " + std::to_string(names.size() - shown) + " more";
  return out;
}

}  // namespace

bool JointMapping::identity() const {
  if (engine_joint_count != engine_index.size()) return false;
  for (size_t j = 0; j < engine_index.size(); ++j) {
    if (engine_index[j] != static_cast<int32_t>(j)) return false;
  }
  return true;
}

std::vector<bool> JointsReadPerFrame(const SphereSet& set) {
  std::vector<bool> read(set.joint_count(), false);
  for (uint16_t j : set.influence_joints) {
    if (j < read.size()) read[j] = true;
  }
  for (const skinning::BindEntry& b : set.mesh.binds) {
    if (b.joint >= 0 && static_cast<size_t>(b.joint) < read.size()) read[static_cast<size_t>(b.joint)] = true;
  }
  return read;
}

std::string DescribeSphereSet(const SphereSet& set) {
  const std::string fitted = set.source_file.empty() ? "" : "fitted on " + set.source_file;
  if (set.loaded_from.empty()) return "sphere set" + (fitted.empty() ? std::string() : " " + fitted);
  return "sphere set '" + set.loaded_from + "'" + (fitted.empty() ? std::string() : " (" + fitted + ")");
}

Result<JointMapping> MapJoints(const SphereSet& set, std::span<const std::string> engine_joint_names) {
  JointMapping m;
  m.engine_joint_count = engine_joint_names.size();
  // The set's own list in its own order: the identity, even where names repeat (some files name a
  // mesh node like a joint; position tells them apart).
  if (std::equal(engine_joint_names.begin(), engine_joint_names.end(), set.joint_names.begin(),
                 set.joint_names.end())) {
    m.engine_index.resize(set.joint_count());
    for (size_t j = 0; j < set.joint_count(); ++j) m.engine_index[j] = static_cast<int32_t>(j);
    return m;
  }
  // By name: a name that appears twice (in either list) cannot be mapped, which matters only for
  // joints the runtime reads.
  std::unordered_map<std::string_view, int32_t> engine;  // name -> index, -1 when repeated
  engine.reserve(engine_joint_names.size());
  for (size_t k = 0; k < engine_joint_names.size(); ++k) {
    auto [it, inserted] = engine.emplace(engine_joint_names[k], static_cast<int32_t>(k));
    if (!inserted) it->second = -1;
  }
  std::unordered_map<std::string_view, int> in_set;
  for (const std::string& name : set.joint_names) ++in_set[name];
  const std::vector<bool> read = JointsReadPerFrame(set);
  m.engine_index.assign(set.joint_count(), JointMapping::kUnmapped);
  std::vector<bool> used(engine_joint_names.size(), false);
  std::vector<std::string> missing, ambiguous;
  for (size_t j = 0; j < set.joint_count(); ++j) {
    const std::string& name = set.joint_names[j];
    auto it = engine.find(name);
    if (it == engine.end()) {
      (read[j] ? missing : m.unmapped_set_joints).push_back(name);
    } else if (it->second < 0 || in_set[name] > 1) {
      (read[j] ? ambiguous : m.unmapped_set_joints).push_back(name);
    } else {
      m.engine_index[j] = it->second;
      used[static_cast<size_t>(it->second)] = true;
    }
  }
  for (size_t k = 0; k < engine_joint_names.size(); ++k) {
    if (!used[k]) m.extra_engine_joints.push_back(engine_joint_names[k]);
  }
  if (!ambiguous.empty()) {
    return MakeError(ErrorCode::kMismatchedAsset,
                     DescribeSphereSet(set) + ": joint " + NameList(ambiguous) +
                         " appears more than once in the set or in the character's list, so "
                         "it cannot be matched by name (pass the set's own joint list)");
  }
  if (!missing.empty()) {
    std::string message = DescribeSphereSet(set) + ": the character has no joint " + NameList(missing) + " (" +
                          std::to_string(missing.size()) + " of the joints the spheres move with are missing";
    if (!m.extra_engine_joints.empty()) message += "; it has " + NameList(m.extra_engine_joints, 4) + " instead";
    return MakeError(ErrorCode::kMismatchedAsset, message + ")");
  }
  return m;
}

}  // namespace skinspheres::runtime
