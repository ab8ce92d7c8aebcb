// FitMetrics: voxel volumes (6-ray parity/winding vote), sphere-union boundary distances (Fibonacci
// samples, AABB tree of triangles), coverage. See fit_metrics.h for the contract and the method.
// These are the acceptance figures of the fit. The paper (§6) judges its spheres by F, the gap
// between a sphere and the contact points it covers (§4.4), and by the "volumetric error"; here
// both are measured globally: union volume over body volume, and the union boundary's distance
// to the surface.
#include "skinspheres/lib/metrics/fit_metrics.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <string>

#include "skinspheres/lib/geometry/fibonacci_directions.h"
#include "skinspheres/lib/geometry/mesh_distance.h"

namespace skinspheres::lib {
namespace {

using Vec3d = Eigen::Vector3d;

Error Invalid(std::string message) {
  return MakeError(ErrorCode::kInvalidArgument, "fit metrics: " + std::move(message));
}

bool Finite(const Eigen::Vector3f& v) { return v.allFinite(); }

// Cubic voxels; voxel (i, j, k) has its centre at origin + (ijk + 0.5) · h.
struct Grid {
  Vec3d origin = Vec3d::Zero();
  double h = 1.0;
  std::array<int, 3> dims{1, 1, 1};
  size_t count() const { return size_t(dims[0]) * size_t(dims[1]) * size_t(dims[2]); }
  size_t stride(int axis) const { return axis == 0 ? 1 : axis == 1 ? size_t(dims[0]) : size_t(dims[0]) * dims[1]; }
};

// `resolution` voxels along the longest axis of [lo, hi], plus one voxel of padding on each side.
Grid MakeGrid(const Vec3d& lo, const Vec3d& hi, int resolution) {
  Grid g;
  const Vec3d ext = hi - lo;
  double longest = ext.maxCoeff();
  if (!(longest > 0)) longest = 1.0;
  g.h = longest / resolution;
  g.origin = lo - Vec3d::Constant(g.h);
  for (int a = 0; a < 3; ++a) g.dims[a] = std::max(1, int(std::ceil(ext[a] / g.h)) + 2);
  return g;
}

// ---- Inside votes: scanline rasterisation of triangles onto voxel-centre columns ----

struct Crossing {
  uint32_t column;
  float depth;  // along the column, in voxel units (voxel i has its centre at i + 0.5)
  int8_t sign;  // +1: the ray along +axis enters here (normal's axis component < 0)
  bool operator<(const Crossing& o) const {
    if (column != o.column) return column < o.column;
    if (depth != o.depth) return depth < o.depth;
    return sign < o.sign;
  }
};

struct P2 {
  double u, v;
};
bool Less(const P2& a, const P2& b) { return a.u < b.u || (a.u == b.u && a.v < b.v); }
// Orientation of r against the directed edge p->q, evaluated in one canonical vertex order so two
// triangles sharing an edge get exactly opposite values (the tie rule below then picks one).
double EdgeFunction(const P2& p, const P2& q, const P2& r) {
  if (Less(q, p)) {
    return -((p.u - q.u) * (r.v - q.v) - (p.v - q.v) * (r.u - q.u));
  }
  return (q.u - p.u) * (r.v - p.v) - (q.v - p.v) * (r.u - p.u);
}
// Top-left rule: for a point exactly on an edge, only one of the two sides owns it (antisymmetric
// in the edge direction).
bool OwnsEdge(const P2& p, const P2& q) {
  const double du = q.u - p.u, dv = q.v - p.v;
  return dv < 0 || (dv == 0 && du > 0);
}
bool Inside(double w, const P2& p, const P2& q) { return w > 0 || (w == 0 && OwnsEdge(p, q)); }

// +1 or -1 per triangle: -1 for the triangles of a closed connected piece (triangles sharing vertex
// indices, every edge used an even number of times) whose signed volume is negative, so every
// closed piece counts as outward-facing and nested pieces of opposite orientation still add up in
// the winding number.
std::vector<int8_t> PieceOrientation(std::span<const Eigen::Vector3f> positions,
                                     std::span<const Eigen::Vector3i> triangles, const Vec3d& centre) {
  std::vector<uint32_t> parent(positions.size());
  for (size_t i = 0; i < parent.size(); ++i) parent[i] = uint32_t(i);
  auto find = [&](uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (const auto& t : triangles)
    for (int k = 1; k < 3; ++k) {
      const uint32_t a = find(uint32_t(t[0])), b = find(uint32_t(t[k]));
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  std::vector<double> volume(positions.size(), 0.0);
  for (const auto& t : triangles) {
    const Vec3d a = positions[t[0]].cast<double>() - centre, b = positions[t[1]].cast<double>() - centre,
                c = positions[t[2]].cast<double>() - centre;
    volume[find(uint32_t(t[0]))] += a.dot(b.cross(c));
  }
  // Only closed pieces (every edge used an even number of times) have a meaningful signed volume;
  // open pieces keep their orientation (an open piece may close a surface together with others).
  std::vector<uint64_t> edges;
  edges.reserve(triangles.size() * 3);
  for (const auto& t : triangles)
    for (int k = 0; k < 3; ++k) {
      const uint64_t a = uint32_t(t[k]), b = uint32_t(t[(k + 1) % 3]);
      edges.push_back(std::min(a, b) << 32 | std::max(a, b));
    }
  std::sort(edges.begin(), edges.end());
  std::vector<uint8_t> open(positions.size(), 0);
  for (size_t i = 0; i < edges.size();) {
    size_t j = i;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    if ((j - i) & 1) open[find(uint32_t(edges[i] >> 32))] = 1;
    i = j;
  }
  std::vector<int8_t> orientation(triangles.size());
  for (size_t t = 0; t < triangles.size(); ++t) {
    const uint32_t piece = find(uint32_t(triangles[t][0]));
    orientation[t] = !open[piece] && volume[piece] < 0 ? -1 : 1;
  }
  return orientation;
}

// Adds 0..6 "inside" votes per voxel from the rays along ±X, ±Y, ±Z (see the header comment).
std::vector<uint8_t> InsideVotes(const Grid& g, std::span<const Eigen::Vector3f> positions,
                                 std::span<const Eigen::Vector3i> triangles) {
  std::vector<uint8_t> votes(g.count(), 0);
  std::vector<Vec3d> p(positions.size());
  for (size_t i = 0; i < positions.size(); ++i) p[i] = (positions[i].cast<double>() - g.origin) / g.h;
  const Vec3d grid_centre = g.origin + 0.5 * g.h * Vec3d(g.dims[0], g.dims[1], g.dims[2]);
  const std::vector<int8_t> orientation = PieceOrientation(positions, triangles, grid_centre);
  std::vector<Crossing> crossings;
  for (int a = 0; a < 3; ++a) {
    const int ua = (a + 1) % 3, va = (a + 2) % 3;
    const int nu = g.dims[ua], nv = g.dims[va], na = g.dims[a];
    crossings.clear();
    for (size_t ti = 0; ti < triangles.size(); ++ti) {
      const Eigen::Vector3i& t = triangles[ti];
      const Vec3d& A = p[t[0]];
      const Vec3d& B0 = p[t[1]];
      const Vec3d& C0 = p[t[2]];
      P2 q0{A[ua], A[va]}, q1{B0[ua], B0[va]}, q2{C0[ua], C0[va]};
      double d0 = A[a], d1 = B0[a], d2 = C0[a];
      // Signed projected area = the normal's component along `a` (for the cyclic axes a, u, v).
      const double area = (q1.u - q0.u) * (q2.v - q0.v) - (q1.v - q0.v) * (q2.u - q0.u);
      if (area == 0 || !std::isfinite(area)) continue;
      const int8_t sign = int8_t((area < 0 ? 1 : -1) * orientation[ti]);
      if (area < 0) {  // make it counter-clockwise in (u, v)
        std::swap(q1, q2);
        std::swap(d1, d2);
      }
      const double umin = std::min({q0.u, q1.u, q2.u}), umax = std::max({q0.u, q1.u, q2.u});
      const double vmin = std::min({q0.v, q1.v, q2.v}), vmax = std::max({q0.v, q1.v, q2.v});
      const int iu0 = std::max(0, int(std::ceil(umin - 0.5))), iu1 = std::min(nu - 1, int(std::floor(umax - 0.5)));
      const int iv0 = std::max(0, int(std::ceil(vmin - 0.5))), iv1 = std::min(nv - 1, int(std::floor(vmax - 0.5)));
      for (int iv = iv0; iv <= iv1; ++iv) {
        for (int iu = iu0; iu <= iu1; ++iu) {
          const P2 r{iu + 0.5, iv + 0.5};
          const double w0 = EdgeFunction(q1, q2, r), w1 = EdgeFunction(q2, q0, r), w2 = EdgeFunction(q0, q1, r);
          if (!Inside(w0, q1, q2) || !Inside(w1, q2, q0) || !Inside(w2, q0, q1)) continue;
          const double sum = w0 + w1 + w2;
          if (!(sum > 0)) continue;
          const double depth = (w0 * d0 + w1 * d1 + w2 * d2) / sum;
          crossings.push_back({uint32_t(iv) * uint32_t(nu) + uint32_t(iu), float(depth), sign});
        }
      }
    }
    std::sort(crossings.begin(), crossings.end());
    const size_t sa = g.stride(a), su = g.stride(ua), sv = g.stride(va);
    size_t k = 0;
    while (k < crossings.size()) {
      const uint32_t col = crossings[k].column;
      size_t end = k;
      int total_w = 0, total_n = 0;
      while (end < crossings.size() && crossings[end].column == col) {
        total_w += crossings[end].sign;
        ++total_n;
        ++end;
      }
      const int iu = int(col % uint32_t(nu)), iv = int(col / uint32_t(nu));
      const size_t base = size_t(iu) * su + size_t(iv) * sv;
      int below_w = 0, below_n = 0;
      size_t c = k;
      for (int i = 0; i < na; ++i) {
        const float centre = float(i) + 0.5f;
        while (c < end && crossings[c].depth < centre) {
          below_w += crossings[c].sign;
          ++below_n;
          ++c;
        }
        const bool from_below = below_w != 0 || (below_n & 1);
        const bool from_above = (total_w - below_w) != 0 || ((total_n - below_n) & 1);
        votes[base + size_t(i) * sa] += uint8_t(from_below) + uint8_t(from_above);
      }
      k = end;
    }
  }
  return votes;
}
constexpr uint8_t kInsideVotes = 4;  // of 6

// Marks (bit 7) the voxels whose centre lies inside any sphere.
constexpr uint8_t kUnionBit = 0x80;
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

// ---- Uniform grid of spheres (candidates for "which spheres may contain this point") ----

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

std::optional<Error> ValidateMesh(std::span<const Eigen::Vector3f> positions,
                                  std::span<const Eigen::Vector3i> triangles) {
  if (positions.empty() || triangles.empty()) return Invalid("the mesh is empty (no vertices or no triangles)");
  for (size_t i = 0; i < positions.size(); ++i)
    if (!Finite(positions[i])) return Invalid("vertex " + std::to_string(i) + " is not finite");
  for (size_t t = 0; t < triangles.size(); ++t)
    for (int k = 0; k < 3; ++k)
      if (triangles[t][k] < 0 || size_t(triangles[t][k]) >= positions.size())
        return Invalid("triangle " + std::to_string(t) + " indexes vertex " + std::to_string(triangles[t][k]) + " of " +
                       std::to_string(positions.size()));
  return std::nullopt;
}

void Bounds(std::span<const Eigen::Vector3f> positions, Vec3d& lo, Vec3d& hi) {
  lo = Vec3d::Constant(std::numeric_limits<double>::max());
  hi = -lo;
  for (const auto& v : positions) {
    lo = lo.cwiseMin(v.cast<double>());
    hi = hi.cwiseMax(v.cast<double>());
  }
}

}  // namespace



Result<double> MeshInsideVolume(std::span<const Eigen::Vector3f> positions, std::span<const Eigen::Vector3i> triangles,
                                int grid_resolution) {
  if (auto e = ValidateMesh(positions, triangles)) return *e;
  if (grid_resolution < 8 || grid_resolution > 1024)
    return Invalid("grid_resolution " + std::to_string(grid_resolution) + " is outside [8, 1024]");
  Vec3d lo, hi;
  Bounds(positions, lo, hi);
  const Grid g = MakeGrid(lo, hi, grid_resolution);
  const std::vector<uint8_t> votes = InsideVotes(g, positions, triangles);
  const size_t inside = size_t(std::count_if(votes.begin(), votes.end(), [](uint8_t v) { return v >= kInsideVotes; }));
  return double(inside) * g.h * g.h * g.h;
}

Result<FitMetrics> MeasureFit(const FitMetricsInput& in, const FitMetricsSettings& settings) {
  // ---- Validate ----
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

  // ---- 1. Volumes on one grid ----
  const Grid g = MakeGrid(lo, hi, settings.grid_resolution);
  m.grid_origin = g.origin.cast<float>();
  m.voxel_size = float(g.h);
  m.grid_dims = Eigen::Vector3i(g.dims[0], g.dims[1], g.dims[2]);
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
  m.body_volume = double(body) * voxel_volume;
  m.union_volume = double(uni) * voxel_volume;
  m.volume_ratio = body > 0 ? double(uni) / double(body) : 0.0;
  m.body_covered_fraction = body > 0 ? double(both) / double(body) : 0.0;
  m.body_ambiguous_fraction = body > 0 ? double(ambiguous) / double(body) : 0.0;

  // ---- 2. Union boundary distance ----
  const double height = m.body_height;
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
  m.boundary_samples = samples.size();
  if (!samples.empty()) {
    std::vector<float> dist(samples.size());
    MeshDistances(in.positions, in.triangles, samples, dist);
    double sum = 0, wsum = 0, mx = 0;
    m.sphere_boundary_distance.assign(in.centers.size(), 0.0);
    for (size_t i = 0; i < samples.size(); ++i) {
      m.sphere_boundary_distance[owners[i]] += weights[i] * dist[i];
      sum += weights[i] * dist[i];
      wsum += weights[i];
      mx = std::max(mx, double(dist[i]));
    }
    for (double& d : m.sphere_boundary_distance) d /= wsum;
    m.boundary_distance_mean = sum / wsum;
    m.boundary_distance_max = mx;
    m.boundary_distance_mean_rel = m.boundary_distance_mean / height;
    m.boundary_distance_max_rel = mx / height;
  }

  // ---- 3. Coverage ----
  const float tol = float(settings.coverage_tolerance * height);
  auto holds = [&](uint32_t s, const Eigen::Vector3i& t) {
    const float r = in.radii[s] + tol, r2 = r * r;
    for (int k = 0; k < 3; ++k)
      if ((in.positions[t[k]] - in.centers[s]).squaredNorm() > r2) return false;
    return true;
  };
  const SphereBins cover_bins = BinSpheres(lo, hi, in.centers, in.radii, double(tol));
  for (size_t t = 0; t < in.triangles.size(); ++t) {
    const Eigen::Vector3i& tri = in.triangles[t];
    bool covered = false;
    for (uint32_t s : cover_bins.Candidates(in.positions[tri[0]]))
      if (holds(s, tri)) {
        covered = true;
        break;
      }
    if (!covered) {
      ++m.uncovered_triangles;
      if (m.uncovered_examples.size() < 16) m.uncovered_examples.push_back(uint32_t(t));
    }
  }
  if (!in.owner_offsets.empty()) {
    for (size_t s = 0; s < in.centers.size(); ++s)
      for (uint32_t i = in.owner_offsets[s]; i < in.owner_offsets[s + 1]; ++i)
        if (!holds(uint32_t(s), in.triangles[in.owned_triangles[i]])) ++m.triangles_outside_owner;
  }
  return m;
}

Result<JointSpheres> NaiveJointSpheres(std::span<const Eigen::Vector3f> positions,
                                       std::span<const uint32_t> dominant_joint) {
  if (positions.size() != dominant_joint.size())
    return Invalid(std::to_string(dominant_joint.size()) + " dominant joints for " + std::to_string(positions.size()) +
                   " vertices");
  if (positions.empty()) return Invalid("no vertices");
  uint32_t joints = 0;
  for (size_t i = 0; i < positions.size(); ++i) {
    if (!Finite(positions[i])) return Invalid("vertex " + std::to_string(i) + " is not finite");
    joints = std::max(joints, dominant_joint[i] + 1);
  }
  if (joints > (1u << 24)) return Invalid("dominant joint index too large");
  std::vector<Eigen::Vector3f> lo(joints, Eigen::Vector3f::Constant(std::numeric_limits<float>::max())),
      hi(joints, -lo[0]);
  std::vector<uint8_t> used(joints, 0);
  for (size_t i = 0; i < positions.size(); ++i) {
    const uint32_t j = dominant_joint[i];
    lo[j] = lo[j].cwiseMin(positions[i]);
    hi[j] = hi[j].cwiseMax(positions[i]);
    used[j] = 1;
  }
  JointSpheres out;
  std::vector<int32_t> slot(joints, -1);
  for (uint32_t j = 0; j < joints; ++j) {
    if (!used[j]) continue;
    slot[j] = int32_t(out.centers.size());
    out.centers.push_back(0.5f * (lo[j] + hi[j]));
    out.radii.push_back(0.f);
    out.joints.push_back(j);
  }
  for (size_t i = 0; i < positions.size(); ++i) {
    const int32_t s = slot[dominant_joint[i]];
    out.radii[size_t(s)] = std::max(out.radii[size_t(s)], (positions[i] - out.centers[size_t(s)]).norm());
  }
  return out;
}

Result<JointSpheres> NaiveJointSpheres(const RawCharacter& character) {
  const skinning::SkinnedMesh& skin = character.skin;
  std::vector<uint32_t> dominant(character.vertex_count(), 0);
  if (skin.influence_offsets.size() == character.vertex_count() + 1) {
    for (size_t v = 0; v < character.vertex_count(); ++v) {
      float best = -1.f;
      for (uint32_t k = skin.influence_offsets[v]; k < skin.influence_offsets[v + 1]; ++k) {
        if (k >= skin.influence_weights.size() || k >= skin.influence_binds.size() ||
            skin.influence_binds[k] >= skin.binds.size())
          return Invalid(character.source_file + ": skin influence " + std::to_string(k) + " is out of range");
        if (skin.influence_weights[k] > best) {
          best = skin.influence_weights[k];
          dominant[v] = uint32_t(std::max(0, skin.binds[skin.influence_binds[k]].joint));
        }
      }
    }
  } else if (!skin.influence_offsets.empty()) {
    return Invalid(character.source_file + ": influence_offsets has " + std::to_string(skin.influence_offsets.size()) +
                   " entries for " + std::to_string(character.vertex_count()) + " vertices");
  }
  return NaiveJointSpheres(character.positions_rest, dominant);
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
  return MeasureFit(in, settings);
}

}  // namespace skinspheres::lib
