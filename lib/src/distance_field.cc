// DistanceField: seeding near the triangles, then vector propagation. See distance_field.h.
#include "skinspheres/lib/distance_field.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "skinspheres/lib/fit_metrics.h"  // ClosestPointOnTriangle

namespace skinspheres::lib {
namespace {
// Voxels whose centre is within this many voxels of a triangle's bounding box are seeded exactly.
constexpr float kSeedMargin = 1.0f;
// Forward + backward sweeps: one round leaves the mean error within ~5% of two rounds' on the shared
// characters (tests/lib/distance_field_tests.cc bounds it against the exact distance).
constexpr int kRounds = 1;

// Ericson, Real-Time Collision Detection §5.1.5, in float (the seeding's hot loop); degenerate
// triangles resolve to a vertex or an edge point through the same region tests.
Eigen::Vector3f ClosestPoint(const Eigen::Vector3f& p, const Eigen::Vector3f& a, const Eigen::Vector3f& b,
                             const Eigen::Vector3f& c) {
  const Eigen::Vector3f ab = b - a, ac = c - a, ap = p - a;
  const float d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0f && d2 <= 0.0f) return a;
  const Eigen::Vector3f bp = p - b;
  const float d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0f && d4 <= d3) return b;
  const float vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0f && d1 >= 0.0f && d3 <= 0.0f && d1 - d3 > 0.0f) return a + (d1 / (d1 - d3)) * ab;
  const Eigen::Vector3f cp = p - c;
  const float d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0f && d5 <= d6) return c;
  const float vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0f && d2 >= 0.0f && d6 <= 0.0f && d2 - d6 > 0.0f) return a + (d2 / (d2 - d6)) * ac;
  const float va = d3 * d6 - d5 * d4;
  if (va <= 0.0f && (d4 - d3) >= 0.0f && (d5 - d6) >= 0.0f && (d4 - d3) + (d5 - d6) > 0.0f) {
    return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  }
  const float sum = va + vb + vc;
  if (!(sum > 0.0f)) return ClosestPointOnTriangle(p, a, b, c);  // degenerate: the careful version
  const float denom = 1.0f / sum;
  return a + ab * (vb * denom) + ac * (vc * denom);
}
}  // namespace

