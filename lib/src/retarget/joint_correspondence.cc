// Joint correspondence (retarget_stages.h, MatchJoints): the joint map's entries, then equal
// names, then equal MatchKeys; and MatchKey itself (retarget.h).
#include <algorithm>
#include <cctype>
#include <map>

#include "retarget_stages.h"

namespace skinspheres::lib {

std::string MatchKey(std::string_view name) {
  const size_t cut = name.find_last_of(":|");
  if (cut != std::string_view::npos) name.remove_prefix(cut + 1);
  std::string key(name);
  std::transform(key.begin(), key.end(), key.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  constexpr std::string_view kMixamo = "mixamorig";
  if (key.size() > kMixamo.size() && key.compare(0, kMixamo.size(), kMixamo) == 0) {
    size_t k = kMixamo.size();
    while (k < key.size() && std::isdigit(static_cast<unsigned char>(key[k]))) ++k;
    if (k < key.size() && key[k] == '_') ++k;
    if (k < key.size()) key.erase(0, k);
  }
  // 3ds Max biped: "Bip01 L Hand", "Bip001 Pelvis".
  for (std::string_view biped : {"bip01 ", "bip001 ", "bip01_", "bip001_"}) {
    if (key.size() > biped.size() && key.compare(0, biped.size(), biped) == 0) {
      key.erase(0, biped.size());
      break;
    }
  }
  return key;
}

namespace retarget {
namespace {

// Names looked up as the map's entries are: the exact name, else a MatchKey only one joint has.
class NameIndex {
 public:
  explicit NameIndex(const skinning::Skeleton& skeleton) : skeleton_(skeleton) {
    for (size_t j = 0; j < skeleton.size(); ++j)
      by_key_[MatchKey(skeleton.joint_names[j])].push_back(static_cast<int32_t>(j));
  }
  int32_t Find(const std::string& name) const {
    if (const int32_t j = skeleton_.Find(name); j >= 0) return j;
    const auto it = by_key_.find(MatchKey(name));
    return it != by_key_.end() && it->second.size() == 1 ? it->second.front() : -1;
  }
  const std::map<std::string, std::vector<int32_t>>& by_key() const { return by_key_; }

 private:
  const skinning::Skeleton& skeleton_;
  std::map<std::string, std::vector<int32_t>> by_key_;
};

bool IsAbove(const skinning::Skeleton& s, int32_t above, int32_t j) {
  for (int32_t a = s.parents[static_cast<size_t>(j)]; a >= 0; a = s.parents[static_cast<size_t>(a)]) {
    if (a == above) return true;
  }
  return false;
}

// A pair that involves a map entry and reverses the hierarchy: target joint a above b, while
// a's node is below b's node in the source.
std::optional<Error> CheckHierarchy(const Correspondence& c, const std::vector<char>& from_map, const SourceRig& source,
                                    const RawCharacter& target, const std::string& map_file) {
  const skinning::Skeleton& t = target.skeleton;
  for (size_t b = 0; b < t.size(); ++b) {
    const int32_t nb = c.node_of[b];
    if (nb < 0) continue;
    for (int32_t a = t.parents[b]; a >= 0; a = t.parents[static_cast<size_t>(a)]) {
      const int32_t na = c.node_of[static_cast<size_t>(a)];
      if (na < 0 || !(from_map[b] || from_map[static_cast<size_t>(a)]) || !IsAbove(source.nodes, nb, na)) continue;
      const auto& sn = source.nodes.joint_names;
      const auto& tn = t.joint_names;
      return MakeError(ErrorCode::kInvalidArgument,
                       map_file + ": \"" + sn[static_cast<size_t>(na)] + "\" -> \"" + tn[static_cast<size_t>(a)] +
                           "\" and \"" + sn[static_cast<size_t>(nb)] + "\" -> \"" + tn[b] +
                           "\" reverse the hierarchy (a cycle: " + tn[static_cast<size_t>(a)] + " is above " + tn[b] +
                           " in " + target.Name() + ", " + sn[static_cast<size_t>(na)] + " below " +
                           sn[static_cast<size_t>(nb)] + " in " + source.source_file + ")");
    }
  }
  return std::nullopt;
}

// The map's entries onto `c`; source nodes set to null are marked in `excluded`.
std::optional<Error> ApplyMap(const JointMap& map, const SourceRig& source, const RawCharacter& target,
                              Correspondence* c, std::vector<char>* excluded, std::vector<char>* from_map) {
  const NameIndex nodes(source.nodes), joints(target.skeleton);
  for (size_t k = 0; k < map.entries.size(); ++k) {
    const auto& [from, to] = map.entries[k];
    const int32_t n = nodes.Find(from);
    if (n < 0) {
      return MakeError(ErrorCode::kInvalidArgument,
                       map.source_file + ": \"" + from + "\" names no joint of " + source.source_file);
    }
    if (c->joint_of[static_cast<size_t>(n)] >= 0 || (*excluded)[static_cast<size_t>(n)]) {
      return MakeError(ErrorCode::kInvalidArgument, map.source_file + ": the joint \"" +
                                                        source.nodes.joint_names[static_cast<size_t>(n)] + "\" of " +
                                                        source.source_file + " is named twice");
    }
    if (map.is_null[k]) {
      (*excluded)[static_cast<size_t>(n)] = 1;
      continue;
    }
    const int32_t j = joints.Find(to);
    if (j < 0) {
      return MakeError(ErrorCode::kInvalidArgument,
                       map.source_file + ": \"" + to + "\" names no joint of " + target.Name());
    }
    if (c->node_of[static_cast<size_t>(j)] >= 0) {
      return MakeError(ErrorCode::kInvalidArgument, map.source_file + ": the joint \"" +
                                                        target.skeleton.joint_names[static_cast<size_t>(j)] + "\" of " +
                                                        target.Name() + " is named twice");
    }
    c->joint_of[static_cast<size_t>(n)] = j;
    c->node_of[static_cast<size_t>(j)] = n;
    (*from_map)[static_cast<size_t>(j)] = 1;
  }
  return CheckHierarchy(*c, *from_map, source, target, map.source_file);
}

}  // namespace

Result<Correspondence> MatchJoints(const SourceRig& source, const RawCharacter& target, const JointMap* map) {
  const skinning::Skeleton& t = target.skeleton;
  const skinning::Skeleton& s = source.nodes;
  Correspondence c;
  c.joint_of.assign(s.size(), -1);
  c.node_of.assign(t.size(), -1);
  std::vector<char> excluded(s.size(), 0), from_map(t.size(), 0);
  if (map != nullptr) {
    if (auto bad = ApplyMap(*map, source, target, &c, &excluded, &from_map)) return *bad;
  }
  auto link = [&](size_t n, int32_t j) {
    c.joint_of[n] = j;
    c.node_of[static_cast<size_t>(j)] = static_cast<int32_t>(n);
  };
  for (size_t n = 0; n < s.size(); ++n) {
    if (excluded[n] || c.joint_of[n] >= 0) continue;
    const int32_t j = t.Find(s.joint_names[n]);
    if (j >= 0 && c.node_of[static_cast<size_t>(j)] < 0) link(n, j);
  }
  // Equal keys, where one free node and one joint share the key.
  const NameIndex joints(t);
  std::map<std::string, std::vector<size_t>> nodes_by_key;
  for (size_t n = 0; n < s.size(); ++n) {
    if (!excluded[n] && c.joint_of[n] < 0) nodes_by_key[MatchKey(s.joint_names[n])].push_back(n);
  }
  for (const auto& [key, nodes] : nodes_by_key) {
    const auto it = joints.by_key().find(key);
    if (key.empty() || nodes.size() != 1 || it == joints.by_key().end() || it->second.size() != 1) continue;
    if (c.node_of[static_cast<size_t>(it->second.front())] < 0) link(nodes.front(), it->second.front());
  }
  return c;
}

}  // namespace retarget
}  // namespace skinspheres::lib
