#include "colliders/shape_fit.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

namespace skinspheres::lib::colliders {

namespace {

double Sign(double x) { return x > 0.0 ? 1.0 : (x < 0.0 ? -1.0 : 0.0); }

// Distance from p to the segment [a, b].
float SegmentDistance(const Eigen::Vector3f& p, const Eigen::Vector3f& a, const Eigen::Vector3f& b) {
  const Eigen::Vector3f ab = b - a;
  const float l2 = ab.squaredNorm();
  const float t = l2 > 0.0f ? std::clamp((p - a).dot(ab) / l2, 0.0f, 1.0f) : 0.0f;
  return (p - (a + t * ab)).norm();
}

// The value below which a share q of xs lies (xs is reordered).
float Quantile(std::vector<float>* xs, float q) {
  if (xs->empty()) return 0.0f;
  const size_t k = std::min(xs->size() - 1, static_cast<size_t>(std::floor(q * static_cast<float>(xs->size() - 1))));
  std::nth_element(xs->begin(), xs->begin() + static_cast<std::ptrdiff_t>(k), xs->end());
  return (*xs)[k];
}

// The points that decide a covering shape along axis d: per slice of the axis, those farthest from
// it, and the two ends.
std::vector<Eigen::Vector3f> Extremes(std::span<const Eigen::Vector3f> points, const Eigen::Vector3f& c,
                                      const Eigen::Vector3f& d, float* tmin, float* tmax) {
  constexpr int kBins = 48, kPerBin = 4;
  *tmin = std::numeric_limits<float>::max();
  *tmax = std::numeric_limits<float>::lowest();
  size_t imin = 0, imax = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    const float t = (points[i] - c).dot(d);
    if (t < *tmin) *tmin = t, imin = i;
    if (t > *tmax) *tmax = t, imax = i;
  }
  const float span = std::max(*tmax - *tmin, 1e-20f);
  std::vector<std::array<std::pair<float, uint32_t>, kPerBin>> bins(kBins,
                                                                    std::array<std::pair<float, uint32_t>, kPerBin>{});
  for (auto& bin : bins) bin.fill({-1.0f, 0});
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f v = points[i] - c;
    const float t = v.dot(d);
    const float rho = (v - t * d).squaredNorm();
    const int k = std::clamp(static_cast<int>((t - *tmin) / span * kBins), 0, kBins - 1);
    auto& bin = bins[static_cast<size_t>(k)];
    if (rho <= bin[kPerBin - 1].first) continue;
    bin[kPerBin - 1] = {rho, static_cast<uint32_t>(i)};
    for (int m = kPerBin - 1; m > 0 && bin[m].first > bin[m - 1].first; --m) std::swap(bin[m], bin[m - 1]);
  }
  std::vector<Eigen::Vector3f> out{points[imin], points[imax]};
  for (const auto& bin : bins) {
    for (const auto& [rho, i] : bin) {
      if (rho >= 0.0f) out.push_back(points[i]);
    }
  }
  return out;
}

bool Covers(const RoundCone& s, std::span<const Eigen::Vector3f> points, float slack) {
  for (const auto& p : points) {
    if (SignedDistance(s, p) > slack) return false;
  }
  return true;
}

// The smallest tail radius covering `points` for this head radius, or -1 when none up to `limit`.
float SmallestTail(RoundCone s, std::span<const Eigen::Vector3f> points, float slack, float limit) {
  s.rb = limit;
  if (!Covers(s, points, slack)) return -1.0f;
  float lo = 0.0f, hi = limit;
  for (int it = 0; it < 14; ++it) {
    s.rb = 0.5f * (lo + hi);
    (Covers(s, points, slack) ? hi : lo) = s.rb;
  }
  return hi;
}

// Sphere: the smallest enclosing ball of `points`, approximately (Badoiu-Clarkson iterations).
RoundCone FitSphere(std::span<const Eigen::Vector3f> points, Eigen::Vector3f c, float slack) {
  for (int it = 1; it <= 60; ++it) {
    size_t far = 0;
    float best = -1.0f;
    for (size_t i = 0; i < points.size(); ++i) {
      const float d2 = (points[i] - c).squaredNorm();
      if (d2 > best) best = d2, far = i;
    }
    c += (points[far] - c) / static_cast<float>(it + 1);
  }
  float r = 0.0f;
  for (const auto& p : points) r = std::max(r, (p - c).norm());
  return RoundCone{c, c, std::max(r - slack, 0.0f), std::max(r - slack, 0.0f)};
}

using Candidates = std::vector<RoundCone>;

