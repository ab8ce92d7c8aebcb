// Spheres per disk level (paper §4.2, the Sphere Construction stage of §5, and §4.4 for M1-A) and
// the levels kept (§4.3). See fit_stages.h.
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <numbers>

#include "fit_stages.h"

namespace skinspheres::lib {
namespace {

// One sector's sphere by the chosen method (geometry/enclosing_sphere.h): M1 centroid, M2 minimum
// ball, M1-A the centroid ball moved towards the disk centre *.c in the disk plane γ0γ1.
Ball MakeBall(SphereMethod method, std::span<const Eigen::Vector3f> pts, const Eigen::Vector3f& disk_center,
              const Eigen::Vector3f& n0, const Eigen::Vector3f& n1) {
  switch (method) {
    case SphereMethod::kM1: return CentroidBall(pts);
    case SphereMethod::kM2: return MinimumBall(pts);
    case SphereMethod::kM1A: return AdjustM1(CentroidBall(pts), pts, disk_center, n0, n1);
  }
  return CentroidBall(pts);
}

float MeanRadius(const std::vector<CandidateSphere>& spheres) {
  float r = 0.0f;
  for (const auto& s : spheres) r += s.ball.radius;
  return spheres.empty() ? 0.0f : r / static_cast<float>(spheres.size());
}

}  // namespace

// The sectors are centred on the principal axes of the section (in the disk plane), so p = 2 cuts an
// ellipse across its long axis and p = 4 gives one sphere per side.
std::vector<CandidateSphere> LevelSpheres(const DiskLevel& level, int rays, int p, SphereMethod method) {
  std::vector<CandidateSphere> out;
  if (level.contacts.size() < 2) return out;
  Eigen::Vector3f mean = Eigen::Vector3f::Zero();
  for (const auto& c : level.contacts) mean += c.point;
  mean /= static_cast<float>(level.contacts.size());  // *.c of this level (Disk Centered)
  const double two_pi = 2.0 * std::numbers::pi;
  double theta = 0.0;
  if (p > 1) {
    Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
    for (const auto& c : level.contacts) {
      const Eigen::Vector3f d = c.point - mean;
      const Eigen::Vector2d q(d.dot(level.n0), d.dot(level.n1));
      cov += q * q.transpose();
    }
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(cov);
    const Eigen::Vector2d major = eig.eigenvectors().col(1);
    theta = std::atan2(major.y(), major.x());
  }
  const double alpha = two_pi / rays;  // α
  const double width = two_pi / p;
  std::vector<std::vector<Eigen::Vector3f>> sectors(p);  // S_0 .. S_{p-1}
  for (const auto& c : level.contacts) {
    double phi = c.ray * alpha - theta + width / 2.0;
    phi -= two_pi * std::floor(phi / two_pi);
    const int k = std::min(p - 1, static_cast<int>(phi / width));
    sectors[k].push_back(c.point);
  }
  for (const auto& pts : sectors) {
    if (pts.empty()) continue;
    CandidateSphere s;
    s.ball = MakeBall(method, pts, mean, level.n0, level.n1);
    s.f = FitError(s.ball, pts);
    s.points = static_cast<int>(pts.size());
    out.push_back(s);
  }
  return out;
}

// §4.3: a level is kept when the distance d along the path from the last kept level satisfies
// d >= (1 - PD)(r̄_last + r̄_new), r̄ the mean radius of a level's spheres; otherwise it waits as
// the pending level, which is kept if the path ends before another level is.
void SelectLevels(std::span<const DiskLevel> levels, int p, const FitSettings& settings, PartSpheres* out) {
  std::vector<CandidateSphere> last_spheres;
  float last_s = 0.0f;
  bool have_last = false;
  std::vector<CandidateSphere> pending;  // the latest level not kept, kept if the path ends
  float pending_s = 0.0f;
  uint16_t level_index = 0;
  double f_sum = 0.0;
  int f_count = 0;
  auto keep = [&](std::vector<CandidateSphere> spheres, float s) {
    for (auto& sp : spheres) {
      sp.level = level_index;
      out->spheres.push_back(sp);
      f_sum += static_cast<double>(sp.f.mean) * sp.points;
      f_count += sp.points;
      out->report.f_max = std::max(out->report.f_max, sp.f.max);
    }
    ++level_index;
    last_spheres = std::move(spheres);
    last_s = s;
    have_last = true;
    pending.clear();
  };
  for (const auto& level : levels) {
    out->report.rays_cast += settings.rays;
    out->report.rays_hit += static_cast<int>(level.contacts.size());
    std::vector<CandidateSphere> spheres = LevelSpheres(level, settings.rays, p, settings.method);
    if (spheres.empty()) continue;
    const float d = level.s - last_s;
    if (!have_last || d >= (1.0f - settings.overlap) * (MeanRadius(last_spheres) + MeanRadius(spheres))) {
      keep(std::move(spheres), level.s);
    } else {
      pending = std::move(spheres);
      pending_s = level.s;
    }
  }
  if (!pending.empty()) keep(std::move(pending), pending_s);  // the end of the path is always covered
  out->report.levels_kept = level_index;
  out->report.f_mean = f_count ? static_cast<float>(f_sum / f_count) : 0.0f;
}

}  // namespace skinspheres::lib
