#include "skinspheres/runtime/format/sphere_set_io.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <new>
#include <nlohmann/json.hpp>

#include "skinspheres/runtime/format/file_io.h"
#include "skinspheres/runtime/format/json_shape.h"
#include "skinspheres/runtime/format/sphere_set_binary.h"

namespace skinspheres::runtime {

using nlohmann::json;

namespace {

json SkeletonJson(const SphereSet& set) {
  json joints = json::array();
  for (size_t k = 0; k < set.joint_count(); ++k) {
    const Mat4f& m = set.joint_rest_world[k];
    joints.push_back({{"name", set.joint_names[k]},
                      {"parent", set.joint_parents[k]},
                      {"rest_world", std::vector<float>(m.data(), m.data() + 16)}});
    if (set.fast_reference_inverse.size() == set.joint_count()) {
      const Mat4f& r = set.fast_reference_inverse[k];
      joints.back()["fast_reference_inverse"] = std::vector<float>(r.data(), r.data() + 16);
    }
  }
  return {{"joints", joints}};
}

// Sphere s's reach groups: [radius, reach, blend, deviation per influence] each; `group_base` is
// where its groups' reaches start, and moves past them.
json ReachGroupsJson(const SphereSet& set, size_t s, size_t* group_base) {
  const size_t k_count = set.influence_offsets[s + 1] - set.influence_offsets[s];
  json groups = json::array();
  for (uint32_t g = set.reach_group_offsets[s]; g < set.reach_group_offsets[s + 1]; ++g, *group_base += k_count) {
    std::vector<float> row = {set.reach_group_radii[g]};
    for (size_t k = 0; k < k_count && *group_base + k < set.reach_group_weights.size(); ++k) {
      row.push_back(set.reach_group_weights[*group_base + k]);
    }
    // With blends (sphere_set.h): the blend weights, then the deviations, after the reaches.
    for (const std::vector<float>* extra : {&set.reach_group_blend, &set.reach_group_deviation}) {
      for (size_t k = 0; k < k_count && *group_base + k < extra->size(); ++k) row.push_back((*extra)[*group_base + k]);
    }
    groups.push_back(row);
  }
  return groups;
}

// Sphere s: its rest sphere, members, influences, and what the set holds beyond them (fast
// reference, pieces, reach groups, influence reach). `group_base` as ReachGroupsJson's.
json SphereJson(const SphereSet& set, size_t s, size_t* group_base) {
  const auto& c = set.centers_rest[s];
  json influences = json::array();
  for (uint32_t k = set.influence_offsets[s]; k < set.influence_offsets[s + 1]; ++k) {
    influences.push_back(json::array({set.influence_joints[k], set.influence_weights[k]}));
  }
  json sphere = {
      {"id", s},
      {"part", set.sphere_part[s]},
      {"joint", set.sphere_joint[s]},
      {"level", set.sphere_level[s]},
      {"center", {c.x(), c.y(), c.z()}},
      {"radius", set.radii_rest[s]},
      {"radius_fast", set.radii_fast[s]},
      {"vertices", std::vector<uint32_t>(set.vertices.begin() + set.vertex_offsets[s],
                                         set.vertices.begin() + set.vertex_offsets[s + 1])},
      {"triangles", std::vector<uint32_t>(set.triangles.begin() + set.triangle_offsets[s],
                                          set.triangles.begin() + set.triangle_offsets[s + 1])},
      {"influences", influences},
  };
  if (set.fast_reference_spheres.size() == set.size()) {
    const Vec4f& r = set.fast_reference_spheres[s];
    sphere["fast_reference"] = {r.x(), r.y(), r.z(), r.w()};
  }
  if (set.piece_offsets.size() == set.size() + 1 && set.piece_offsets[s] < set.piece_offsets[s + 1]) {
    std::vector<uint32_t> pieces;  // (triangle, level, index) per piece, flat
    for (uint32_t k = set.piece_offsets[s]; k < set.piece_offsets[s + 1] && k < set.pieces.size(); ++k) {
      pieces.insert(pieces.end(), {set.pieces[k].triangle, set.pieces[k].level, set.pieces[k].index});
    }
    sphere["pieces"] = pieces;
  }
  if (set.reach_group_offsets.size() == set.size() + 1) sphere["reach_groups"] = ReachGroupsJson(set, s, group_base);
  if (!set.influence_reach.empty() && set.influence_reach.size() == set.influence_joints.size()) {
    sphere["influence_reach"] = std::vector<float>(set.influence_reach.begin() + set.influence_offsets[s],
                                                   set.influence_reach.begin() + set.influence_offsets[s + 1]);
  }
  return sphere;
}

// The mesh (format version >= 2): triangles, bind-space positions, bind entries, influences, and
// the pieces' grid points.
json MeshJson(const SphereSet& set) {
  const skinning::SkinnedMesh& mesh = set.mesh;
  json binds = json::array();
  for (const skinning::BindEntry& b : mesh.binds) {
    binds.push_back(
        {{"joint", b.joint}, {"inverse_bind", std::vector<float>(b.inverse_bind.data(), b.inverse_bind.data() + 16)}});
  }
  std::vector<float> positions;
  positions.reserve(3 * mesh.vertex_count());
  for (const Eigen::Vector3f& p : mesh.positions_bind) positions.insert(positions.end(), {p.x(), p.y(), p.z()});
  json out = {{"triangles", set.triangle_vertices},
              {"positions_bind", positions},
              {"binds", binds},
              {"influence_offsets", mesh.influence_offsets},
              {"influence_binds", mesh.influence_binds},
              {"influence_weights", mesh.influence_weights}};
  if (set.has_pieces()) {
    std::vector<uint32_t> points;  // (triangle, level, i, j) per grid point, flat
    for (const PiecePoint& g : set.piece_points) points.insert(points.end(), {g.triangle, g.level, g.i, g.j});
    out["piece_points"] = points;
  }
  return out;
}

}  // namespace

std::string WriteSphereSetJson(const SphereSet& set) {
  json j;
  j["format"] = kSphereSetFormat;
  const bool triangle_rules = set.contact_rules == ContactRules::kTriangles;
  j["version"] = triangle_rules     ? kSphereSetVersionWithRules
                 : set.has_pieces() ? kSphereSetVersionWithPieces
                 : set.has_mesh()   ? kSphereSetVersion
                                    : kSphereSetVersionWithoutMesh;
  j["source"] = {
      {"file", set.source_file}, {"vertices", set.source_vertex_count}, {"triangles", set.source_triangle_count}};
  json params = json::parse(set.params_json, nullptr, /*allow_exceptions=*/false);
  j["params"] = params.is_object() ? params : json::object();
  j["skeleton"] = SkeletonJson(set);

  json parts = json::array();
  for (const auto& p : set.parts) parts.push_back({{"name", p.name}, {"joints", p.joints}});
  j["parts"] = parts;

  json spheres = json::array();
  size_t group_base = 0;  // where the current sphere's reach groups' reaches start
  for (size_t s = 0; s < set.size(); ++s) spheres.push_back(SphereJson(set, s, &group_base));
  j["spheres"] = spheres;

  json pairs = json::array();
  for (const auto& p : set.excluded_pairs) pairs.push_back(json::array({p.i, p.j, ToString(p.reason)}));
  j["excluded_pairs"] = pairs;
  if (triangle_rules) {
    j["contact_rules"] = {{"on", ToString(set.contact_rules)}, {"hops", set.contact_hops}, {"rest_gap", set.rest_gap}};
  }
  if (set.has_mesh()) j["mesh"] = MeshJson(set);
  // Names that are not valid UTF-8 (paths are bytes; FBX names may be Latin-1) are written with
  // U+FFFD instead of aborting; such a set then refuses to match its character by name.
  return j.dump(-1, ' ', false, json::error_handler_t::replace);
}

namespace {

// Reading: every access goes through these helpers, which throw a ReadError carrying the JSON
// path of the offending field; ReadSphereSetJson turns it into an Error. Exceptions stay inside
// this file.
struct ReadError {
  std::string what;
};

const json& Field(const json& obj, const char* key, const std::string& where) {
  if (!obj.is_object()) throw ReadError{where + " is not an object"};
  auto it = obj.find(key);
  if (it == obj.end()) throw ReadError{where + "." + key + " is missing"};
  return *it;
}

template <typename T>
T Number(const json& v, const std::string& where) {
  if (!v.is_number()) throw ReadError{where + " is not a number"};
  if constexpr (std::is_integral_v<T>) {
    if (!v.is_number_integer()) throw ReadError{where + " is not an integer"};
    if (v.is_number_unsigned() && v.get<uint64_t>() > static_cast<uint64_t>(std::numeric_limits<int64_t>::max())) {
      throw ReadError{where + " is out of range"};
    }
    const auto x = v.get<int64_t>();
    if (x < static_cast<int64_t>(std::numeric_limits<T>::min()) ||
        x > static_cast<int64_t>(std::numeric_limits<T>::max())) {
      throw ReadError{where + " is out of range"};
    }
    return static_cast<T>(x);
  } else {
    // A double beyond the float range converts with undefined behaviour: refused by name instead.
    const double x = v.get<double>();
    if (std::fabs(x) > static_cast<double>(std::numeric_limits<T>::max())) throw ReadError{where + " is out of range"};
    return static_cast<T>(x);
  }
}

const json& Array(const json& v, const std::string& where, size_t exact_size = 0) {
  if (!v.is_array()) throw ReadError{where + " is not an array"};
  if (exact_size && v.size() != exact_size) {
    throw ReadError{where + " has " + std::to_string(v.size()) + " entries, expected " + std::to_string(exact_size)};
  }
  return v;
}

template <typename T>
std::vector<T> Numbers(const json& v, const std::string& where) {
  std::vector<T> out;
  out.reserve(Array(v, where).size());
  for (const json& x : v) out.push_back(Number<T>(x, where));
  return out;
}

// The large arrays of version 2's "mesh", converted while the text is parsed (SetStream) and
// dropped from the document; `seen` records which ones the file had.
struct StreamedMesh {
  std::vector<uint32_t> triangles, influence_offsets;
  std::vector<float> positions, influence_weights;
  std::vector<uint16_t> influence_binds;
  std::vector<uint32_t> piece_points;
  std::vector<std::string> seen;
};

// Version 2's "mesh" (sphere_set.h): flat arrays; sizes and ranges are SphereSet::Validate()'s.
void ReadMesh(const json& m, StreamedMesh&& streamed, SphereSet* set) {
  const std::string where = "$.mesh";
  if (!m.is_object()) throw ReadError{where + " is not an object"};
  for (const char* key : {"triangles", "positions_bind", "influence_offsets", "influence_binds", "influence_weights"}) {
    if (std::find(streamed.seen.begin(), streamed.seen.end(), key) == streamed.seen.end()) {
      throw ReadError{where + "." + key + " is missing (or not an array)"};
    }
  }
  set->triangle_vertices = std::move(streamed.triangles);
  // "piece_points" (version 3, optional): (triangle, level, i, j) per grid point, flat.
  const std::vector<uint32_t>& points = streamed.piece_points;
  if (points.size() % 4 != 0) throw ReadError{where + ".piece_points does not hold whole (triangle, level, i, j)"};
  for (size_t k = 0; k < points.size(); k += 4) {
    if (points[k + 1] > kMaxPieceLevel || points[k + 2] > kMaxPieceLevel || points[k + 3] > kMaxPieceLevel) {
      throw ReadError{where + ".piece_points[" + std::to_string(k / 4) + "] has a level or coordinate above " +
                      std::to_string(kMaxPieceLevel)};
    }
    set->piece_points.push_back({points[k], static_cast<uint16_t>(points[k + 1]), static_cast<uint8_t>(points[k + 2]),
                                 static_cast<uint8_t>(points[k + 3])});
  }
  const std::vector<float>& positions = streamed.positions;
  if (positions.size() % 3 != 0) throw ReadError{where + ".positions_bind does not hold whole xyz triples"};
  skinning::SkinnedMesh& mesh = set->mesh;
  mesh.positions_bind.resize(positions.size() / 3);
  for (size_t v = 0; v < mesh.positions_bind.size(); ++v) {
    mesh.positions_bind[v] = Eigen::Vector3f(positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]);
  }
  const json& binds = Array(Field(m, "binds", where), where + ".binds");
  for (size_t b = 0; b < binds.size(); ++b) {
    const std::string at = where + ".binds[" + std::to_string(b) + "]";
    skinning::BindEntry entry;
    entry.joint = Number<int32_t>(Field(binds[b], "joint", at), at + ".joint");
    const json& ibm = Array(Field(binds[b], "inverse_bind", at), at + ".inverse_bind", 16);
    for (int e = 0; e < 16; ++e) entry.inverse_bind.data()[e] = Number<float>(ibm[e], at + ".inverse_bind");
    mesh.binds.push_back(entry);
  }
  mesh.influence_offsets = std::move(streamed.influence_offsets);
  mesh.influence_binds = std::move(streamed.influence_binds);
  mesh.influence_weights = std::move(streamed.influence_weights);
}

// One sphere's "reach_groups" (the last sphere's influences are its own): a row per group of
// 1 + K or 1 + 3 K numbers, *group_row (0 not known yet, 1 or 3) fixed by the first row that fits.
void ParseReachGroups(const json& groups, const std::string& where, SphereSet* set, int* group_row) {
  const size_t k_count = set->influence_offsets.back() - set->influence_offsets[set->influence_offsets.size() - 2];
  const json& list = Array(groups, where + ".reach_groups");
  if (list.empty() || list.size() > kMaxReachGroups) {
    throw ReadError{where + ".reach_groups has " + std::to_string(list.size()) + " groups (1 to " +
                    std::to_string(kMaxReachGroups) + ")"};
  }
  for (const json& g : list) {
    const json& row = Array(g, where + ".reach_groups[]");
    if (*group_row == 0 && (row.size() == 1 + k_count || row.size() == 1 + 3 * k_count)) {
      *group_row = row.size() == 1 + k_count ? 1 : 3;
    }
    const size_t expected = 1 + size_t(std::max(*group_row, 1)) * k_count;
    if (row.size() != expected) {
      throw ReadError{where + ".reach_groups[] has " + std::to_string(row.size()) + " entries, expected " +
                      std::to_string(expected) +
                      (*group_row == 0 ? " or " + std::to_string(1 + 3 * k_count) + " (with blends)" : std::string())};
    }
    set->reach_group_radii.push_back(Number<float>(row[0], where + ".reach_groups[][0]"));
    for (size_t k = 0; k < k_count; ++k) {
      set->reach_group_weights.push_back(Number<float>(row[1 + k], where + ".reach_groups[][]"));
    }
    for (size_t k = 0; k < k_count && *group_row == 3; ++k) {
      set->reach_group_blend.push_back(Number<float>(row[1 + k_count + k], where + ".reach_groups[][] (blend)"));
      set->reach_group_deviation.push_back(
          Number<float>(row[1 + 2 * k_count + k], where + ".reach_groups[][] (deviation)"));
    }
  }
  set->reach_group_offsets.push_back(static_cast<uint32_t>(set->reach_group_radii.size()));
}

// One element of "spheres", appended to the set's per-sphere arrays and CSR lists. "influence_reach"
// is optional, but all spheres have it or none does (the first sphere decides: *has_reach).
void ParseSphere(const json& sp, size_t s, SphereSet* set, bool* has_reach, bool* has_reference, bool* has_groups,
                 int* group_row) {
  const std::string where = "$.spheres[" + std::to_string(s) + "]";
  if (Number<uint32_t>(Field(sp, "id", where), where + ".id") != s) throw ReadError{where + ".id is not its index"};
  set->sphere_part.push_back(Number<uint16_t>(Field(sp, "part", where), where + ".part"));
  set->sphere_joint.push_back(Number<uint16_t>(Field(sp, "joint", where), where + ".joint"));
  set->sphere_level.push_back(Number<uint16_t>(Field(sp, "level", where), where + ".level"));
  const json& c = Array(Field(sp, "center", where), where + ".center", 3);
  set->centers_rest.emplace_back(Number<float>(c[0], where + ".center"), Number<float>(c[1], where + ".center"),
                                 Number<float>(c[2], where + ".center"));
  set->radii_rest.push_back(Number<float>(Field(sp, "radius", where), where + ".radius"));
  set->radii_fast.push_back(Number<float>(Field(sp, "radius_fast", where), where + ".radius_fast"));
  for (const json& v : Array(Field(sp, "vertices", where), where + ".vertices")) {
    set->vertices.push_back(Number<uint32_t>(v, where + ".vertices"));
  }
  set->vertex_offsets.push_back(static_cast<uint32_t>(set->vertices.size()));
  for (const json& v : Array(Field(sp, "triangles", where), where + ".triangles")) {
    set->triangles.push_back(Number<uint32_t>(v, where + ".triangles"));
  }
  set->triangle_offsets.push_back(static_cast<uint32_t>(set->triangles.size()));
  for (const json& v : Array(Field(sp, "influences", where), where + ".influences")) {
    const json& pair = Array(v, where + ".influences[]", 2);
    set->influence_joints.push_back(Number<uint16_t>(pair[0], where + ".influences[][0]"));
    set->influence_weights.push_back(Number<float>(pair[1], where + ".influences[][1]"));
  }
  const auto reach = sp.find("influence_reach");
  if (s == 0) *has_reach = reach != sp.end();
  if ((reach != sp.end()) != *has_reach) {
    throw ReadError{where + (*has_reach ? ".influence_reach is missing (the first sphere has one)"
                                        : ".influence_reach is given but the first sphere has none")};
  }
  if (*has_reach) {
    const size_t influences = set->influence_joints.size() - set->influence_offsets.back();
    for (const json& v : Array(*reach, where + ".influence_reach", influences)) {
      set->influence_reach.push_back(Number<float>(v, where + ".influence_reach"));
    }
    // Array() reads an exact size of 0 as any size: entries for a sphere without influences end here.
    if (set->influence_reach.size() != set->influence_joints.size()) {
      throw ReadError{where + ".influence_reach has " + std::to_string(reach->size()) + " entries, expected " +
                      std::to_string(influences)};
    }
  }
  set->influence_offsets.push_back(static_cast<uint32_t>(set->influence_joints.size()));
  // "pieces" (version 3, optional per sphere): (triangle, level, index) per piece, flat.
  if (const auto pieces = sp.find("pieces"); pieces != sp.end()) {
    const json& list = Array(*pieces, where + ".pieces");
    if (list.size() % 3 != 0) throw ReadError{where + ".pieces does not hold whole (triangle, level, index)"};
    for (size_t k = 0; k < list.size(); k += 3) {
      const auto level = Number<uint16_t>(list[k + 1], where + ".pieces"),
                 index = Number<uint16_t>(list[k + 2], where + ".pieces");
      set->pieces.push_back({Number<uint32_t>(list[k], where + ".pieces"), level, index});
    }
  }
  set->piece_offsets.push_back(static_cast<uint32_t>(set->pieces.size()));
  // "fast_reference" (sphere_set.h): optional, all spheres or none, like "influence_reach".
  const auto reference = sp.find("fast_reference");
  if (s == 0) *has_reference = reference != sp.end();
  if ((reference != sp.end()) != *has_reference) {
    throw ReadError{where + (*has_reference ? ".fast_reference is missing (the first sphere has one)"
                                            : ".fast_reference is given but the first sphere has none")};
  }
  // "reach_groups" (sphere_set.h): optional, all spheres or none; per group [radius, reach per
  // influence] or, with blends (every group of the file or none), [radius, reach, blend and deviation
  // per influence]: 1 + K or 1 + 3 K numbers. *group_row: 0 not known yet, 1 or 3.
  const auto groups = sp.find("reach_groups");
  if (s == 0) {
    *has_groups = groups != sp.end();
    if (*has_groups) set->reach_group_offsets = {0};
  }
  if ((groups != sp.end()) != *has_groups) {
    throw ReadError{where + (*has_groups ? ".reach_groups is missing (the first sphere has them)"
                                         : ".reach_groups is given but the first sphere has none")};
  }
  if (*has_groups) ParseReachGroups(*groups, where, set, group_row);
  if (*has_reference) {
    const json& r = Array(*reference, where + ".fast_reference", 4);
    set->fast_reference_spheres.emplace_back(
        Number<float>(r[0], where + ".fast_reference"), Number<float>(r[1], where + ".fast_reference"),
        Number<float>(r[2], where + ".fast_reference"), Number<float>(r[3], where + ".fast_reference"));
  }
}

// One element of "excluded_pairs".
void ParsePair(const json& pair, size_t k, SphereSet* set) {
  const std::string where = "$.excluded_pairs[" + std::to_string(k) + "]";
  const json& p = Array(pair, where, 3);
  if (!p[2].is_string()) throw ReadError{where + "[2] is not a reason string"};
  auto reason = ExclusionReasonFromString(p[2].get<std::string>());
  if (!reason) throw ReadError{where + " has unknown reason \"" + p[2].get<std::string>() + "\""};
  set->excluded_pairs.push_back({Number<uint32_t>(p[0], where), Number<uint32_t>(p[1], where), *reason});
}

// The parser callback of ReadSphereSetJson: each sphere, each excluded pair and each large "mesh"
// array is converted as soon as the parser completes it and then dropped from the document, so the
// document holds at most one of them at a time: reading peaks at about the text plus the set,
// where the whole document would be several times the text. (Depths as nlohmann counts them: the
// top object's members at 1, their elements at 2.)
class SetStream {
 public:
  SetStream() {
    set_.vertex_offsets = {0};
    set_.triangle_offsets = {0};
    set_.influence_offsets = {0};
    set_.piece_offsets = {0};
  }
  bool operator()(int depth, json::parse_event_t event, json& parsed) {
    using E = json::parse_event_t;
    if (depth > 2) return true;
    const size_t d = static_cast<size_t>(depth);
    switch (event) {
      case E::key: key_[d] = parsed.get<std::string>(); return true;
      case E::object_start:
      case E::array_start: array_[d] = event == E::array_start; return true;
      case E::object_end:
        if (d == 2 && array_[1] && key_[1] == "spheres") {
          ParseSphere(parsed, set_.size(), &set_, &has_reach_, &has_reference_, &has_groups_, &group_row_);
          return false;
        }
        return true;
      case E::array_end:
        if (d == 2 && array_[1] && key_[1] == "excluded_pairs") {
          ParsePair(parsed, set_.excluded_pairs.size(), &set_);
          return false;
        }
        if (d == 2 && !array_[1] && key_[1] == "mesh") return !TakeMeshArray(parsed);
        return true;
      case E::value: return true;
    }
    return true;
  }
  SphereSet TakeSet() { return std::move(set_); }
  StreamedMesh TakeMesh() { return std::move(mesh_); }