// Capsules along axis d: ends chosen on a grid inside the cloud's extent, straight capsules first;
// the best few then tapered.
void FitAlongAxis(std::span<const Eigen::Vector3f> points, const Eigen::Vector3f& c, const Eigen::Vector3f& d,
                  const ShapeFitSettings& settings, Candidates* out) {
  float tmin = 0.0f, tmax = 0.0f;
  const std::vector<Eigen::Vector3f> ext = Extremes(points, c, d, &tmin, &tmax);
  const float span = tmax - tmin;
  if (!(span > 0.0f)) return;
  constexpr std::array<float, 6> kInset{0.0f, 0.06f, 0.12f, 0.2f, 0.3f, 0.4f};
  std::vector<std::pair<double, RoundCone>> straight;
  for (float i0 : kInset) {
    for (float i1 : kInset) {
      if (i0 + i1 >= 0.95f) continue;
      const Eigen::Vector3f a = c + (tmin + i0 * span) * d, b = c + (tmax - i1 * span) * d;
      float r = 0.0f;
      for (const auto& p : ext) r = std::max(r, SegmentDistance(p, a, b));
      r = std::max(r - settings.slack, 0.0f);
      straight.emplace_back(Volume(RoundCone{a, b, r, r}), RoundCone{a, b, r, r});
      out->push_back(straight.back().second);
    }
  }
  if (!settings.tapered || straight.empty()) return;
  std::sort(straight.begin(), straight.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
  for (size_t k = 0; k < std::min<size_t>(3, straight.size()); ++k) {
    RoundCone s = straight[k].second;
    const float r = s.ra + settings.slack + 1e-6f * span;
    for (int m = 0; m < 10; ++m) {
      s.ra = r * (0.25f + 0.15f * static_cast<float>(m));
      const float rb = SmallestTail(s, ext, settings.slack, 2.0f * r);
      if (rb < 0.0f) continue;
      RoundCone t = s;
      t.rb = rb;
      out->push_back(t);
    }
  }
}

}  // namespace

float SignedDistance(const RoundCone& s, const Eigen::Vector3f& point) {
  const Eigen::Vector3d a = s.a.cast<double>(), b = s.b.cast<double>(), p = point.cast<double>();
  const double r1 = s.ra, r2 = s.rb;
  const Eigen::Vector3d ba = b - a;
  const double l2 = ba.squaredNorm(), rr = r1 - r2;
  if (l2 <= rr * rr * (1.0 + 1e-9) || l2 <= 1e-30) {  // one ball holds the other
    return static_cast<float>(r1 >= r2 ? (p - a).norm() - r1 : (p - b).norm() - r2);
  }
  const double a2 = l2 - rr * rr, il2 = 1.0 / l2;
  const Eigen::Vector3d pa = p - a;
  const double y = pa.dot(ba), z = y - l2;
  const double x2 = (pa * l2 - ba * y).squaredNorm();
  const double y2 = y * y * l2, z2 = z * z * l2;
  const double k = Sign(rr) * rr * rr * x2;
  if (Sign(z) * a2 * z2 > k) return static_cast<float>(std::sqrt(x2 + z2) * il2 - r2);
  if (Sign(y) * a2 * y2 < k) return static_cast<float>(std::sqrt(x2 + y2) * il2 - r1);
  return static_cast<float>((std::sqrt(x2 * a2 * il2) + y * rr) * il2 - r1);
}

double Volume(const RoundCone& s) {
  const double l = (s.b - s.a).norm(), r1 = s.ra, r2 = s.rb;
  if (l <= std::abs(r1 - r2)) return 4.0 / 3.0 * std::numbers::pi * std::pow(std::max(r1, r2), 3);
  return std::numbers::pi * (l * (r1 * r1 + r1 * r2 + r2 * r2) / 3.0 + 2.0 / 3.0 * (r1 * r1 * r1 + r2 * r2 * r2));
}

