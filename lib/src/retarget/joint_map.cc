// LoadJointMap (retarget.h): the --joint-map file, {"source node": "target joint" | null, ...},
// checked before any joint is looked up: one key once, one target joint once, no cycle.
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "retarget_stages.h"
#include "skinspheres/runtime/format/file_io.h"
#include "skinspheres/runtime/format/json_shape.h"

namespace skinspheres::lib {
namespace {

Error MapError(ErrorCode code, const std::string& file, const std::string& problem) {
  return MakeError(code, file + ": " + problem);
}

// The first cycle of renames "A" -> "B" -> ... -> "A" of two names or more, as text, or "".
// Each name is a key at most once, so every name has at most one successor.
std::string FindCycle(const JointMap& map) {
  std::map<std::string, std::string> next;
  for (size_t k = 0; k < map.entries.size(); ++k) {
    if (!map.is_null[k] && map.entries[k].first != map.entries[k].second)
      next[map.entries[k].first] = map.entries[k].second;
  }
  std::set<std::string> done;
  for (const auto& [start, unused] : next) {
    std::vector<std::string> path;
    std::set<std::string> on_path;
    std::string at = start;
    bool cycle = false;
    while (!done.count(at)) {
      if (on_path.count(at)) {
        cycle = true;
        break;
      }
      path.push_back(at);
      on_path.insert(at);
      const auto it = next.find(at);
      if (it == next.end()) break;
      at = it->second;
    }
    if (cycle) {
      std::string text;
      bool in_cycle = false;
      for (const std::string& name : path) {
        in_cycle = in_cycle || name == at;
        if (in_cycle) text.append("\"").append(name).append("\" -> ");
      }
      return text.append("\"").append(at).append("\"");
    }
    done.insert(path.begin(), path.end());
  }
  return {};
}

}  // namespace

Result<JointMap> LoadJointMap(const std::filesystem::path& file) {
  const std::string name = runtime::PathText(file);
  Result<std::string> text = runtime::ReadRegularFile(file, kMaxJointMapBytes, "joint map");
  if (!text.ok()) return text.error();
  if (const size_t depth = runtime::ScanJson(*text).depth; depth > runtime::kMaxJsonDepth) {
    return MapError(ErrorCode::kFormatRejected, name,
                    "the JSON nests " + std::to_string(depth) + " deep (at most " +
                        std::to_string(runtime::kMaxJsonDepth) + " is read)");
  }
  // A key given twice would silently keep one value: the parser's callback sees every key.
  std::set<std::string> keys;
  std::string twice;
  const nlohmann::json::parser_callback_t seen = [&](int depth, nlohmann::json::parse_event_t event,
                                                     nlohmann::json& parsed) {
    if (event == nlohmann::json::parse_event_t::key && depth == 1 && parsed.is_string() && twice.empty() &&
        !keys.insert(parsed.get<std::string>()).second) {
      twice = parsed.get<std::string>();
    }
    return true;
  };
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(*text, seen);
  } catch (const nlohmann::json::exception& e) {
    return MapError(ErrorCode::kFormatRejected, name, std::string("malformed JSON: ") + e.what());
  }
  if (!j.is_object()) {
    return MapError(
        ErrorCode::kFormatRejected, name,
        "expected a JSON object {\"source joint\": \"target joint\", ...}, got " + std::string(j.type_name()));
  }
  if (!twice.empty()) return MapError(ErrorCode::kFormatRejected, name, "\"" + twice + "\" is mapped twice");
  JointMap out;
  out.source_file = name;
  std::map<std::string, std::string> key_of_target;
  for (auto it = j.begin(); it != j.end(); ++it) {
    if (it.key().empty()) return MapError(ErrorCode::kFormatRejected, name, "an empty joint name");
    if (it.value().is_null()) {
      out.entries.emplace_back(it.key(), "");
      out.is_null.push_back(true);
      continue;
    }
    if (!it.value().is_string() || it.value().get<std::string>().empty()) {
      return MapError(ErrorCode::kFormatRejected, name,
                      "\"" + it.key() + "\" maps to " +
                          (it.value().is_string() ? "an empty name" : std::string("a ") + it.value().type_name()) +
                          ", expected a target joint's name or null");
    }
    const std::string target = it.value().get<std::string>();
    if (const auto [at, fresh] = key_of_target.emplace(target, it.key()); !fresh) {
      return MapError(
          ErrorCode::kInvalidArgument, name,
          "the target joint \"" + target + "\" is named twice (by \"" + at->second + "\" and \"" + it.key() + "\")");
    }
    out.entries.emplace_back(it.key(), target);
    out.is_null.push_back(false);
  }
  if (const std::string cycle = FindCycle(out); !cycle.empty()) {
    return MapError(ErrorCode::kInvalidArgument, name,
                    cycle + " is a cycle (renaming joints in a circle does not mirror a motion)");
  }
  return out;
}

}  // namespace skinspheres::lib