 private:
  bool TakeMeshArray(const json& a) {
    const std::string& key = key_[2];
    const std::string where = "$.mesh." + key;
    if (key == "triangles")
      mesh_.triangles = Numbers<uint32_t>(a, where);
    else if (key == "positions_bind")
      mesh_.positions = Numbers<float>(a, where);
    else if (key == "influence_offsets")
      mesh_.influence_offsets = Numbers<uint32_t>(a, where);
    else if (key == "influence_binds")
      mesh_.influence_binds = Numbers<uint16_t>(a, where);
    else if (key == "influence_weights")
      mesh_.influence_weights = Numbers<float>(a, where);
    else if (key == "piece_points")
      mesh_.piece_points = Numbers<uint32_t>(a, where);

    else
      return false;  // "binds" (small): read from the document
    mesh_.seen.push_back(key);
    return true;
  }
  SphereSet set_;
  bool has_reach_ = false;
  bool has_reference_ = false;
  bool has_groups_ = false;
  int group_row_ = 0;  // ParseSphere's group_row
  StreamedMesh mesh_;
  std::string key_[3];
  bool array_[3] = {false, false, false};
};

// "contact_rules" (version 4: required; before it: absent, the rules on sphere pairs as fitted).
void ReadContactRules(const json& j, int version, SphereSet* set) {
  const auto rules = j.find("contact_rules");
  if (version < kSphereSetVersionWithRules) {
    if (rules != j.end()) throw ReadError{"$.contact_rules is not part of version " + std::to_string(version)};
    set->contact_rules = ContactRules::kSpherePairs;
    set->contact_hops = 0;
    set->rest_gap = 0.0f;
    return;
  }
  if (rules == j.end()) throw ReadError{"$.contact_rules is missing"};
  const std::string where = "$.contact_rules";
  if (!rules->is_object()) throw ReadError{where + " is not an object"};
  const json& on = Field(*rules, "on", where);
  const auto kind = on.is_string() ? ContactRulesFromString(on.get<std::string>()) : std::nullopt;
  if (!kind) throw ReadError{where + ".on is not \"triangles\" or \"sphere_pairs\""};
  set->contact_rules = *kind;
  set->contact_hops = Number<uint32_t>(Field(*rules, "hops", where), where + ".hops");
  set->rest_gap = Number<float>(Field(*rules, "rest_gap", where), where + ".rest_gap");
}

// The rest of the document, once SetStream has taken the spheres, pairs and mesh arrays.
SphereSet Parse(const json& j, SetStream&& stream) {
  if (!j.is_object()) throw ReadError{"the top level is not an object"};
  const json& format = Field(j, "format", "$");
  if (!format.is_string() || format.get<std::string>() != kSphereSetFormat) {
    throw ReadError{std::string("not a sphere set (format is not \"") + kSphereSetFormat + "\")"};
  }
  const int version = Number<int>(Field(j, "version", "$"), "$.version");
  if (version < kSphereSetVersionWithoutMesh || version > kSphereSetVersionWithRules) {
    throw ReadError{"version " + std::to_string(version) + " is not supported (this build reads versions " +
                    std::to_string(kSphereSetVersionWithoutMesh) + " to " + std::to_string(kSphereSetVersionWithRules) +
                    ")"};
  }
  SphereSet set = stream.TakeSet();
  if (set.pieces.empty()) set.piece_offsets.clear();  // no sphere has pieces
  if (version < kSphereSetVersionWithPieces && !set.pieces.empty()) {
    throw ReadError{"$.spheres[].pieces is not part of version " + std::to_string(version)};
  }
  const json& source = Field(j, "source", "$");
  const json& file = Field(source, "file", "$.source");
  if (!file.is_string()) throw ReadError{"$.source.file is not a string"};
  set.source_file = file.get<std::string>();
  set.source_vertex_count = Number<uint32_t>(Field(source, "vertices", "$.source"), "$.source.vertices");
  set.source_triangle_count = Number<uint32_t>(Field(source, "triangles", "$.source"), "$.source.triangles");
  const json& params = Field(j, "params", "$");
  if (!params.is_object()) throw ReadError{"$.params is not an object"};
  set.params_json = params.dump();

  const json& joints = Array(Field(Field(j, "skeleton", "$"), "joints", "$.skeleton"), "$.skeleton.joints");
  for (size_t k = 0; k < joints.size(); ++k) {
    const std::string where = "$.skeleton.joints[" + std::to_string(k) + "]";
    const json& name = Field(joints[k], "name", where);
    if (!name.is_string()) throw ReadError{where + ".name is not a string"};
    set.joint_names.push_back(name.get<std::string>());
    set.joint_parents.push_back(Number<int32_t>(Field(joints[k], "parent", where), where + ".parent"));
    const json& m = Array(Field(joints[k], "rest_world", where), where + ".rest_world", 16);
    Mat4f mat;
    for (int e = 0; e < 16; ++e) mat.data()[e] = Number<float>(m[e], where + ".rest_world");
    set.joint_rest_world.push_back(mat);
    // "fast_reference_inverse" (sphere_set.h): optional, on every joint or none, and with the
    // spheres' "fast_reference".
    const auto reference = joints[k].find("fast_reference_inverse");
    const bool with_reference = !set.fast_reference_spheres.empty();
    if ((reference != joints[k].end()) != with_reference) {
      throw ReadError{where + (with_reference
                                   ? ".fast_reference_inverse is missing (the spheres have a fast_reference)"
                                   : ".fast_reference_inverse is given but the spheres have no fast_reference")};
    }
    if (with_reference) {
      const json& r = Array(*reference, where + ".fast_reference_inverse", 16);
      for (int e = 0; e < 16; ++e) mat.data()[e] = Number<float>(r[e], where + ".fast_reference_inverse");
      set.fast_reference_inverse.push_back(mat);
    }
  }

  const json& parts = Array(Field(j, "parts", "$"), "$.parts");
  for (size_t k = 0; k < parts.size(); ++k) {
    const std::string where = "$.parts[" + std::to_string(k) + "]";
    SpherePart part;
    const json& name = Field(parts[k], "name", where);
    if (!name.is_string()) throw ReadError{where + ".name is not a string"};
    part.name = name.get<std::string>();
    for (const json& v : Array(Field(parts[k], "joints", where), where + ".joints")) {
      part.joints.push_back(Number<uint32_t>(v, where + ".joints"));
    }
    set.parts.push_back(std::move(part));
  }

  Array(Field(j, "spheres", "$"), "$.spheres");                // its elements went to SetStream
  Array(Field(j, "excluded_pairs", "$"), "$.excluded_pairs");  // so did these
  ReadContactRules(j, version, &set);

  // Version 1 has no mesh, 2 and 3 have one, 4 may.
  if (version == kSphereSetVersionWithoutMesh || (version == kSphereSetVersionWithRules && !j.contains("mesh"))) {
    if (j.contains("mesh")) throw ReadError{"$.mesh is not part of version 1"};
    return set;
  }
  ReadMesh(Field(j, "mesh", "$"), stream.TakeMesh(), &set);
  if (version < kSphereSetVersionWithPieces && !set.piece_points.empty()) {
    throw ReadError{"$.mesh.piece_points is not part of version " + std::to_string(version)};
  }
  return set;
}

}  // namespace

