// FitMetrics: voxel volumes (6-ray parity/winding vote), sphere-union boundary distances (Fibonacci
// samples, exact distances to the mesh), coverage. See fit_metrics.h for the contract and the method.
// These are the acceptance figures of the fit. The paper (§6) judges its spheres by F, the gap
// between a sphere and the contact points it covers (§4.4), and by the "volumetric error"; here
// both are measured globally: union volume over body volume, and the union boundary's distance
// to the surface.
#include "skinspheres/lib/metrics/fit_metrics.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <string>

#include "metrics_internal.h"
#include "skinspheres/lib/geometry/fibonacci_directions.h"
#include "skinspheres/lib/geometry/mesh_distance.h"

namespace skinspheres::lib {
namespace {

using metrics_internal::Bounds;
using metrics_internal::Finite;
using metrics_internal::Grid;
using metrics_internal::InsideVotes;
using metrics_internal::Invalid;
using metrics_internal::kInsideVotes;
using metrics_internal::kUnionBit;
using metrics_internal::MakeGrid;
using metrics_internal::ValidateMesh;
using metrics_internal::Vec3d;

// Marks (kUnionBit) the voxels whose centre lies inside any sphere.
void MarkSpheres(const Grid& g, std::span<const Eigen::Vector3f> centers, std::span<const float> radii,
                 std::vector<uint8_t>& cells) {
  for (size_t s = 0; s < centers.size(); ++s) {
    const Vec3d c = (centers[s].cast<double>() - g.origin) / g.h;
    const double r = double(radii[s]) / g.h;
    if (!(r > 0)) continue;
    const double r2 = r * r;
    const int z0 = std::max(0, int(std::ceil(c.z() - r - 0.5))),
              z1 = std::min(g.dims[2] - 1, int(std::floor(c.z() + r - 0.5)));
    for (int z = z0; z <= z1; ++z) {
      const double dz = z + 0.5 - c.z();
      const double ry2 = r2 - dz * dz;
      if (ry2 < 0) continue;
      const double ry = std::sqrt(ry2);
      const int y0 = std::max(0, int(std::ceil(c.y() - ry - 0.5))),
                y1 = std::min(g.dims[1] - 1, int(std::floor(c.y() + ry - 0.5)));
      for (int y = y0; y <= y1; ++y) {
        const double dy = y + 0.5 - c.y();
        const double rx2 = ry2 - dy * dy;
        if (rx2 < 0) continue;
        const double rx = std::sqrt(rx2);
        const int x0 = std::max(0, int(std::ceil(c.x() - rx - 0.5))),
                  x1 = std::min(g.dims[0] - 1, int(std::floor(c.x() + rx - 0.5)));
        uint8_t* row = cells.data() + (size_t(z) * g.dims[1] + y) * g.dims[0];
        for (int x = x0; x <= x1; ++x) row[x] |= kUnionBit;
      }
    }
  }
}

// A uniform grid of spheres: the candidates for "which spheres may contain this point".
struct SphereBins {
  Vec3d origin;
  double cell = 1.0;
  std::array<int, 3> dims{1, 1, 1};
  std::vector<uint32_t> offsets, items;  // CSR per cell

