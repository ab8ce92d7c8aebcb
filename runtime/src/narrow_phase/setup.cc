// NarrowPhaseData::Create (narrow_phase.h) as the named stages internal.h lists, in order.
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <tuple>
#include <unordered_map>
#include <vector>

#include "narrow_phase/internal.h"
#include "skinspheres/skinning/skinning_job.h"
#include "skinspheres/skinning/skinning_matrices_job.h"

namespace skinspheres::runtime::narrow_phase {

bool RestPositions(const SphereSet& set, std::vector<Eigen::Vector3f>* out) {
  const skinning::SkinnedMesh& mesh = set.mesh;
  std::vector<Mat4f> matrices(mesh.binds.size());
  if (!skinning::SkinningMatricesJob{mesh.binds, set.joint_rest_world, matrices}.Run()) return false;
  out->assign(mesh.vertex_count(), Eigen::Vector3f::Zero());
  skinning::SkinningJob job;
  job.joint_matrices = matrices;
  job.vertex_count = mesh.vertex_count();
  job.in_positions = {reinterpret_cast<const float*>(mesh.positions_bind.data()), 3 * mesh.vertex_count()};
  job.out_positions = {reinterpret_cast<float*>(out->data()), 3 * out->size()};
  job.influence_offsets = mesh.influence_offsets;
  job.influence_binds = mesh.influence_binds;
  job.influence_weights = mesh.influence_weights;
  return mesh.vertex_count() == 0 || job.Run();
}

void SphereItems(const SphereSet& set, NarrowPhaseData::Layout& d) {
  d.triangle_count = set.source_triangle_count;
  d.piece_items.clear();
  d.sphere_item_offsets.assign(1, 0);
  d.sphere_items.clear();
  for (size_t s = 0; s < set.size(); ++s) {
    d.sphere_items.insert(d.sphere_items.end(), set.triangles.begin() + set.triangle_offsets[s],
                          set.triangles.begin() + set.triangle_offsets[s + 1]);
    for (const TrianglePiece& p : set.PiecesOf(s)) {
      NarrowPhaseData::Layout::PieceItem item{p.triangle, p.level, {}};
      PieceCorners(p.level, p.index, item.corners);  // in range: Validate()
      d.sphere_items.push_back(d.triangle_count + static_cast<uint32_t>(d.piece_items.size()));
      d.piece_items.push_back(item);
    }
    d.sphere_item_offsets.push_back(static_cast<uint32_t>(d.sphere_items.size()));
  }
}

void BuildClusters(const SphereSet& set, NarrowPhaseData* d) {
  const auto& rest = Of(*d).rest_positions;
  auto centroid = [&](uint32_t id) {
    Eigen::Vector3f c[3];
    ItemCorners(set, Of(*d), rest.data(), nullptr, id, c);
    return Eigen::Vector3f((c[0] + c[1] + c[2]) / 3.0f);
  };
  Of(*d).cluster_offsets.assign(1, 0);
  Of(*d).cluster_triangle_offsets.assign(1, 0);
  Of(*d).cluster_vertex_offsets.assign(1, 0);
  Of(*d).cluster_grid_offsets.assign(1, 0);
  Of(*d).piece_corner_refs.assign(Of(*d).piece_items.size(), {});
  std::vector<uint32_t> tris, verts;
  std::vector<PiecePoint> grid;
  auto key = [](const PiecePoint& g) { return std::tuple(g.triangle, g.level, g.i, g.j); };
  struct Range {
    size_t begin, end;
  };
  std::vector<Range> stack;
  for (size_t s = 0; s < set.size(); ++s) {
    tris.assign(Of(*d).sphere_items.begin() + Of(*d).sphere_item_offsets[s],
                Of(*d).sphere_items.begin() + Of(*d).sphere_item_offsets[s + 1]);
    stack.clear();
    if (!tris.empty()) stack.push_back({0, tris.size()});
    std::vector<Range> leaves;
    while (!stack.empty()) {
      const Range r = stack.back();
      stack.pop_back();
      if (r.end - r.begin <= Of(*d).settings.cluster_triangles) {
        leaves.push_back(r);
        continue;
      }
      Eigen::AlignedBox3f box;
      for (size_t k = r.begin; k < r.end; ++k) box.extend(centroid(tris[k]));
      int axis;
      box.sizes().maxCoeff(&axis);
      const size_t mid = (r.begin + r.end) / 2;
      std::nth_element(tris.begin() + r.begin, tris.begin() + mid, tris.begin() + r.end, [&](uint32_t a, uint32_t b) {
        const float ca = centroid(a)[axis], cb = centroid(b)[axis];
        return ca != cb ? ca < cb : a < b;
      });
      stack.push_back({mid, r.end});
      stack.push_back({r.begin, mid});
    }
    std::sort(leaves.begin(), leaves.end(), [](const Range& a, const Range& b) { return a.begin < b.begin; });
    for (const Range& r : leaves) {
      verts.clear();
      grid.clear();
      for (size_t k = r.begin; k < r.end; ++k) {
        const uint32_t id = tris[k];
        Of(*d).cluster_triangles.push_back(id);
        const uint32_t t = ItemTriangle(Of(*d), id);
        const uint32_t* v = set.triangle_vertices.data() + 3 * size_t{t};
        if (id < Of(*d).triangle_count) {
          verts.insert(verts.end(), v, v + 3);
          continue;
        }
        const NarrowPhaseData::Layout::PieceItem& p = Of(*d).piece_items[id - Of(*d).triangle_count];
        for (const auto& ij : p.corners) {
          const int corner = GridCorner(p.level, ij[0], ij[1]);
          if (corner >= 0) {
            verts.push_back(v[corner]);
          } else {
            grid.push_back(PiecePoint{t, p.level, ij[0], ij[1]});
          }
        }
      }
      std::sort(verts.begin(), verts.end());
      verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
      std::sort(grid.begin(), grid.end(), [&](const PiecePoint& a, const PiecePoint& b) { return key(a) < key(b); });
      grid.erase(std::unique(grid.begin(), grid.end()), grid.end());
      // Each piece's corners: a vertex, or where its grid point sits in this cluster's range.
      const uint32_t grid_base = uint32_t(Of(*d).cluster_grid.size());
      for (size_t k = r.begin; k < r.end; ++k) {
        const uint32_t id = tris[k];
        if (id < Of(*d).triangle_count) continue;
        const NarrowPhaseData::Layout::PieceItem& p = Of(*d).piece_items[id - Of(*d).triangle_count];
        const uint32_t* v = set.triangle_vertices.data() + 3 * size_t{p.triangle};
        auto& refs = Of(*d).piece_corner_refs[id - Of(*d).triangle_count];
        for (int c = 0; c < 3; ++c) {
          const PiecePoint g{p.triangle, p.level, p.corners[c][0], p.corners[c][1]};
          const int corner = GridCorner(g.level, g.i, g.j);
          if (corner >= 0) {
            refs[c] = v[corner];
            continue;
          }
          const auto at = std::lower_bound(grid.begin(), grid.end(), g,
                                           [&](const PiecePoint& a, const PiecePoint& b) { return key(a) < key(b); });
          refs[c] = NarrowPhaseData::Layout::kGridRef | (grid_base + uint32_t(at - grid.begin()));
        }
      }
      Of(*d).cluster_vertices.insert(Of(*d).cluster_vertices.end(), verts.begin(), verts.end());
      Of(*d).cluster_grid.insert(Of(*d).cluster_grid.end(), grid.begin(), grid.end());
      Of(*d).cluster_triangle_offsets.push_back(uint32_t(Of(*d).cluster_triangles.size()));
      Of(*d).cluster_vertex_offsets.push_back(uint32_t(Of(*d).cluster_vertices.size()));
      Of(*d).cluster_grid_offsets.push_back(uint32_t(Of(*d).cluster_grid.size()));
    }
    Of(*d).cluster_offsets.push_back(uint32_t(Of(*d).cluster_vertex_offsets.size() - 1));
  }
}

bool BuildVertexGroups(const SphereSet& set, NarrowPhaseData* d) {
  const size_t vertices = set.source_vertex_count;
  std::vector<std::vector<uint32_t>> spheres_of(vertices);
  for (uint32_t s = 0; s < set.size(); ++s) {
    for (uint32_t k = Of(*d).sphere_vertex_offsets[s]; k < Of(*d).sphere_vertex_offsets[s + 1]; ++k) {
      spheres_of[Of(*d).sphere_vertices[k]].push_back(s);  // ascending s
    }
  }
  std::map<std::vector<uint32_t>, uint32_t> group_of;
  std::vector<std::vector<uint32_t>> members;
  for (uint32_t v = 0; v < vertices; ++v) {
    if (spheres_of[v].empty()) continue;
    auto [it, added] = group_of.emplace(spheres_of[v], uint32_t(members.size()));
    if (added) members.emplace_back();
    members[it->second].push_back(v);
  }
  const skinning::SkinnedMesh& mesh = set.mesh;
  std::vector<uint32_t> subset;
  for (const auto& m : members) subset.insert(subset.end(), m.begin(), m.end());
  if (!Of(*d).lazy_influences.Build(mesh.vertex_count(), mesh.influence_offsets, mesh.influence_binds,
                                    mesh.influence_weights, subset)) {
    return false;
  }
  // Runs: for each influence count (the layout's groups, ascending), each vertex group's members
  // with that count, in group order.
  const size_t groups = members.size();
  Of(*d).run_begin.assign(1, 0);
  std::vector<std::vector<uint32_t>> runs_of(groups);
  for (const skinning::PreparedInfluences::Group& layout : Of(*d).lazy_influences.groups()) {
    for (size_t g = 0; g < groups; ++g) {
      uint32_t length = 0;
      for (uint32_t v : members[g]) {
        length += mesh.influence_offsets[v + 1] - mesh.influence_offsets[v] == layout.influence_count;
      }
      if (length == 0) continue;
      runs_of[g].push_back(uint32_t(Of(*d).run_begin.size() - 1));
      Of(*d).run_begin.push_back(Of(*d).run_begin.back() + length);
    }
  }
  if (Of(*d).run_begin.back() != Of(*d).lazy_influences.size()) return false;
  Of(*d).group_run_offsets.assign(1, 0);
  Of(*d).group_sizes.clear();
  for (size_t g = 0; g < groups; ++g) {
    Of(*d).group_runs.insert(Of(*d).group_runs.end(), runs_of[g].begin(), runs_of[g].end());
    Of(*d).group_run_offsets.push_back(uint32_t(Of(*d).group_runs.size()));
    Of(*d).group_sizes.push_back(uint32_t(members[g].size()));
  }
  std::vector<std::vector<uint32_t>> groups_of(set.size());
  for (const auto& [spheres, g] : group_of) {
    for (uint32_t s : spheres) groups_of[s].push_back(g);
  }
  Of(*d).sphere_group_offsets.assign(1, 0);
  for (auto& list : groups_of) {
    std::sort(list.begin(), list.end());
    Of(*d).sphere_groups.insert(Of(*d).sphere_groups.end(), list.begin(), list.end());
    Of(*d).sphere_group_offsets.push_back(uint32_t(Of(*d).sphere_groups.size()));
  }
  // Per sphere, its groups' runs as the non-zero words of a run bitset.
  Of(*d).sphere_run_offsets.assign(1, 0);
  std::vector<uint32_t> runs;
  for (const auto& list : groups_of) {
    runs.clear();
    for (uint32_t g : list) {
      for (uint32_t k = Of(*d).group_run_offsets[g]; k < Of(*d).group_run_offsets[g + 1]; ++k)
        runs.push_back(Of(*d).group_runs[k]);
    }
    std::sort(runs.begin(), runs.end());
    for (uint32_t r : runs) {
      if (Of(*d).sphere_run_words.size() == Of(*d).sphere_run_offsets.back() ||
          Of(*d).sphere_run_words.back() != r >> 6) {
        Of(*d).sphere_run_words.push_back(r >> 6);
        Of(*d).sphere_run_bits.push_back(0);
      }
      Of(*d).sphere_run_bits.back() |= uint64_t{1} << (r & 63);
    }
    Of(*d).sphere_run_offsets.push_back(uint32_t(Of(*d).sphere_run_words.size()));
  }
  return true;
}

namespace {

// Stage 1: what the set, the filter and the settings must be.
std::optional<Error> CheckInputs(const SphereSet& set, const PairFilter& filter, const NarrowPhaseSettings& settings,
                                 const std::string& who) {
  if (!set.has_mesh()) {
    return MakeError(
        ErrorCode::kVersionMismatch,
        who + " has no mesh (format version 1): the narrow phase needs a version-2 set; fit the character again");
  }
  if (auto err = set.Validate()) return MakeError(err->code, who + ": " + err->message);
  if (uint64_t{set.source_triangle_count} + set.pieces.size() > UINT32_MAX) {  // item ids (internal.h)
    return MakeError(ErrorCode::kInvalidData, who + ": more triangles and pieces than 32-bit ids can name");
  }
  if (filter.size() != set.size()) {
    return MakeError(ErrorCode::kInvalidArgument, who + ": the pair filter has " + std::to_string(filter.size()) +
                                                      " spheres, the set " + std::to_string(set.size()));
  }
  if (!(settings.margin >= 0.0f) || !std::isfinite(settings.margin)) {
    return MakeError(ErrorCode::kInvalidArgument, who + ": the narrow-phase margin must be finite and >= 0");
  }
  if (!(settings.touch_tolerance_share >= 0.0f && settings.touch_tolerance_share < 1.0f)) {
    return MakeError(ErrorCode::kInvalidArgument,
                     who + ": the touch tolerance must be a share of the body height in [0, 1)");
  }
  if (settings.cluster_triangles < 1 || settings.cluster_triangles > 256) {
    return MakeError(ErrorCode::kInvalidArgument, who + ": the narrow-phase cluster size must be 1..256 triangles");
  }
  return std::nullopt;
}

// Stage 2: the mesh at rest, finite, its height (for the touch tolerance), and the margin against
// its size. A margin is a contact distance, not a search radius: the rest-pose exclusions (and a
// frame's contacts) grow with the square of the triangle count within it. Xbot (1.8 units tall) at a margin of 0.1
// peaked at 290 MB, at 0.18 at 2.7 GB and 100 s of set-up, at 1e30 past 4 GB. Refused beyond the limit, with the size,
// so the caller can choose.
std::optional<Error> RestMesh(const SphereSet& set, const NarrowPhaseSettings& settings, const std::string& who,
                              NarrowPhaseData::Layout& d) {
  if (!RestPositions(set, &d.rest_positions)) {
    return MakeError(ErrorCode::kInvalidData,
                     who + ": the mesh cannot be skinned at rest (bind entries and skeleton disagree)");
  }
  Eigen::Vector3f low = Eigen::Vector3f::Constant(std::numeric_limits<float>::max()), high = -low;
  for (const auto& p : d.rest_positions) {
    if (!p.allFinite()) return MakeError(ErrorCode::kInvalidData, who + ": the mesh skinned at rest is not finite");
    low = low.cwiseMin(p);
    high = high.cwiseMax(p);
  }
  const float size = d.rest_positions.empty() ? 0.0f : (high - low).maxCoeff();
  d.rest_height = d.rest_positions.empty() ? 0.0f : high.y() - low.y();
  if (settings.margin > kMaxMarginShareOfSize * size) {
    char text[200];
    std::snprintf(text, sizeof text,
                  ": the narrow-phase margin %g is more than %g of the character's rest size (%g units, its largest "
                  "extent): a contact distance, not a search radius",
                  double(settings.margin), double(kMaxMarginShareOfSize), double(size));
    return MakeError(ErrorCode::kInvalidArgument, who + text);
  }
  return std::nullopt;
}

// Stage 3, rule 2: vertices with bit-identical rest positions (-0 and +0 alike) welded; returns
// each vertex's canonical id (the first with its position) and writes the welded triangles.
std::vector<uint32_t> WeldVertices(const SphereSet& set, NarrowPhaseData::Layout& d) {
  const size_t vertices = set.source_vertex_count;
  std::vector<uint32_t> canonical(vertices);
  struct KeyHash {
    size_t operator()(const std::array<uint32_t, 3>& k) const {
      return (size_t{k[0]} * 0x9E3779B97F4A7C15ull) ^ (size_t{k[1]} * 0xC2B2AE3D27D4EB4Full) ^
             (size_t{k[2]} * 0x165667B19E3779F9ull);
    }
  };
  std::unordered_map<std::array<uint32_t, 3>, uint32_t, KeyHash> first;
  first.reserve(vertices);
  for (uint32_t v = 0; v < vertices; ++v) {
    std::array<uint32_t, 3> key;
    for (int k = 0; k < 3; ++k) {
      const float x = d.rest_positions[v][k] + 0.0f;  // -0 -> +0
      std::memcpy(&key[k], &x, sizeof(float));
    }
    canonical[v] = first.emplace(key, v).first->second;
  }
  d.welded.resize(set.triangle_vertices.size());
  for (size_t k = 0; k < set.triangle_vertices.size(); ++k) d.welded[k] = canonical[set.triangle_vertices[k]];
  return canonical;
}

// Stage 4: each sphere's items, the vertices of their triangles, and its largest item list.
void SphereVertices(const SphereSet& set, NarrowPhaseData::Layout& d) {
  SphereItems(set, d);
  d.sphere_vertex_offsets.assign(1, 0);
  std::vector<uint32_t> list;
  for (size_t s = 0; s < set.size(); ++s) {
    list.clear();
    for (uint32_t k = d.sphere_item_offsets[s]; k < d.sphere_item_offsets[s + 1]; ++k) {
      const uint32_t t = ItemTriangle(d, d.sphere_items[k]);
      for (int c = 0; c < 3; ++c) list.push_back(set.triangle_vertices[3 * size_t{t} + c]);
    }
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
    d.sphere_vertices.insert(d.sphere_vertices.end(), list.begin(), list.end());
    d.sphere_vertex_offsets.push_back(uint32_t(d.sphere_vertices.size()));
    d.max_sphere_triangles =
        std::max<size_t>(d.max_sphere_triangles, d.sphere_item_offsets[s + 1] - d.sphere_item_offsets[s]);
  }
}

// Stage 7: neighbours for the depth estimate: same part, and overlapping at rest or sharing a
// (welded) vertex.
void Neighbours(const SphereSet& set, const std::vector<uint32_t>& canonical, NarrowPhaseData::Layout& d) {
  const size_t n = set.size();
  std::vector<std::vector<uint32_t>> spheres_of(set.source_vertex_count);
  for (uint32_t s = 0; s < n; ++s) {
    for (uint32_t k = d.sphere_vertex_offsets[s]; k < d.sphere_vertex_offsets[s + 1]; ++k) {
      auto& owners = spheres_of[canonical[d.sphere_vertices[k]]];
      if (owners.empty() || owners.back() != s) owners.push_back(s);
    }
  }
  std::vector<std::vector<uint32_t>> adjacent(n);
  for (const auto& owners : spheres_of) {
    for (size_t x = 0; x < owners.size(); ++x) {
      for (size_t y = x + 1; y < owners.size(); ++y) {
        if (set.sphere_part[owners[x]] != set.sphere_part[owners[y]]) continue;
        adjacent[owners[x]].push_back(owners[y]);
        adjacent[owners[y]].push_back(owners[x]);
      }
    }
  }
  for (uint32_t i = 0; i < n; ++i) {
    for (uint32_t j = i + 1; j < n; ++j) {
      if (set.sphere_part[i] != set.sphere_part[j]) continue;
      const float reach = set.radii_rest[i] + set.radii_rest[j];
      if ((set.centers_rest[i] - set.centers_rest[j]).squaredNorm() <= reach * reach) {
        adjacent[i].push_back(j);
        adjacent[j].push_back(i);
      }
    }
  }
  d.neighbour_offsets.assign(1, 0);
  for (auto& a : adjacent) {
    std::sort(a.begin(), a.end());
    a.erase(std::unique(a.begin(), a.end()), a.end());
    d.neighbours.insert(d.neighbours.end(), a.begin(), a.end());
    d.neighbour_offsets.push_back(uint32_t(d.neighbours.size()));
  }
}

// Stage 8, rule 3: every pair the runtime could test that intersects or lies within the margin at
// rest (the oracle's all pairs, with the rule itself off).
void RestExclusions(const SphereSet& set, const PairFilter& filter, NarrowPhaseData& data) {
  NarrowPhaseData::Layout& d = Of(data);
  const Frame rest{set, data, d.rest_positions.data(), d.settings.margin, /*rest_rule=*/false};
  std::vector<Hit> hits;
  AllPairs(rest, filter, &hits);
  d.rest_excluded.reserve(hits.size());
  for (const auto& h : hits) d.rest_excluded.push_back((uint64_t{std::min(h.t, h.u)} << 32) | std::max(h.t, h.u));
  std::sort(d.rest_excluded.begin(), d.rest_excluded.end());
  d.rest_excluded.erase(std::unique(d.rest_excluded.begin(), d.rest_excluded.end()), d.rest_excluded.end());
}

}  // namespace
}  // namespace skinspheres::runtime::narrow_phase

namespace skinspheres::runtime {

Result<NarrowPhaseData> NarrowPhaseData::Create(const SphereSet& set, const PairFilter& filter,
                                                const NarrowPhaseSettings& settings) {
  using namespace narrow_phase;
  const std::string who = "sphere set '" + set.source_file + "'";
  if (auto err = CheckInputs(set, filter, settings, who)) return *err;
  NarrowPhaseData data;
  Layout& d = Of(data);
  d.settings = settings;
  if (auto err = RestMesh(set, settings, who, d)) return *err;
  const std::vector<uint32_t> canonical = WeldVertices(set, d);
  SphereVertices(set, d);
  BuildClusters(set, &data);
  if (!BuildVertexGroups(set, &data)) {
    return MakeError(ErrorCode::kInvalidData, who + ": the mesh's influences do not fit its bind entries");
  }
  for (size_t s = 0; s < set.size(); ++s) {
    d.max_sphere_clusters = std::max<size_t>(d.max_sphere_clusters, d.cluster_offsets[s + 1] - d.cluster_offsets[s]);
  }
  Neighbours(set, canonical, d);
  RestExclusions(set, filter, data);
  return data;
}

}  // namespace skinspheres::runtime