ShapeFitResult FitShape(std::span<const Eigen::Vector3f> points, const Eigen::Vector3f& hint,
                        const ShapeFitSettings& settings) {
  if (points.empty()) return {};
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : points) mean += p.cast<double>();
  mean /= static_cast<double>(points.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : points) {
    const Eigen::Vector3d v = p.cast<double>() - mean;
    cov += v * v.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  const Eigen::Vector3f c = mean.cast<float>();
  std::vector<Eigen::Vector3f> axes{eig.eigenvectors().col(2).cast<float>().normalized()};
  if (hint.norm() > 0.0f && std::abs(hint.normalized().dot(axes[0])) < 0.999f) axes.push_back(hint.normalized());

  Candidates candidates;
  if (settings.allow_capsule) {
    for (const auto& d : axes) FitAlongAxis(points, c, d, settings, &candidates);
  }
  if (settings.allow_sphere || candidates.empty()) {
    float tmin = 0.0f, tmax = 0.0f;
    candidates.push_back(FitSphere(Extremes(points, c, axes[0], &tmin, &tmax), c, settings.slack));
  }
  // Each candidate covers the extremes; grown or shrunk (both balls alike: the hull moves by the same
  // distance everywhere) so that the chosen share of a sample lies within slack, it is scored by
  // how deep the sample lies under its surface. The winner is then sized on every point.
  const size_t stride = std::max<size_t>(1, points.size() / 1500);
  std::vector<Eigen::Vector3f> sample;
  for (size_t i = 0; i < points.size(); i += stride) sample.push_back(points[i]);
  auto sized = [&](RoundCone s, std::span<const Eigen::Vector3f> pts, double* depth) {
    std::vector<float> sd(pts.size());
    for (size_t i = 0; i < pts.size(); ++i) sd[i] = SignedDistance(s, pts[i]);
    std::vector<float> sorted = sd;
    const float e = Quantile(&sorted, settings.quantile) - settings.slack;
    const float floor = 1e-4f * std::max(s.ra, s.rb) + 1e-12f;
    const float ea = std::max(s.ra + e, floor) - s.ra, eb = std::max(s.rb + e, floor) - s.rb;
    s.ra += ea, s.rb += eb;
    double sum = 0.0;
    for (float x : sd) sum += std::max(0.0f, -(x - std::min(ea, eb)));
    *depth = pts.empty() ? 0.0 : sum / static_cast<double>(pts.size());
    return s;
  };
  double best_depth = std::numeric_limits<double>::infinity();
  RoundCone best;
  for (const RoundCone& cand : candidates) {
    double depth = 0.0;
    sized(cand, sample, &depth);
    if (depth < best_depth) best_depth = depth, best = cand;
  }
  double depth = 0.0;
  const RoundCone s = sized(best, points, &depth);
  return ShapeFitResult{s, depth * static_cast<double>(points.size()), true};
}

void SurfaceSamples(const RoundCone& s, int per_sphere, std::vector<Eigen::Vector3f>* points,
                    std::vector<float>* areas) {
  points->clear();
  areas->clear();
  const float golden = std::numbers::pi_v<float> * (3.0f - std::sqrt(5.0f));
  auto sphere = [&](const Eigen::Vector3f& c, float r) {
    const float area = 4.0f * std::numbers::pi_v<float> * r * r / static_cast<float>(per_sphere);
    for (int i = 0; i < per_sphere; ++i) {
      const float z = 1.0f - 2.0f * (static_cast<float>(i) + 0.5f) / static_cast<float>(per_sphere);
      const float rho = std::sqrt(std::max(0.0f, 1.0f - z * z)), phi = golden * static_cast<float>(i);
      const Eigen::Vector3f p = c + r * Eigen::Vector3f(rho * std::cos(phi), rho * std::sin(phi), z);
      if (SignedDistance(s, p) > -1e-4f * r) points->push_back(p), areas->push_back(area);
    }
  };
  sphere(s.a, s.ra);
  const float l = (s.b - s.a).norm();
  if (l <= std::abs(s.ra - s.rb)) return;
  sphere(s.b, s.rb);
  // The cone between the two circles where it touches the balls.
  const Eigen::Vector3f d = (s.b - s.a) / l;
  const float sin_t = (s.ra - s.rb) / l, cos_t = std::sqrt(std::max(0.0f, 1.0f - sin_t * sin_t));
  Eigen::Vector3f u = d.unitOrthogonal(), v = d.cross(u);
  const int rings = std::max(2, static_cast<int>(std::ceil(l / (std::max(s.ra, s.rb) * 0.4f)))), around = 24;
  const Eigen::Vector3f p0 = s.a + s.ra * sin_t * d, p1 = s.b + s.rb * sin_t * d;
  const float q0 = s.ra * cos_t, q1 = s.rb * cos_t;
  const float slant = std::sqrt((p1 - p0).squaredNorm() + (q0 - q1) * (q0 - q1));
  for (int i = 0; i < rings; ++i) {
    const float f = (static_cast<float>(i) + 0.5f) / static_cast<float>(rings);
    const float q = q0 + f * (q1 - q0);
    const float area = 2.0f * std::numbers::pi_v<float> * q * slant / static_cast<float>(rings * around);
    for (int k = 0; k < around; ++k) {
      const float phi = 2.0f * std::numbers::pi_v<float> * (static_cast<float>(k) + 0.5f * static_cast<float>(i % 2)) /
                        static_cast<float>(around);
      points->push_back(p0 + f * (p1 - p0) + q * (std::cos(phi) * u + std::sin(phi) * v));
      areas->push_back(area);
    }
  }
}

}  // namespace skinspheres::lib::colliders
