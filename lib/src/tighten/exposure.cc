// The tightening pass's objective: the exposure E of a sphere, its surface inside no other sphere
// weighted by the distance to the mesh. See tightener.h and sphere_tightener.h.
#include <numbers>

#include "tightener.h"

namespace skinspheres::lib {

std::pair<double, double> Tightener::TotalExposure() {
  double area = 0.0, acc = 0.0;
  for (size_t s = 0; s < sp_.size(); ++s) {
    double a = 0.0, x = 0.0;
    ExposureOf(s, &a, &x);
    area += a;
    acc += x;
  }
  return {acc, area > 0.0 && height_ > 0.0f ? acc / area / height_ : 0.0};
}

void Tightener::Neighbours(const Eigen::Vector3f& c, float reach, long skip_a, long skip_b, Nbrs* out,
                           std::span<const Ball> extras) const {
  out->clear();
  for (const auto& e : extras) out->push(e.center, e.radius);
  for (size_t o = 0; o < sp_.size(); ++o) {
    if (static_cast<long>(o) == skip_a || static_cast<long>(o) == skip_b || sp_[o].triangles.empty()) continue;
    const float lim = sp_[o].radius + reach;
    if ((sp_[o].center - c).squaredNorm() < lim * lim) out->push(sp_[o].center, sp_[o].radius);
  }
  out->pad();
}

double Tightener::Exposure(const Eigen::Vector3f& c, float r, const Nbrs& nbrs, double* exposed_area,
                           double* accurate) const {
  double acc = 0.0;
  double e = 0.0;
  int exposed = 0;
  const size_t n = nbrs.size();
  const float* nx = nbrs.x.data();
  const float* ny = nbrs.y.data();
  const float* nz = nbrs.z.data();
  const float* nr2 = nbrs.r2.data();
  for (const auto& u : unit_) {
    const Eigen::Vector3f q = c + r * u;
    const float qx = q.x(), qy = q.y(), qz = q.z();
    int hits = 0;
    for (size_t k = 0; k < n; ++k) {
      const float dx = qx - nx[k], dy = qy - ny[k], dz = qz - nz[k];
      hits += (dx * dx + dy * dy + dz * dz < nr2[k]) ? 1 : 0;
    }
    if (hits == 0) {
      e += field_.Distance(q);
      if (accurate) acc += field_.TriangleDistance(q);
      ++exposed;
    }
  }
  const double patch = 4.0 * std::numbers::pi * double(r) * r / static_cast<double>(unit_.size());
  if (exposed_area) *exposed_area = exposed * patch;
  if (accurate) *accurate = acc * patch;
  return e * patch;
}

double Tightener::ExposureOf(size_t s, double* exposed_area, double* accurate) {
  Neighbours(sp_[s].center, sp_[s].radius, static_cast<long>(s), -1, &nbrs_);
  return Exposure(sp_[s].center, sp_[s].radius, nbrs_, exposed_area, accurate);
}

double Tightener::GroupExposure(std::span<const Ball> group, size_t s) {
  double e = 0.0;
  std::vector<Ball> others;
  for (size_t i = 0; i < group.size(); ++i) {
    others.assign(group.begin(), group.end());
    others.erase(others.begin() + static_cast<std::ptrdiff_t>(i));
    Neighbours(group[i].center, group[i].radius, static_cast<long>(s), -1, &nbrs_, others);
    e += Exposure(group[i].center, group[i].radius, nbrs_);
  }
  return e;
}

double Tightener::PairExposure(const Ball& a, const Ball& b, size_t s) {
  const Ball g[2] = {a, b};
  return GroupExposure(g, s);
}

}  // namespace skinspheres::lib
