// DistanceField: seeding near the triangles, then vector propagation. See distance_field.h.
#include "skinspheres/lib/geometry/distance_field.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "skinspheres/lib/geometry/closest_point.h"

namespace skinspheres::lib {
namespace {
// Voxels whose centre is within this many voxels of a triangle's bounding box are seeded exactly.
constexpr float kSeedMargin = 1.0f;
constexpr int kMaxResolution = 256;  // 257³ voxels x 20 bytes = 340 MB at most
// Forward + backward sweeps: one round leaves the mean error within ~5% of two rounds' on the shared
// characters (tests/lib/geometry/distance_field_tests.cc bounds it against the exact distance).
constexpr int kRounds = 1;

// A grid coordinate (in voxels) as an index in [0, n): clamped in float first, so huge, infinite or
// NaN coordinates never reach the int conversion (NaN and -inf give 0).
int ClampIndex(float g, int n) {
  if (!(g > 0.0f)) return 0;
  return static_cast<int>(std::min(g, static_cast<float>(n - 1)));
}

// The per-axis [q, 1 - q] quantiles of the triangles' centroids: the body's box, which a few
// stray triangles far away (a prop at the origin, a dropped vertex) do not stretch.
void RobustBox(std::span<const Eigen::Vector3f> positions, std::span<const Eigen::Vector3i> triangles,
               Eigen::Vector3f* lo, Eigen::Vector3f* hi) {
  constexpr double kTail = 0.005;
  std::vector<float> axis(triangles.size());
  for (int k = 0; k < 3; ++k) {
    for (size_t t = 0; t < triangles.size(); ++t) {
      const auto& tri = triangles[t];
      axis[t] = (positions[tri[0]][k] + positions[tri[1]][k] + positions[tri[2]][k]) / 3.0f;
    }
    const size_t a = static_cast<size_t>(kTail * static_cast<double>(axis.size()));
    const size_t b = axis.size() - 1 - a;
    std::nth_element(axis.begin(), axis.begin() + static_cast<std::ptrdiff_t>(a), axis.end());
    (*lo)[k] = axis[a];
    std::nth_element(axis.begin(), axis.begin() + static_cast<std::ptrdiff_t>(b), axis.end());
    (*hi)[k] = axis[b];
  }
}
}  // namespace

DistanceField DistanceField::Build(std::span<const Eigen::Vector3f> positions,
                                   std::span<const Eigen::Vector3i> triangles, int resolution, float padding) {
  DistanceField f;
  if (triangles.empty() || positions.empty()) return f;
  resolution = std::clamp(resolution, 2, kMaxResolution);
  padding = std::max(0.0f, padding);
  Eigen::Vector3f lo, hi;
  RobustBox(positions, triangles, &lo, &hi);
  const float extent = (hi - lo).maxCoeff();
  lo.array() -= padding * extent;
  hi.array() += padding * extent;
  f.voxel_ = (hi - lo).maxCoeff() / static_cast<float>(resolution);
  // A mesh collapsed to a point (or to sub-ulp size): any positive voxel will do.
  if (!(f.voxel_ > 0.0f) || !std::isfinite(f.voxel_)) f.voxel_ = 1.0f;
  f.inv_voxel_ = 1.0f / f.voxel_;
  f.origin_ = lo;
  for (int a = 0; a < 3; ++a) f.dims_[a] = ClampIndex(std::ceil((hi[a] - lo[a]) * f.inv_voxel_), resolution + 1) + 1;
  const Eigen::Vector3f none = Eigen::Vector3f::Constant(std::numeric_limits<float>::infinity());
  f.closest_.assign(static_cast<size_t>(f.dims_.prod()), none);
  f.closest_triangle_.assign(f.closest_.size(), -1);
  f.positions_ = positions;
  f.triangles_ = triangles;
  std::vector<float> best(f.closest_.size(), std::numeric_limits<float>::infinity());
  auto centre = [&](int x, int y, int z) { return Eigen::Vector3f(f.origin_ + f.voxel_ * Eigen::Vector3f(x, y, z)); };

  f.grid_hi_ = f.origin_ + f.voxel_ * (f.dims_ - Eigen::Vector3i::Ones()).cast<float>();

  // 1. Seeding: exact closest points for the voxels around each triangle.
  for (size_t t = 0; t < triangles.size(); ++t) {
    const auto& tri = triangles[t];
    const Eigen::Vector3f &a = positions[tri[0]], &b = positions[tri[1]], &c = positions[tri[2]];
    const Eigen::Vector3f blo = a.cwiseMin(b).cwiseMin(c), bhi = a.cwiseMax(b).cwiseMax(c);
    if ((blo.array() < f.origin_.array()).any() || (bhi.array() > f.grid_hi_.array()).any()) {
      f.outside_.push_back(static_cast<int32_t>(t));
    }
    const Eigen::Vector3f tlo = a.cwiseMin(b).cwiseMin(c).array() - kSeedMargin * f.voxel_;
    const Eigen::Vector3f thi = a.cwiseMax(b).cwiseMax(c).array() + kSeedMargin * f.voxel_;
    Eigen::Vector3i vlo, vhi;
    for (int k = 0; k < 3; ++k) {
      // A triangle outside the grid seeds the nearest boundary voxels (with points on it, so the
      // field still never under-estimates).
      vlo[k] = ClampIndex(std::ceil((tlo[k] - f.origin_[k]) * f.inv_voxel_), f.dims_[k]);
      vhi[k] = std::max(vlo[k], ClampIndex(std::floor((thi[k] - f.origin_[k]) * f.inv_voxel_), f.dims_[k]));
    }
    for (int z = vlo.z(); z <= vhi.z(); ++z) {
      for (int y = vlo.y(); y <= vhi.y(); ++y) {
        for (int x = vlo.x(); x <= vhi.x(); ++x) {
          const Eigen::Vector3f p = centre(x, y, z);
          const Eigen::Vector3f cp = ClosestPointOnTriangleFloat(p, a, b, c);
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
  // (the 13 before it in the sweep order), forward then backward, kRounds times.
  for (int round = 0; round < kRounds; ++round) {
    for (int dir : {+1, -1}) {
      const int zs = dir > 0 ? 0 : f.dims_.z() - 1, ys = dir > 0 ? 0 : f.dims_.y() - 1,
                xs = dir > 0 ? 0 : f.dims_.x() - 1;
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
                  if (nx < 0 || ny < 0 || nz < 0 || nx >= f.dims_.x() || ny >= f.dims_.y() || nz >= f.dims_.z())
                    continue;
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
  for (int k = 0; k < 3; ++k) v[k] = ClampIndex((q[k] - origin_[k]) * inv_voxel_ + 0.5f, dims_[k]);
  return Index(v[0], v[1], v[2]);
}

float DistanceField::OutsideDistance(const Eigen::Vector3f& q, float d) const {
  // Beyond the grid the clamped voxel knows only the body; the triangles that stick out of the
  // grid (few by construction) are measured directly.
  if ((q.array() >= origin_.array()).all() && (q.array() <= grid_hi_.array()).all()) return d;
  for (int32_t t : outside_) {
    const auto& tri = triangles_[static_cast<size_t>(t)];
    d = std::min(
        d, (q - ClosestPointOnTriangleFloat(q, positions_[tri[0]], positions_[tri[1]], positions_[tri[2]])).norm());
  }
  return d;
}

float DistanceField::Distance(const Eigen::Vector3f& q) const {
  if (closest_.empty()) return std::numeric_limits<float>::infinity();
  return OutsideDistance(q, (q - closest_[Nearest(q)]).norm());
}

float DistanceField::TriangleDistance(const Eigen::Vector3f& q) const {
  if (closest_.empty()) return std::numeric_limits<float>::infinity();
  const auto& tri = triangles_[static_cast<size_t>(closest_triangle_[Nearest(q)])];
  const float d =
      (q - ClosestPointOnTriangleFloat(q, positions_[tri[0]], positions_[tri[1]], positions_[tri[2]])).norm();
  // Far beyond the mesh (|q| ~ 1e19 and up) the float products overflow: fall back to the point.
  return std::isfinite(d) ? OutsideDistance(q, d) : Distance(q);
}

}  // namespace skinspheres::lib