DistanceField DistanceField::Build(std::span<const Eigen::Vector3f> positions, std::span<const Eigen::Vector3i> triangles,
                                   int resolution, float padding) {
  DistanceField f;
  if (triangles.empty() || positions.empty()) return f;
  resolution = std::clamp(resolution, 2, 1024);
  padding = std::max(0.0f, padding);
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::infinity()), hi = -lo;
  for (const auto& tri : triangles) {
    for (int k = 0; k < 3; ++k) {
      lo = lo.cwiseMin(positions[tri[k]]);
      hi = hi.cwiseMax(positions[tri[k]]);
    }
  }
  const float extent = std::max((hi - lo).maxCoeff(), 1e-12f);
  lo.array() -= padding * extent;
  hi.array() += padding * extent;
  f.voxel_ = (hi - lo).maxCoeff() / static_cast<float>(resolution);
  f.inv_voxel_ = 1.0f / f.voxel_;
  f.origin_ = lo;
  for (int a = 0; a < 3; ++a) {
    f.dims_[a] = std::clamp(static_cast<int>(std::ceil((hi[a] - lo[a]) / f.voxel_)) + 1, 1, resolution + 1);
  }
  const Eigen::Vector3f none = Eigen::Vector3f::Constant(std::numeric_limits<float>::infinity());
  f.closest_.assign(static_cast<size_t>(f.dims_.prod()), none);
  f.closest_triangle_.assign(f.closest_.size(), -1);
  f.positions_ = positions;
  f.triangles_ = triangles;
  std::vector<float> best(f.closest_.size(), std::numeric_limits<float>::infinity());
  auto centre = [&](int x, int y, int z) { return Eigen::Vector3f(f.origin_ + f.voxel_ * Eigen::Vector3f(x, y, z)); };

  // 1. Seeding: exact closest points for the voxels around each triangle.
  for (size_t t = 0; t < triangles.size(); ++t) {
    const auto& tri = triangles[t];
    const Eigen::Vector3f &a = positions[tri[0]], &b = positions[tri[1]], &c = positions[tri[2]];
    const Eigen::Vector3f tlo = a.cwiseMin(b).cwiseMin(c).array() - kSeedMargin * f.voxel_;
    const Eigen::Vector3f thi = a.cwiseMax(b).cwiseMax(c).array() + kSeedMargin * f.voxel_;
    Eigen::Vector3i vlo, vhi;
    for (int k = 0; k < 3; ++k) {
      vlo[k] = std::clamp(static_cast<int>(std::ceil((tlo[k] - f.origin_[k]) / f.voxel_)), 0, f.dims_[k] - 1);
      vhi[k] = std::clamp(static_cast<int>(std::floor((thi[k] - f.origin_[k]) / f.voxel_)), 0, f.dims_[k] - 1);
    }
    for (int z = vlo.z(); z <= vhi.z(); ++z) {
      for (int y = vlo.y(); y <= vhi.y(); ++y) {
        for (int x = vlo.x(); x <= vhi.x(); ++x) {
          const Eigen::Vector3f p = centre(x, y, z);
          const Eigen::Vector3f cp = ClosestPoint(p, a, b, c);
          const float d2 = (cp - p).squaredNorm();
          const size_t i = f.Index(x, y, z);
          if (d2 < best[i]) {
            best[i] = d2;
            f.closest_[i] = cp;
            f.closest_triangle_[i] = static_cast<int32_t>(t);
          }
        }
      }
    }
  }

  // 2. Propagation: each voxel looks at the closest points of its already-visited neighbours
  // (the 13 before it in the sweep order), forward then backward, twice.
  for (int round = 0; round < kRounds; ++round) {
    for (int dir : {+1, -1}) {
      const int zs = dir > 0 ? 0 : f.dims_.z() - 1, ys = dir > 0 ? 0 : f.dims_.y() - 1, xs = dir > 0 ? 0 : f.dims_.x() - 1;
      for (int z = zs; z >= 0 && z < f.dims_.z(); z += dir) {
        for (int y = ys; y >= 0 && y < f.dims_.y(); y += dir) {
          for (int x = xs; x >= 0 && x < f.dims_.x(); x += dir) {
            const size_t i = f.Index(x, y, z);
            const Eigen::Vector3f p = centre(x, y, z);
            for (int dz = -1; dz <= 0; ++dz) {
              for (int dy = -1; dy <= 1; ++dy) {
                for (int dx = -1; dx <= 1; ++dx) {
                  // The 13 neighbours that precede (x, y, z) in this sweep.
                  if (dz == 0 && (dy > 0 || (dy == 0 && dx >= 0))) continue;
                  const int nx = x + dir * dx, ny = y + dir * dy, nz = z + dir * dz;
                  if (nx < 0 || ny < 0 || nz < 0 || nx >= f.dims_.x() || ny >= f.dims_.y() || nz >= f.dims_.z()) continue;
                  const size_t n = f.Index(nx, ny, nz);
                  const Eigen::Vector3f& cp = f.closest_[n];
                  if (!std::isfinite(cp.x())) continue;
                  const float d2 = (cp - p).squaredNorm();
                  if (d2 < best[i]) {
                    best[i] = d2;
                    f.closest_[i] = cp;
                    f.closest_triangle_[i] = f.closest_triangle_[n];
                  }
                }
              }
            }
          }
        }
      }
    }
  }
  return f;
}

size_t DistanceField::Nearest(const Eigen::Vector3f& q) const {
  int v[3];
  for (int k = 0; k < 3; ++k) {
    const float g = (q[k] - origin_[k]) * inv_voxel_;
    // NaN compares false everywhere and lands on voxel 0: still a point of the mesh.
    v[k] = g > 0.0f ? std::min(static_cast<int>(g + 0.5f), dims_[k] - 1) : 0;
  }
  return Index(v[0], v[1], v[2]);
}

float DistanceField::Distance(const Eigen::Vector3f& q) const {
  if (closest_.empty()) return std::numeric_limits<float>::infinity();
  return (q - closest_[Nearest(q)]).norm();
}

float DistanceField::TriangleDistance(const Eigen::Vector3f& q) const {
  if (closest_.empty()) return std::numeric_limits<float>::infinity();
  const auto& tri = triangles_[static_cast<size_t>(closest_triangle_[Nearest(q)])];
  return (q - ClosestPoint(q, positions_[tri[0]], positions_[tri[1]], positions_[tri[2]])).norm();
}

}  // namespace skinspheres::lib