Result<SphereSet> ReadSphereSetJson(std::string_view text, const std::string& source_name) {
  // Nesting checked first (file_io.h): the parse is iterative, a copy or a dump of a deep value
  // (params is kept as text) is not.
  if (const size_t depth = ScanJson(text).depth; depth > kMaxJsonDepth) {
    return MakeError(ErrorCode::kFormatRejected, source_name + ": the JSON nests " + std::to_string(depth) +
                                                     " deep (at most " + std::to_string(kMaxJsonDepth) + " is read)");
  }
  try {
    SetStream stream;
    json j = json::parse(text, std::ref(stream), /*allow_exceptions=*/false);
    if (j.is_discarded()) {
      return MakeError(ErrorCode::kFormatRejected, source_name + ": not valid JSON (malformed or truncated)");
    }
    SphereSet set = Parse(j, std::move(stream));
    if (auto err = set.Validate()) {
      return MakeError(ErrorCode::kInvalidData, OneLine(source_name + ": " + err->message));
    }
    set.loaded_from = source_name;
    return set;
  } catch (const ReadError& e) {
    const bool version = e.what.rfind("version", 0) == 0;
    // OneLine: a message may quote a string of the file (an unknown reason, a name), which JSON
    // escapes can fill with newlines or NULs.
    return MakeError(version ? ErrorCode::kVersionMismatch : ErrorCode::kInvalidData,
                     OneLine(source_name + ": " + e.what));
  } catch (const json::exception& e) {
    return MakeError(ErrorCode::kInvalidData, OneLine(source_name + ": " + e.what()));
  } catch (const std::bad_alloc&) {
    return MakeError(ErrorCode::kFormatRejected,
                     OneLine(source_name + ": implausible sizes (out of memory while reading)"));
  }
}

