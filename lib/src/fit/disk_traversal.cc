// Paper §4.1 (Disk Translation) and §5 (Disk Construction, Ray Triangle Intersection Test,
// Disk Centered).
#include "skinspheres/lib/fit/disk_traversal.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace skinspheres::lib {

void DiskPath::Evaluate(float s, Eigen::Vector3f* point, Eigen::Vector3f* tangent) const {
  s = std::clamp(s, 0.0f, length());
  // Segment k holds s when arc_length[k] <= s <= arc_length[k+1].
  size_t k = std::upper_bound(arc_length.begin(), arc_length.end(), s) - arc_length.begin();
  k = std::clamp<size_t>(k, 1, points.size() - 1) - 1;
  const Eigen::Vector3f d = points[k + 1] - points[k];
  const float len = arc_length[k + 1] - arc_length[k];
  *tangent = d / len;
  *point = points[k] + (s - arc_length[k]) * *tangent;
}

namespace {

// Principal axis of a point set (largest-variance direction), deterministic sign (largest
// component positive).
Eigen::Vector3f PrincipalAxis(std::span<const Eigen::Vector3f> pts, const Eigen::Vector3f& mean) {
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : pts) {
    const Eigen::Vector3d d = (p - mean).cast<double>();
    cov += d * d.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  Eigen::Vector3f axis = eig.eigenvectors().col(2).cast<float>();
  Eigen::Index k;
  axis.cwiseAbs().maxCoeff(&k);
  if (axis[k] < 0) axis = -axis;
  return axis.normalized();
}

}  // namespace

DiskPath BuildDiskPath(std::span<const Eigen::Vector3f> chain, std::span<const Eigen::Vector3f> verts) {
  DiskPath path;
  if (verts.empty()) return path;
  Eigen::Vector3f lo = verts[0], hi = verts[0];
  for (const auto& v : verts) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  const float merge = 1e-4f * (hi - lo).norm();
  std::vector<Eigen::Vector3f> pts;
  for (const auto& j : chain) {
    if (pts.empty() || (j - pts.back()).norm() > merge) pts.push_back(j);
  }
  if (pts.size() < 2) {
    Eigen::Vector3f mean = Eigen::Vector3f::Zero();
    for (const auto& v : verts) mean += v;
    mean /= static_cast<float>(verts.size());
    const Eigen::Vector3f axis = PrincipalAxis(verts, mean);
    // Along the principal axis over the vertices' extent (never shorter than float can resolve
    // at these coordinates, so the path keeps a direction far from the origin too).
    float tmin = 0.0f, tmax = 0.0f;
    for (const auto& v : verts) {
      tmin = std::min(tmin, (v - mean).dot(axis));
      tmax = std::max(tmax, (v - mean).dot(axis));
    }
    const float floor =
        std::max(1e-3f * (hi - lo).norm(), 64.0f * std::numeric_limits<float>::epsilon() * mean.cwiseAbs().maxCoeff());
    if (tmax - tmin < floor) {
      tmin = -floor;
      tmax = floor;
    }
    pts = {mean + axis * tmin, mean + axis * tmax};
  }
  // Extend both ends along the end segments to the extreme projections of the part's vertices.
  const Eigen::Vector3f d0 = (pts[1] - pts[0]).normalized();
  const Eigen::Vector3f d1 = (pts.back() - pts[pts.size() - 2]).normalized();
  float before = 0.0f, after = 0.0f;
  for (const auto& v : verts) {
    before = std::max(before, -(v - pts.front()).dot(d0));
    after = std::max(after, (v - pts.back()).dot(d1));
  }
  if (before > merge) pts.insert(pts.begin(), pts.front() - before * d0);
  if (after > merge) pts.push_back(pts.back() + after * d1);
  path.points = std::move(pts);
  path.arc_length.resize(path.points.size());
  path.arc_length[0] = 0.0f;
  for (size_t k = 1; k < path.points.size(); ++k) {
    path.arc_length[k] = path.arc_length[k - 1] + (path.points[k] - path.points[k - 1]).norm();
  }
  return path;
}

std::vector<DiskLevel> TraverseDisk(const TriangleBvh& bvh, const DiskPath& path, const DiskSettings& settings) {
  std::vector<DiskLevel> levels;
  if (path.points.size() < 2 || settings.rays < 3 || !(settings.step > 0.0f)) return levels;
  const float length = path.length();
  if (!(length > 0.0f) || !std::isfinite(length)) return levels;
  const int steps = std::max(1, static_cast<int>(std::ceil(length / settings.step)));
  const float alpha = 2.0f * std::numbers::pi_v<float> / static_cast<float>(settings.rays);  // α = 360°/Nr
  std::vector<Eigen::Vector2f> ray_dir(settings.rays);
  for (int i = 0; i < settings.rays; ++i) ray_dir[i] = {std::cos(i * alpha), std::sin(i * alpha)};

  Eigen::Vector3f n0_prev = Eigen::Vector3f::Zero();
  Eigen::Vector3f offset = Eigen::Vector3f::Zero();  // re-centring carried to the next step
  levels.reserve(steps + 1);
  for (int h = 0; h <= steps; ++h) {
    DiskLevel level;
    level.s = std::min(length, h * length / static_cast<float>(steps));  // * += δγ
    Eigen::Vector3f point;
    path.Evaluate(level.s, &point, &level.tangent);
    // γ0 by parallel transport: the previous γ0 projected onto the new plane.
    Eigen::Vector3f n0 = n0_prev - n0_prev.dot(level.tangent) * level.tangent;
    if (n0.squaredNorm() < 1e-8f) {
      Eigen::Index k;
      level.tangent.cwiseAbs().minCoeff(&k);
      n0 = Eigen::Vector3f::Unit(k).cross(level.tangent);
    }
    level.n0 = n0.normalized();
    level.n1 = level.tangent.cross(level.n0);  // γ = γ0 × γ1  <=>  γ1 = γ × γ0
    n0_prev = level.n0;
    offset -= offset.dot(level.tangent) * level.tangent;  // stay in the new plane
    level.center = point + offset;
    for (int i = 0; i < settings.rays; ++i) {
      const Eigen::Vector3f dir = ray_dir[i].x() * level.n0 + ray_dir[i].y() * level.n1;
      if (auto hit = bvh.FirstHit(level.center, dir, settings.ray_length)) {
        level.contacts.push_back({static_cast<uint16_t>(i), hit->triangle, hit->point});
      }
    }
    if (2 * level.contacts.size() >= static_cast<size_t>(settings.rays)) {
      // Disk Centered: C = mean of the contact points; the next disk starts there (in-plane).
      // Only a mostly closed ring is trusted: with most rays missing (an open end, a hole) the
      // mean sits on one side, so the disk goes back onto the path instead of drifting out.
      Eigen::Vector3f mean = Eigen::Vector3f::Zero();
      for (const auto& c : level.contacts) mean += c.point;
      mean /= static_cast<float>(level.contacts.size());
      offset = mean - point;
    } else {
      offset.setZero();
    }
    levels.push_back(std::move(level));
  }
  return levels;
}

}  // namespace skinspheres::lib