  int CellIndex(const Vec3d& p, int a) const {
    return std::clamp(int(std::floor((p[a] - origin[a]) / cell)), 0, dims[a] - 1);
  }
  std::span<const uint32_t> Candidates(const Eigen::Vector3f& pf) const {
    const Vec3d p = pf.cast<double>();
    const size_t c = (size_t(CellIndex(p, 2)) * dims[1] + CellIndex(p, 1)) * dims[0] + CellIndex(p, 0);
    return std::span<const uint32_t>(items).subspan(offsets[c], offsets[c + 1] - offsets[c]);
  }
};

SphereBins BinSpheres(const Vec3d& lo, const Vec3d& hi, std::span<const Eigen::Vector3f> centers,
                      std::span<const float> radii, double margin) {
  SphereBins b;
  const Vec3d ext = (hi - lo).cwiseMax(1e-30);
  const int longest_cells = 24;
  b.cell = ext.maxCoeff() / longest_cells;
  b.origin = lo;
  for (int a = 0; a < 3; ++a) b.dims[a] = std::clamp(int(std::ceil(ext[a] / b.cell)), 1, longest_cells);
  const size_t cells = size_t(b.dims[0]) * b.dims[1] * b.dims[2];
  std::vector<std::array<int, 6>> ranges(centers.size());
  std::vector<uint32_t> counts(cells + 1, 0);
  for (size_t s = 0; s < centers.size(); ++s) {
    const Vec3d c = centers[s].cast<double>();
    const double r = double(radii[s]) + margin;
    auto& rg = ranges[s];
    for (int a = 0; a < 3; ++a) {
      rg[a] = b.CellIndex(c - Vec3d::Constant(r), a);
      rg[3 + a] = b.CellIndex(c + Vec3d::Constant(r), a);
    }
    for (int z = rg[2]; z <= rg[5]; ++z)
      for (int y = rg[1]; y <= rg[4]; ++y)
        for (int x = rg[0]; x <= rg[3]; ++x) ++counts[(size_t(z) * b.dims[1] + y) * b.dims[0] + x];
  }
  b.offsets.assign(cells + 1, 0);
  for (size_t c = 0; c < cells; ++c) b.offsets[c + 1] = b.offsets[c] + counts[c];
  b.items.resize(b.offsets[cells]);
  std::vector<uint32_t> fill(b.offsets.begin(), b.offsets.end() - 1);
  for (size_t s = 0; s < centers.size(); ++s) {
    const auto& rg = ranges[s];
    for (int z = rg[2]; z <= rg[5]; ++z)
      for (int y = rg[1]; y <= rg[4]; ++y)
        for (int x = rg[0]; x <= rg[3]; ++x) b.items[fill[(size_t(z) * b.dims[1] + y) * b.dims[0] + x]++] = uint32_t(s);
  }
  return b;
}

// Every reason the input or the settings are refused (kInvalidArgument, named).
std::optional<Error> ValidateMetricsInput(const FitMetricsInput& in, const FitMetricsSettings& settings) {
  if (auto e = ValidateMesh(in.positions, in.triangles)) return *e;
  if (in.centers.empty()) return Invalid("no spheres");
  if (in.radii.size() != in.centers.size())
    return Invalid(std::to_string(in.radii.size()) + " radii for " + std::to_string(in.centers.size()) + " centres");
  for (size_t s = 0; s < in.centers.size(); ++s)
    if (!Finite(in.centers[s]) || !std::isfinite(in.radii[s]) || in.radii[s] < 0)
      return Invalid("sphere " + std::to_string(s) + " has a non-finite centre or a negative / non-finite radius");
  if (settings.grid_resolution < 8 || settings.grid_resolution > 1024)
    return Invalid("grid_resolution " + std::to_string(settings.grid_resolution) + " is outside [8, 1024]");
  if (settings.samples_per_sphere < 1) return Invalid("samples_per_sphere must be >= 1");
  if (!(settings.coverage_tolerance >= 0)) return Invalid("coverage_tolerance must be >= 0");
  if (!in.owner_offsets.empty()) {
    if (in.owner_offsets.size() != in.centers.size() + 1)
      return Invalid("owner_offsets has " + std::to_string(in.owner_offsets.size()) +
                     " entries, expected spheres + 1 = " + std::to_string(in.centers.size() + 1));
    if (in.owner_offsets.front() != 0 || in.owner_offsets.back() != in.owned_triangles.size())
      return Invalid("owner_offsets must start at 0 and end at owned_triangles.size()");
    for (size_t s = 0; s + 1 < in.owner_offsets.size(); ++s)
      if (in.owner_offsets[s] > in.owner_offsets[s + 1])
        return Invalid("owner_offsets decrease at sphere " + std::to_string(s));
    for (uint32_t t : in.owned_triangles)
      if (t >= in.triangles.size()) return Invalid("owned triangle " + std::to_string(t) + " is out of range");
  }
  if (!in.piece_offsets.empty() || !in.pieces.empty()) {
    if (in.piece_offsets.size() != in.centers.size() + 1 || in.piece_offsets.front() != 0 ||
        in.piece_offsets.back() != in.pieces.size() ||
        !std::is_sorted(in.piece_offsets.begin(), in.piece_offsets.end())) {
      return Invalid("piece_offsets must have one entry per sphere and one more, rise from 0 to pieces.size()");
    }
    uint8_t corners[3][2];
    for (const runtime::TrianglePiece& p : in.pieces) {
      if (p.triangle >= in.triangles.size() || !runtime::PieceCorners(p.level, p.index, corners))
        return Invalid("piece " + std::to_string(p.index) + " of triangle " + std::to_string(p.triangle) +
                       " is out of range");
    }
  }
  return std::nullopt;
}

// 1. Volumes on one grid: the body by the six-ray vote, the union by marking voxel centres.
void MeasureVolumes(const FitMetricsInput& in, const FitMetricsSettings& settings, const Vec3d& lo, const Vec3d& hi,
                    FitMetrics* m) {
  const Grid g = MakeGrid(lo, hi, settings.grid_resolution);
  m->grid_origin = g.origin.cast<float>();
  m->voxel_size = float(g.h);
  m->grid_dims = Eigen::Vector3i(g.dims[0], g.dims[1], g.dims[2]);
  std::vector<uint8_t> cells = InsideVotes(g, in.positions, in.triangles);
  MarkSpheres(g, in.centers, in.radii, cells);
  size_t body = 0, uni = 0, both = 0, ambiguous = 0;
  for (uint8_t c : cells) {
    const uint8_t v = c & 0x7f;
    ambiguous += v >= 2 && v <= 4;
    const bool in_body = v >= kInsideVotes, in_union = (c & kUnionBit) != 0;
    body += in_body;
    uni += in_union;
    both += in_body && in_union;
  }
  const double voxel_volume = g.h * g.h * g.h;
  m->body_volume = double(body) * voxel_volume;
  m->union_volume = double(uni) * voxel_volume;
  m->volume_ratio = body > 0 ? double(uni) / double(body) : 0.0;
  m->body_covered_fraction = body > 0 ? double(both) / double(body) : 0.0;
  m->body_ambiguous_fraction = body > 0 ? double(ambiguous) / double(body) : 0.0;
}

// 2. The union boundary's distance to the mesh: Fibonacci samples on each sphere that no other
// sphere strictly contains, each standing for its share of the sphere's area.
void MeasureBoundaryDistance(const FitMetricsInput& in, const FitMetricsSettings& settings, const Vec3d& lo,
                             const Vec3d& hi, FitMetrics* m) {
  const double height = m->body_height;
  const SphereBins bins = BinSpheres(lo, hi, in.centers, in.radii, 0.0);
  const int n = settings.samples_per_sphere;
  const std::vector<Eigen::Vector3f> unit = FibonacciDirections(n);
  const float strict = float(1e-6 * height);
  std::vector<Eigen::Vector3f> samples;
  std::vector<double> weights;
  std::vector<uint32_t> owners;
  for (size_t s = 0; s < in.centers.size(); ++s) {
    const float r = in.radii[s];
    if (!(r > 0)) continue;
    const double w = 4.0 * std::numbers::pi * double(r) * r / n;
    for (const Eigen::Vector3f& u : unit) {
      const Eigen::Vector3f q = in.centers[s] + r * u;
      bool covered = false;
      for (uint32_t j : bins.Candidates(q)) {
        if (j == s) continue;
        const float rj = in.radii[j] - strict;
        if (rj > 0 && (q - in.centers[j]).squaredNorm() < rj * rj) {
          covered = true;
          break;
        }
      }
      if (covered) continue;
      samples.push_back(q);
      weights.push_back(w);
      owners.push_back(static_cast<uint32_t>(s));
    }
  }
  m->boundary_samples = samples.size();
  if (!samples.empty()) {
    std::vector<float> dist(samples.size());
    MeshDistances(in.positions, in.triangles, samples, dist);
    double sum = 0, wsum = 0, mx = 0;
    m->sphere_boundary_distance.assign(in.centers.size(), 0.0);
    for (size_t i = 0; i < samples.size(); ++i) {
      m->sphere_boundary_distance[owners[i]] += weights[i] * dist[i];
      sum += weights[i] * dist[i];
      wsum += weights[i];
      mx = std::max(mx, double(dist[i]));
    }
    for (double& d : m->sphere_boundary_distance) d /= wsum;
    m->boundary_distance_mean = sum / wsum;
    m->boundary_distance_max = mx;
    m->boundary_distance_mean_rel = m->boundary_distance_mean / height;
    m->boundary_distance_max_rel = mx / height;
    // The area-weighted 95th percentile: the smallest distance below which 95% of the exposed
    // boundary lies (samples by distance, ties by index).
    std::vector<uint32_t> order(samples.size());
    for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<uint32_t>(i);
    std::sort(order.begin(), order.end(),
              [&](uint32_t a, uint32_t b) { return dist[a] != dist[b] ? dist[a] < dist[b] : a < b; });
    double below = 0.0;
    for (uint32_t i : order) {
      below += weights[i];
      m->boundary_distance_p95 = dist[i];
      if (below >= 0.95 * wsum) break;
    }
    m->boundary_distance_p95_rel = m->boundary_distance_p95 / height;
  }
}

// 3. Coverage: triangles inside no single sphere, and owned triangles outside their owner.
void MeasureCoverage(const FitMetricsInput& in, const FitMetricsSettings& settings, const Vec3d& lo, const Vec3d& hi,
                     FitMetrics* m) {
  const double height = m->body_height;
  const float tol = float(settings.coverage_tolerance * height);
  auto holds = [&](uint32_t s, const Eigen::Vector3i& t) {
    const float r = in.radii[s] + tol, r2 = r * r;
    for (int k = 0; k < 3; ++k)
      if ((in.positions[t[k]] - in.centers[s]).squaredNorm() > r2) return false;
    return true;
  };
  // A piece's corners (grid points of its triangle, as the runtime computes them).
  auto piece_corners = [&](const runtime::TrianglePiece& p, Eigen::Vector3f out[3]) {
    const Eigen::Vector3i& tri = in.triangles[p.triangle];
    uint8_t c[3][2];
    runtime::PieceCorners(p.level, p.index, c);
    for (int k = 0; k < 3; ++k) {
      out[k] = runtime::GridPoint(in.positions[tri[0]], in.positions[tri[1]], in.positions[tri[2]], p.level, c[k][0],
                                  c[k][1]);
    }
  };
  auto holds_points = [&](uint32_t s, const Eigen::Vector3f* p) {
    const float r = in.radii[s] + tol, r2 = r * r;
    for (int k = 0; k < 3; ++k)
      if ((p[k] - in.centers[s]).squaredNorm() > r2) return false;
    return true;
  };
  const SphereBins cover_bins = BinSpheres(lo, hi, in.centers, in.radii, double(tol));
  std::vector<char> cut(in.pieces.empty() ? 0 : in.triangles.size(), 0), piece_missed(cut.size(), 0);
  for (const runtime::TrianglePiece& p : in.pieces) {
    cut[p.triangle] = 1;
    Eigen::Vector3f corner[3];
    piece_corners(p, corner);
    bool covered = false;
    for (uint32_t s : cover_bins.Candidates(corner[0])) covered = covered || holds_points(s, corner);
    if (!covered) piece_missed[p.triangle] = 1;
  }
  for (size_t t = 0; t < in.triangles.size(); ++t) {
    const Eigen::Vector3i& tri = in.triangles[t];
    bool covered = false;
    if (!cut.empty() && cut[t]) {
      covered = !piece_missed[t];
    } else {
      for (uint32_t s : cover_bins.Candidates(in.positions[tri[0]]))
        if (holds(s, tri)) {
          covered = true;
          break;
        }
    }
    if (!covered) {
      ++m->uncovered_triangles;
      if (m->uncovered_examples.size() < 16) m->uncovered_examples.push_back(uint32_t(t));
    }
  }
  if (!in.owner_offsets.empty()) {
    for (size_t s = 0; s < in.centers.size(); ++s)
      for (uint32_t i = in.owner_offsets[s]; i < in.owner_offsets[s + 1]; ++i)
        if (!holds(uint32_t(s), in.triangles[in.owned_triangles[i]])) ++m->triangles_outside_owner;
  }
  if (!in.piece_offsets.empty()) {
    for (size_t s = 0; s < in.centers.size(); ++s)
      for (uint32_t i = in.piece_offsets[s]; i < in.piece_offsets[s + 1]; ++i) {
        Eigen::Vector3f corner[3];
        piece_corners(in.pieces[i], corner);
        if (!holds_points(uint32_t(s), corner)) ++m->triangles_outside_owner;
      }
  }
}

}  // namespace

Result<FitMetrics> MeasureFit(const FitMetricsInput& in, const FitMetricsSettings& settings) {
  if (auto e = ValidateMetricsInput(in, settings)) return *e;
  FitMetrics m;
  Vec3d mesh_lo, mesh_hi;
  Bounds(in.positions, mesh_lo, mesh_hi);
  const Vec3d mesh_ext = mesh_hi - mesh_lo;
  m.body_height = float(settings.height_along_y && mesh_ext.y() > 0 ? mesh_ext.y() : mesh_ext.maxCoeff());
  if (!(m.body_height > 0)) return Invalid("the mesh has no extent (all vertices coincide)");

  Vec3d lo = mesh_lo, hi = mesh_hi;
  for (size_t s = 0; s < in.centers.size(); ++s) {
    lo = lo.cwiseMin(in.centers[s].cast<double>() - Vec3d::Constant(in.radii[s]));
    hi = hi.cwiseMax(in.centers[s].cast<double>() + Vec3d::Constant(in.radii[s]));
  }

  MeasureVolumes(in, settings, lo, hi, &m);
  MeasureBoundaryDistance(in, settings, lo, hi, &m);
  MeasureCoverage(in, settings, lo, hi, &m);
  return m;
}

Result<FitMetrics> MeasureFit(const RawCharacter& character, const runtime::SphereSet& set,
                              const FitMetricsSettings& settings) {
  if (set.source_vertex_count != character.vertex_count() || set.source_triangle_count != character.triangle_count())
    return MakeError(ErrorCode::kMismatchedAsset, "fit metrics: the sphere set (" + set.source_file + ", " +
                                                      std::to_string(set.source_vertex_count) + " vertices, " +
                                                      std::to_string(set.source_triangle_count) +
                                                      " triangles) was not made for " + character.source_file + " (" +
                                                      std::to_string(character.vertex_count()) + " vertices, " +
                                                      std::to_string(character.triangle_count()) + " triangles)");
  FitMetricsInput in;
  in.positions = character.positions_rest;
  in.triangles = character.triangles;
  in.centers = set.centers_rest;
  in.radii = set.radii_rest;
  if (!set.triangle_offsets.empty()) {
    in.owner_offsets = set.triangle_offsets;
    in.owned_triangles = set.triangles;
  }
  in.piece_offsets = set.piece_offsets;
  in.pieces = set.pieces;
  return MeasureFit(in, settings);
}

}  // namespace skinspheres::lib