std::optional<SphereSetFileFormat> SphereSetFormatForPath(const std::filesystem::path& path) {
  const std::string ext = path.extension().string();
  if (ext == ".json") return SphereSetFileFormat::kJson;
  if (ext == ".ssb") return SphereSetFileFormat::kBinary;
  return std::nullopt;
}

std::optional<Error> SaveSphereSet(const SphereSet& set, const std::filesystem::path& path,
                                   SphereSetFileFormat format) {
  if (format == SphereSetFileFormat::kBinary) return SaveSphereSetBinary(set, path);
  if (format == SphereSetFileFormat::kBinaryFastOnly)
    return SaveSphereSetBinary(set, path, SphereSetBinaryContent::kFastOnly);
  if (set.fast_only) {
    return MakeError(ErrorCode::kInvalidArgument, PathText(path) + ": a fast-only sphere set (" +
                                                      (set.loaded_from.empty() ? "no vertex lists" : set.loaded_from) +
                                                      ") cannot be written as JSON, which holds the whole set");
  }
  // Checked through the close (file_io.h): a full disk is an error, never a truncated set.
  CheckedFileWriter out(path);
  out.Write(WriteSphereSetJson(set));
  out.Write("\n");
  return out.Close();
}

std::optional<Error> SaveSphereSet(const SphereSet& set, const std::filesystem::path& path) {
  return SaveSphereSet(set, path, SphereSetFormatForPath(path).value_or(SphereSetFileFormat::kJson));
}

Result<SphereSet> ReadSphereSet(std::span<const std::byte> bytes, const std::string& source_name) {
  if (IsSphereSetBinary(bytes)) return ReadSphereSetBinary(bytes, source_name);
  // Shorter than the binary magic: neither format (the smallest JSON set is far longer).
  if (bytes.empty()) return MakeError(ErrorCode::kFormatRejected, source_name + ": empty file");
  if (bytes.size() < sizeof kSphereSetBinaryMagic) {
    return MakeError(ErrorCode::kFormatRejected,
                     source_name + ": too short to be a sphere set (" + std::to_string(bytes.size()) + " bytes)");
  }
  return ReadSphereSetJson(std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()), source_name);
}

Result<SphereSet> LoadSphereSet(const std::filesystem::path& path) {
  // A regular file only, at most kMaxSphereSetBytes, refused from its size (file_io.h).
  auto bytes = ReadSphereSetFile(path);
  if (!bytes.ok()) return bytes.error();
  return ReadSphereSet(*bytes, PathText(path));
}

}  // namespace skinspheres::runtime
