// The body's inside volume on a voxel grid: triangles rasterised onto voxel-centre columns along X,
// Y and Z, six parity/winding votes per voxel (fit_metrics.h explains the method).
#include "skinspheres/lib/metrics/inside_volume.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "metrics_internal.h"

namespace skinspheres::lib {
namespace metrics_internal {
namespace {

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

}  // namespace

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

}  // namespace metrics_internal

using metrics_internal::Bounds;
using metrics_internal::Grid;
using metrics_internal::InsideVotes;
using metrics_internal::Invalid;
using metrics_internal::kInsideVotes;
using metrics_internal::MakeGrid;
using metrics_internal::ValidateMesh;
using metrics_internal::Vec3d;

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

}  // namespace skinspheres::lib
