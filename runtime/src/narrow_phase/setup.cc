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
#include <span>
#include <string>
#include <tuple>
#include <unordered_map>
#include <vector>

#include "narrow_phase/internal.h"
#include "skinspheres/runtime/narrow_phase/triangle_contact.h"
#include "skinspheres/skinning/skinning_job.h"
#include "skinspheres/skinning/skinning_matrices_job.h"

namespace skinspheres::runtime::narrow_phase {

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

namespace {

// A run [begin, end) of one sphere's items.
struct ItemRange {
  size_t begin, end;
};

auto PointKey(const PiecePoint& g) { return std::tuple(g.triangle, g.level, g.i, g.j); }

// The joint whose run an item's cluster belongs to: its triangle's rule-2 joint (kTriangles), else 0.
uint16_t ClusterJoint(const NarrowPhaseData::Layout& d, uint32_t id) {
  return d.rules == ContactRules::kTriangles ? d.triangle_joint[ItemTriangle(d, id)] : uint16_t{0};
}

// One sphere's items (`items`, reordered in place) cut into clusters: one run per joint (rule 2 is
// then a cluster pair's), in joint order, stable; each run split at the median of its rest
// centroids along the longest axis until it has at most settings.cluster_triangles. In order.
std::vector<ItemRange> ClusterRanges(const SphereSet& set, const NarrowPhaseData::Layout& d,
                                     std::vector<uint32_t>& items) {
  auto centroid = [&](uint32_t id) {
    Eigen::Vector3f c[3];
    ItemCorners(set, d, d.rest_positions.data(), nullptr, id, c);
    return Eigen::Vector3f((c[0] + c[1] + c[2]) / 3.0f);
  };
  auto joint = [&](uint32_t id) { return ClusterJoint(d, id); };
  std::stable_sort(items.begin(), items.end(), [&](uint32_t a, uint32_t b) { return joint(a) < joint(b); });
  std::vector<ItemRange> stack;
  for (size_t begin = 0; begin < items.size();) {
    size_t end = begin + 1;
    while (end < items.size() && joint(items[end]) == joint(items[begin])) ++end;
    stack.push_back({begin, end});
    begin = end;
  }
  std::reverse(stack.begin(), stack.end());
  std::vector<ItemRange> leaves;
  while (!stack.empty()) {
    const ItemRange r = stack.back();
    stack.pop_back();
    if (r.end - r.begin <= d.settings.cluster_triangles) {
      leaves.push_back(r);
      continue;
    }
    Eigen::AlignedBox3f box;
    for (size_t k = r.begin; k < r.end; ++k) box.extend(centroid(items[k]));
    int axis;
    box.sizes().maxCoeff(&axis);
    const size_t mid = (r.begin + r.end) / 2;
    std::nth_element(items.begin() + r.begin, items.begin() + mid, items.begin() + r.end, [&](uint32_t a, uint32_t b) {
      const float ca = centroid(a)[axis], cb = centroid(b)[axis];
      return ca != cb ? ca < cb : a < b;
    });
    stack.push_back({mid, r.end});
    stack.push_back({r.begin, mid});
  }
  std::sort(leaves.begin(), leaves.end(), [](const ItemRange& a, const ItemRange& b) { return a.begin < b.begin; });
  return leaves;
}

// A cluster's points: its items' vertices and the grid points of its pieces' corners that are not
// vertices, each sorted and once.
void ClusterPoints(const SphereSet& set, const NarrowPhaseData::Layout& d, std::span<const uint32_t> items,
                   std::vector<uint32_t>* verts, std::vector<PiecePoint>* grid) {
  verts->clear();
  grid->clear();
  for (const uint32_t id : items) {
    const uint32_t t = ItemTriangle(d, id);
    const uint32_t* v = set.triangle_vertices.data() + 3 * size_t{t};
    if (id < d.triangle_count) {
      verts->insert(verts->end(), v, v + 3);
      continue;
    }
    const NarrowPhaseData::Layout::PieceItem& p = d.piece_items[id - d.triangle_count];
    for (const auto& ij : p.corners) {
      const int corner = GridCorner(p.level, ij[0], ij[1]);
      if (corner >= 0) {
        verts->push_back(v[corner]);
      } else {
        grid->push_back(PiecePoint{t, p.level, ij[0], ij[1]});
      }
    }
  }
  std::sort(verts->begin(), verts->end());
  verts->erase(std::unique(verts->begin(), verts->end()), verts->end());
  std::sort(grid->begin(), grid->end(),
            [&](const PiecePoint& a, const PiecePoint& b) { return PointKey(a) < PointKey(b); });
  grid->erase(std::unique(grid->begin(), grid->end()), grid->end());
}

// Each piece's corners: a vertex, or where its grid point sits in this cluster's range (`grid`,
// from grid_base on in cluster_grid).
void PieceCornerRefs(const SphereSet& set, NarrowPhaseData::Layout& d, std::span<const uint32_t> items,
                     const std::vector<PiecePoint>& grid, uint32_t grid_base) {
  for (const uint32_t id : items) {
    if (id < d.triangle_count) continue;
    const NarrowPhaseData::Layout::PieceItem& p = d.piece_items[id - d.triangle_count];
    const uint32_t* v = set.triangle_vertices.data() + 3 * size_t{p.triangle};
    auto& refs = d.piece_corner_refs[id - d.triangle_count];
    for (int c = 0; c < 3; ++c) {
      const PiecePoint g{p.triangle, p.level, p.corners[c][0], p.corners[c][1]};
      const int corner = GridCorner(g.level, g.i, g.j);
      if (corner >= 0) {
        refs[c] = v[corner];
        continue;
      }
      const auto at = std::lower_bound(grid.begin(), grid.end(), g, [&](const PiecePoint& a, const PiecePoint& b) {
        return PointKey(a) < PointKey(b);
      });
      refs[c] = NarrowPhaseData::Layout::kGridRef | (grid_base + uint32_t(at - grid.begin()));
    }
  }
}

}  // namespace

void BuildClusters(const SphereSet& set, NarrowPhaseData* data) {
  NarrowPhaseData::Layout& d = Of(*data);
  d.cluster_offsets.assign(1, 0);
  d.cluster_triangle_offsets.assign(1, 0);
  d.cluster_vertex_offsets.assign(1, 0);
  d.cluster_grid_offsets.assign(1, 0);
  d.piece_corner_refs.assign(d.piece_items.size(), {});
  d.cluster_joint.clear();
  std::vector<uint32_t> items, verts;
  std::vector<PiecePoint> grid;
  for (size_t s = 0; s < set.size(); ++s) {
    items.assign(d.sphere_items.begin() + d.sphere_item_offsets[s],
                 d.sphere_items.begin() + d.sphere_item_offsets[s + 1]);
    for (const ItemRange& r : ClusterRanges(set, d, items)) {
      const std::span<const uint32_t> cluster(items.data() + r.begin, r.end - r.begin);
      d.cluster_triangles.insert(d.cluster_triangles.end(), cluster.begin(), cluster.end());
      ClusterPoints(set, d, cluster, &verts, &grid);
      PieceCornerRefs(set, d, cluster, grid, uint32_t(d.cluster_grid.size()));
      d.cluster_joint.push_back(ClusterJoint(d, cluster[0]));
      d.cluster_vertices.insert(d.cluster_vertices.end(), verts.begin(), verts.end());
      d.cluster_grid.insert(d.cluster_grid.end(), grid.begin(), grid.end());
      d.cluster_triangle_offsets.push_back(uint32_t(d.cluster_triangles.size()));
      d.cluster_vertex_offsets.push_back(uint32_t(d.cluster_vertices.size()));
      d.cluster_grid_offsets.push_back(uint32_t(d.cluster_grid.size()));
    }
    d.cluster_offsets.push_back(uint32_t(d.cluster_vertex_offsets.size() - 1));
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
// its size. A margin is a contact distance, not a search radius: a frame's contacts, and the pairs
// rule 3 must measure at rest, grow with the square of the triangle count within it (a margin of a
// tenth of the height makes every triangle of a limb a candidate of every other). Refused beyond the
// limit, with the size, so the caller can choose.
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
  d.rest_height = RestHeight(d.rest_positions);
  d.rest_size = size;
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

// Stage 3, rule 1: vertices with bit-identical rest positions welded; returns each vertex's
// canonical id and writes the welded triangles.
std::vector<uint32_t> WeldVertices(const SphereSet& set, NarrowPhaseData::Layout& d) {
  std::vector<uint32_t> canonical = WeldedVertices(d.rest_positions);
  d.welded.resize(set.triangle_vertices.size());
  for (size_t k = 0; k < set.triangle_vertices.size(); ++k) d.welded[k] = canonical[set.triangle_vertices[k]];
  return canonical;
}

// Stage 4: each triangle's rule-2 joint (with rules on triangles), its part and owner(s).
void TriangleRules(const SphereSet& set, NarrowPhaseData::Layout& d) {
  d.rules = set.contact_rules;
  if (d.rules == ContactRules::kTriangles) {
    d.near = NearJoints(set, set.contact_hops);
    d.triangle_joint = TriangleJoints(set);
  }
  d.triangle_part.assign(set.source_triangle_count, 0);
  d.triangle_owner.assign(set.source_triangle_count, 0);
  for (uint32_t s = 0; s < set.size(); ++s) {
    for (uint32_t k = set.triangle_offsets[s]; k < set.triangle_offsets[s + 1]; ++k) {
      d.triangle_owner[set.triangles[k]] = s;
      d.triangle_part[set.triangles[k]] = set.sphere_part[s];
    }
  }
  // Cut triangles: per triangle, its level and one owner per piece index (every piece owned once,
  // all in one part: Validate()).
  d.piece_level.clear();
  d.piece_owner_offsets.assign(1, 0);
  d.piece_owner.clear();
  for (uint32_t s = 0; s < set.size(); ++s) {
    for (const TrianglePiece& p : set.PiecesOf(s)) {
      uint32_t& owner = d.triangle_owner[p.triangle];  // 0 until its first piece: owned whole by none
      if ((owner & NarrowPhaseData::Layout::kCut) == 0) {
        owner = NarrowPhaseData::Layout::kCut | uint32_t(d.piece_level.size());
        d.piece_level.push_back(p.level);
        d.piece_owner.resize(d.piece_owner.size() + size_t{p.level} * p.level, 0);
        d.piece_owner_offsets.push_back(uint32_t(d.piece_owner.size()));
      }
      const uint32_t k = owner & ~NarrowPhaseData::Layout::kCut;
      d.piece_owner[d.piece_owner_offsets[k] + p.index] = s;
      d.triangle_part[p.triangle] = set.sphere_part[s];
    }
  }
}

// Stage 5: each sphere's items, the vertices of their triangles, and its largest item list.
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

// Stage 9: per welded vertex, the triangles using it (the depth estimate floods the mesh through them).
void VertexTriangles(const SphereSet& set, NarrowPhaseData::Layout& d) {
  const size_t vertices = set.source_vertex_count;
  d.vertex_triangle_offsets.assign(vertices + 1, 0);
  for (uint32_t w : d.welded) ++d.vertex_triangle_offsets[w + 1];
  for (size_t v = 0; v < vertices; ++v) d.vertex_triangle_offsets[v + 1] += d.vertex_triangle_offsets[v];
  d.vertex_triangles.assign(d.welded.size(), 0);
  std::vector<uint32_t> fill(d.vertex_triangle_offsets.begin(), d.vertex_triangle_offsets.end() - 1);
  for (size_t k = 0; k < d.welded.size(); ++k) d.vertex_triangles[fill[d.welded[k]]++] = uint32_t(k / 3);
}

// Stage 7: with rules on triangles, the spheres holding triangles of joints more than the hops apart
// (tested against themselves each frame).
void SelfSpheres(const SphereSet& set, NarrowPhaseData::Layout& d) {
  d.self_spheres.clear();
  if (d.rules != ContactRules::kTriangles) return;
  for (uint32_t s = 0; s < set.size(); ++s) {
    bool apart = false;
    for (uint32_t a = d.cluster_offsets[s]; a < d.cluster_offsets[s + 1] && !apart; ++a) {
      for (uint32_t b = a + 1; b < d.cluster_offsets[s + 1] && !apart; ++b) {
        apart = !d.near(d.cluster_joint[a], d.cluster_joint[b]);
      }
    }
    if (apart) d.self_spheres.push_back(s);
  }
}

// The smallest box's centre and the radius around it holding the points (rounded up a hair).
std::array<double, 4> BallOf(const std::vector<Eigen::Vector3d>& points) {
  if (points.empty()) return {0.0, 0.0, 0.0, 0.0};
  Eigen::Vector3d lo = points[0], hi = points[0];
  for (const auto& p : points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Eigen::Vector3d c = 0.5 * (lo + hi);
  double r2 = 0.0;
  for (const auto& p : points) r2 = std::max(r2, (p - c).squaredNorm());
  return {c.x(), c.y(), c.z(), std::sqrt(r2) * (1.0 + 1e-12)};
}

// Far vertices: the vertices of a cluster's pieces' triangles not among its corners.
void FarVertices(const SphereSet& set, NarrowPhaseData::Layout& d) {
  d.cluster_far_offsets.assign(1, 0);
  d.cluster_far_vertices.clear();
  std::vector<uint32_t> far;
  for (size_t c = 0; c + 1 < d.cluster_vertex_offsets.size(); ++c) {
    far.clear();
    for (uint32_t k = d.cluster_triangle_offsets[c]; k < d.cluster_triangle_offsets[c + 1]; ++k) {
      const uint32_t id = d.cluster_triangles[k];
      if (id < d.triangle_count) continue;
      const uint32_t* v = set.triangle_vertices.data() + 3 * size_t{ItemTriangle(d, id)};
      far.insert(far.end(), v, v + 3);
    }
    std::sort(far.begin(), far.end());
    far.erase(std::unique(far.begin(), far.end()), far.end());
    std::erase_if(far, [&](uint32_t v) {
      return std::binary_search(d.cluster_vertices.begin() + d.cluster_vertex_offsets[c],
                                d.cluster_vertices.begin() + d.cluster_vertex_offsets[c + 1], v);
    });
    d.cluster_far_vertices.insert(d.cluster_far_vertices.end(), far.begin(), far.end());
    d.cluster_far_offsets.push_back(uint32_t(d.cluster_far_vertices.size()));
  }
}

// Builds the patches one by one into the layout's patch arrays: the balls of their points' rest
// positions and rest copies, the largest weights, whether rule 3 may skip them; `used` marks the
// joints they name.
class PatchBuilder {
 public:
  PatchBuilder(const SphereSet& set, NarrowPhaseData::Layout& d, const std::vector<Mat4f>& rest_matrices)
      : set_(set), d_(d), rest_matrices_(rest_matrices), used_(set.joint_count(), 0) {
    // A triangle degenerate at rest lay at no distance rule 3 knows: its patch is never skipped.
    degenerate_.assign(set.source_triangle_count, 0);
    for (uint32_t t = 0; t < set.source_triangle_count; ++t) {
      const uint32_t* v = set.triangle_vertices.data() + 3 * size_t{t};
      degenerate_[t] = TriangleIsDegenerate(d.rest_positions[v[0]], d.rest_positions[v[1]], d.rest_positions[v[2]]);
    }
  }

  // The patch of clusters [c, end), of `joint`.
  void Add(uint32_t c, uint32_t end, uint16_t joint) {
    NarrowPhaseData::Layout& d = d_;
    still_ok_ = d.rules == ContactRules::kTriangles && joint != kNoTriangleJoint;
    rest_.clear();
    copies_.clear();
    reach_.clear();
    for (uint32_t k = c; k < end; ++k) {
      for (uint32_t e = d.cluster_vertex_offsets[k]; e < d.cluster_vertex_offsets[k + 1]; ++e)
        AddVertex(d.cluster_vertices[e]);
      for (uint32_t e = d.cluster_far_offsets[k]; e < d.cluster_far_offsets[k + 1]; ++e)
        AddVertex(d.cluster_far_vertices[e]);
      for (uint32_t e = d.cluster_triangle_offsets[k]; e < d.cluster_triangle_offsets[k + 1]; ++e)
        still_ok_ &= !degenerate_[ItemTriangle(d, d.cluster_triangles[e])];
    }
    d.patch_rest_ball.push_back(BallOf(rest_));
    for (size_t e = 0; e < copies_.size(); ++e) {
      d.patch_copy_joint.push_back(copies_[e].first);
      d.patch_copy_ball.push_back(BallOf(copies_[e].second));
      d.patch_copy_reach.push_back(std::min(reach_[e] * (1.0 + 1e-9), 1.0));
      if (copies_[e].first < set_.joint_count()) used_[copies_[e].first] = 1;
    }
    d.patch_copy_offsets.push_back(uint32_t(d.patch_copy_joint.size()));
    d.patch_joint.push_back(joint);
    d.patch_still_ok.push_back(still_ok_ ? 1 : 0);
    d.patch_cluster_offsets.push_back(end);
    if (joint != kNoTriangleJoint && joint < set_.joint_count()) used_[joint] = 1;
  }

  const std::vector<uint8_t>& used() const { return used_; }

 private:
  // Vertex v's rest position, and its rest copy through each joint it is skinned by.
  void AddVertex(uint32_t v) {
    const skinning::SkinnedMesh& mesh = set_.mesh;
    rest_.push_back(d_.rest_positions[v].cast<double>());
    double total[64] = {};  // per entry of `copies_` this vertex adds to (a vertex has few joints)
    for (uint32_t k = mesh.influence_offsets[v]; k < mesh.influence_offsets[v + 1]; ++k) {
      const auto j = uint16_t(mesh.binds[mesh.influence_binds[k]].joint);
      const Mat4f& m = rest_matrices_[mesh.influence_binds[k]];
      const Eigen::Vector3d copy = m.cast<double>().topLeftCorner<3, 3>() * mesh.positions_bind[v].cast<double>() +
                                   m.cast<double>().topRightCorner<3, 1>();
      size_t e = 0;
      while (e < copies_.size() && copies_[e].first != j) ++e;
      if (e == copies_.size()) {
        copies_.emplace_back(j, std::vector<Eigen::Vector3d>{});
        reach_.push_back(0.0);
      }
      copies_[e].second.push_back(copy);
      if (e < 64) total[e] += double(mesh.influence_weights[k]);
      still_ok_ &= e < 64;
    }
    for (size_t e = 0; e < copies_.size() && e < 64; ++e) reach_[e] = std::max(reach_[e], total[e]);
  }

  const SphereSet& set_;
  NarrowPhaseData::Layout& d_;
  const std::vector<Mat4f>& rest_matrices_;
  std::vector<uint8_t> degenerate_;
  std::vector<uint8_t> used_;
  bool still_ok_ = false;
  std::vector<Eigen::Vector3d> rest_;
  std::vector<std::pair<uint16_t, std::vector<Eigen::Vector3d>>> copies_;  // per joint
  std::vector<double> reach_;
};

// The joints whose motion the bound reads (`used`), each with G_j(rest)^-1; a patch naming one that
// has none (a singular rest transform) is never skipped.
void MotionJoints(const SphereSet& set, const std::vector<uint8_t>& used, NarrowPhaseData::Layout& d) {
  d.motion_joints.clear();
  d.rest_inverse.assign(set.joint_count(), internal::Mat4d::Identity());
  std::vector<uint8_t> invertible(set.joint_count(), 0);
  for (uint16_t j = 0; j < set.joint_count(); ++j) {
    if (!used[j]) continue;
    const auto inverse = internal::AffineInverse(set.joint_rest_world[j].cast<double>());
    if (!inverse) continue;
    d.rest_inverse[j] = *inverse;
    invertible[j] = 1;
    d.motion_joints.push_back(j);
  }
  for (size_t p = 0; p < d.patch_joint.size(); ++p) {
    if (d.patch_joint[p] >= set.joint_count() || !invertible[d.patch_joint[p]]) d.patch_still_ok[p] = 0;
    for (uint32_t e = d.patch_copy_offsets[p]; e < d.patch_copy_offsets[p + 1]; ++e) {
      if (d.patch_copy_joint[e] >= set.joint_count() || !invertible[d.patch_copy_joint[e]]) d.patch_still_ok[p] = 0;
    }
  }
}

// Stage 10: the patches (a sphere's clusters of one joint, contiguous since BuildClusters sorts them
// by joint), each with the ball of its points' rest positions and, per joint its points are skinned
// by, the ball of their rest copies through it and the largest weight; the clusters' far vertices;
// the joints whose motion bounds them; rule 3's distance.
bool Patches(const SphereSet& set, NarrowPhaseData::Layout& d) {
  const bool triangles = d.rules == ContactRules::kTriangles;
  d.rest_distance = triangles ? std::max(set.rest_gap, d.settings.margin) : d.settings.margin;
  FarVertices(set, d);
  // The skinning matrices at rest, M_b = G_joint(b)(rest) · IBM_b, for the vertices' rest copies.
  const skinning::SkinnedMesh& mesh = set.mesh;
  std::vector<Mat4f> rest_matrices(mesh.binds.size());
  if (!skinning::SkinningMatricesJob{mesh.binds, set.joint_rest_world, rest_matrices}.Run()) return false;
  d.cluster_ids.resize(d.cluster_joint.size());
  for (uint32_t c = 0; c < d.cluster_ids.size(); ++c) d.cluster_ids[c] = c;
  d.patch_offsets.assign(1, 0);
  d.patch_cluster_offsets.assign(1, 0);
  d.patch_copy_offsets.assign(1, 0);
  d.patch_joint.clear();
  d.patch_still_ok.clear();
  d.patch_rest_ball.clear();
  d.patch_copy_joint.clear();
  d.patch_copy_ball.clear();
  d.patch_copy_reach.clear();
  PatchBuilder patches(set, d, rest_matrices);
  for (size_t s = 0; s < set.size(); ++s) {
    for (uint32_t c = d.cluster_offsets[s]; c < d.cluster_offsets[s + 1];) {
      uint32_t end = c + 1;
      while (triangles && end < d.cluster_offsets[s + 1] && d.cluster_joint[end] == d.cluster_joint[c]) ++end;
      if (!triangles) end = d.cluster_offsets[s + 1];
      patches.Add(c, end, triangles ? d.cluster_joint[c] : kNoTriangleJoint);
      c = end;
    }
    d.patch_offsets.push_back(uint32_t(d.patch_joint.size()));
  }
  MotionJoints(set, patches.used(), d);
  return true;
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
  TriangleRules(set, d);
  SphereVertices(set, d);
  BuildClusters(set, &data);
  SelfSpheres(set, d);
  if (!BuildVertexGroups(set, &data)) {
    return MakeError(ErrorCode::kInvalidData, who + ": the mesh's influences do not fit its bind entries");
  }
  for (size_t s = 0; s < set.size(); ++s) {
    d.max_sphere_clusters = std::max<size_t>(d.max_sphere_clusters, d.cluster_offsets[s + 1] - d.cluster_offsets[s]);
  }
  VertexTriangles(set, d);
  if (!Patches(set, d)) {
    return MakeError(ErrorCode::kInvalidData,
                     who + ": the mesh cannot be skinned at rest (bind entries and skeleton disagree)");
  }
  for (size_t s = 0; s < set.size(); ++s) {
    d.max_sphere_patches = std::max<size_t>(d.max_sphere_patches, d.patch_offsets[s + 1] - d.patch_offsets[s]);
  }
  return data;
}

}  // namespace skinspheres::runtime
