// Sphere construction M1, M2 and the adjustment M1-A of the paper (§4.2-4.4, §5), and F (§4.4).
#include "skinspheres/lib/geometry/enclosing_sphere.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

namespace skinspheres::lib {
namespace {

using Vec3d = Eigen::Vector3d;

// The returned ball: float centre, radius = the holding radius around that float centre.
Ball Finalize(const Vec3d& center_d, std::span<const Eigen::Vector3f> points) {
  Ball b;
  b.center = center_d.cast<float>();
  b.radius = HoldingRadius(points, b.center);
  return b;
}

bool ContainsAll(const Ball& b, std::span<const Eigen::Vector3f> points) {
  const Vec3d c = b.center.cast<double>();
  for (const Eigen::Vector3f& p : points) {
    if (!((p.cast<double>() - c).norm() <= static_cast<double>(b.radius))) return false;
  }
  return true;
}

// ---- M2: Welzl move-to-front with Gärtner's stable support-set update -----------------------

// Gärtner's support-set ball: Push keeps the ball with all support points on its boundary and
// its centre in their affine hull. As in his mtf_mb, the "current" ball is updated by Push only
// (not by Pop): after a sub-call returns it is the minimum ball of the prefix just processed.
class SupportBall {
 public:
  // Adds p to the support set; false (and no change) when p is (nearly) affinely dependent on the
  // current support points (collinear, coplanar, duplicate), relative to the current radius.
  bool Push(const Vec3d& p) {
    if (m_ == 0) {
      q0_ = p;
      c_[0] = p;
      sqr_r_[0] = 0.0;
    } else {
      if (m_ >= 4) return false;
      v_[m_] = p - q0_;
      for (int i = 1; i < m_; ++i) a_[m_][i] = 2.0 * v_[i].dot(v_[m_]) / z_[i];
      for (int i = 1; i < m_; ++i) v_[m_] -= a_[m_][i] * v_[i];
      z_[m_] = 2.0 * v_[m_].squaredNorm();
      // Reject a (nearly) affinely dependent point: its component off the support hull is tiny.
      const double scale = std::max(current_sqr_r_, (p - q0_).squaredNorm());
      if (!(z_[m_] > kDependentRelative * scale)) return false;
      const double e = (p - c_[m_ - 1]).squaredNorm() - sqr_r_[m_ - 1];
      const double f = e / z_[m_];
      c_[m_] = c_[m_ - 1] + f * v_[m_];
      sqr_r_[m_] = sqr_r_[m_ - 1] + e * f / 2.0;
    }
    current_c_ = c_[m_];
    current_sqr_r_ = sqr_r_[m_];
    ++m_;
    return true;
  }
  void Pop() { --m_; }
  int size() const { return m_; }
  void Reset() {
    m_ = 0;
    current_sqr_r_ = -1.0;  // contains nothing: every point has positive excess
  }
  const Vec3d& center() const { return current_c_; }
  double sqr_radius() const { return current_sqr_r_; }
  // ||p - c||² - r² of the current ball (> 0: outside).
  double Excess(const Vec3d& p) const { return (p - current_c_).squaredNorm() - current_sqr_r_; }

 private:
  static constexpr double kDependentRelative = 1e-20;
  int m_ = 0;
  Vec3d q0_ = Vec3d::Zero(), current_c_ = Vec3d::Zero();
  double current_sqr_r_ = -1.0;
  std::array<Vec3d, 4> v_{}, c_{};
  std::array<std::array<double, 4>, 4> a_{};
  std::array<double, 4> z_{}, sqr_r_{};
};

// Welzl's MB(L[0, end), support) with move-to-front (Gärtner's mtf_mb).
void MoveToFrontBall(std::vector<Vec3d>& pts, size_t end, SupportBall& ball) {
  constexpr double kOutsideRelative = 1e-12;  // boundary points do not count as outside
  if (ball.size() == 4) return;
  for (size_t k = 0; k < end; ++k) {
    const double r2 = std::max(ball.sqr_radius(), 0.0);
    if (!(ball.Excess(pts[k]) > kOutsideRelative * r2)) continue;
    if (!ball.Push(pts[k])) continue;
    MoveToFrontBall(pts, k, ball);
    ball.Pop();
    // Move pts[k] to the front; pts[k + 1 ..] keep their positions.
    std::rotate(pts.begin(), pts.begin() + static_cast<std::ptrdiff_t>(k),
                pts.begin() + static_cast<std::ptrdiff_t>(k) + 1);
  }
}

uint64_t SplitMix64(uint64_t& state) {
  uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// ---- Oracle helpers ----------------------------------------------------------------------------

// Ball through 1..4 points with all on its boundary and centre in their affine hull; false when
// the points are affinely dependent.
bool CircumBall(const Vec3d* p, int k, Vec3d* center) {
  constexpr double kDegenerate = 1e-12;
  if (k == 1) {
    *center = p[0];
    return true;
  }
  if (k == 2) {
    *center = 0.5 * (p[0] + p[1]);
    return (p[1] - p[0]).squaredNorm() > 0.0;
  }
  const Vec3d ab = p[1] - p[0], ac = p[2] - p[0];
  if (k == 3) {
    const Vec3d n = ab.cross(ac);
    const double n2 = n.squaredNorm();
    if (!(n2 > kDegenerate * kDegenerate * ab.squaredNorm() * ac.squaredNorm())) return false;
    *center = p[0] + (ac.squaredNorm() * n.cross(ab) + ab.squaredNorm() * ac.cross(n)) / (2.0 * n2);
    return true;
  }
  const Vec3d ad = p[3] - p[0];
  Eigen::Matrix3d m;
  m.row(0) = ab.transpose();
  m.row(1) = ac.transpose();
  m.row(2) = ad.transpose();
  const double det = m.determinant();
  if (!(std::fabs(det) > kDegenerate * ab.norm() * ac.norm() * ad.norm())) return false;
  const Vec3d rhs(0.5 * ab.squaredNorm(), 0.5 * ac.squaredNorm(), 0.5 * ad.squaredNorm());
  *center = p[0] + m.partialPivLu().solve(rhs);
  return true;
}

// ---- M1-A helpers ------------------------------------------------------------------------------

struct Eval {
  double r = 0.0, mean_f = 0.0, max_f = 0.0;
};

// F at centre c with r(c) = max distance (every point inside).
Eval Evaluate(const Vec3d& c, std::span<const Eigen::Vector3f> points) {
  double r = 0.0, sum = 0.0, dmin = std::numeric_limits<double>::infinity();
  for (const Eigen::Vector3f& p : points) {
    const double d = (p.cast<double>() - c).norm();
    r = std::max(r, d);
    dmin = std::min(dmin, d);
    sum += d;
  }
  const double n = static_cast<double>(points.size());
  return Eval{r, r - sum / n, r - dmin};
}

}  // namespace

float RoundUpRadius(double r) {
  float rf = static_cast<float>(r);
  if (static_cast<double>(rf) < r) rf = std::nextafter(rf, std::numeric_limits<float>::infinity());
  return rf;
}

float HoldingRadius(double max_sq, double pad) { return RoundUpRadius(std::sqrt(max_sq) * (1.0 + pad)); }

float HoldingRadius(std::span<const Eigen::Vector3f> points, const Eigen::Vector3f& center, double pad) {
  const Vec3d c = center.cast<double>();
  double max_sq = 0.0;
  for (const Eigen::Vector3f& p : points) max_sq = std::max(max_sq, (p.cast<double>() - c).squaredNorm());
  return HoldingRadius(max_sq, pad);
}

FitErrorStats FitError(const Ball& ball, std::span<const Eigen::Vector3f> points) {
  FitErrorStats s;
  if (points.empty()) return s;
  const Vec3d c = ball.center.cast<double>();
  const double r = ball.radius;
  double sum = 0.0, mx = 0.0;
  for (const Eigen::Vector3f& p : points) {
    const double f = std::fabs(r - (p.cast<double>() - c).norm());  // F_i = | r - ||c - v_i|| |
    sum += f;
    mx = std::max(mx, f);
  }
  s.mean = static_cast<float>(sum / static_cast<double>(points.size()));
  s.max = static_cast<float>(mx);
  return s;
}

Ball CentroidBall(std::span<const Eigen::Vector3f> points) {
  if (points.empty()) return Ball{};
  Vec3d sum = Vec3d::Zero();
  for (const Eigen::Vector3f& p : points) sum += p.cast<double>();
  return Finalize(sum / static_cast<double>(points.size()), points);  // M1: c = mean, r = max ||c - v_i||
}

Ball MinimumBall(std::span<const Eigen::Vector3f> points) {
  if (points.empty()) return Ball{};
  std::vector<Vec3d> pts(points.size());
  for (size_t i = 0; i < points.size(); ++i) pts[i] = points[i].cast<double>();
  // Deterministic Fisher-Yates shuffle (fixed seed) for Welzl's expected linear time.
  uint64_t state = 0x5EED5EED12345678ull;
  for (size_t i = pts.size(); i > 1; --i) std::swap(pts[i - 1], pts[SplitMix64(state) % i]);

  SupportBall ball;
  Vec3d center = pts.front();
  for (int pass = 0; pass < 8; ++pass) {
    ball.Reset();
    MoveToFrontBall(pts, pts.size(), ball);
    center = ball.center();
    // Pivot check: if rounding left the farthest point noticeably outside, run again with it first.
    size_t far = 0;
    double far2 = -1.0;
    for (size_t i = 0; i < pts.size(); ++i) {
      const double d2 = (pts[i] - center).squaredNorm();
      if (d2 > far2) far2 = d2, far = i;
    }
    if (far2 <= ball.sqr_radius() * (1.0 + 1e-10)) break;
    std::rotate(pts.begin(), pts.begin() + static_cast<std::ptrdiff_t>(far),
                pts.begin() + static_cast<std::ptrdiff_t>(far) + 1);
  }
  return Finalize(center, points);
}

Ball ExhaustiveMinimumBall(std::span<const Eigen::Vector3f> points) {
  if (points.empty()) return Ball{};
  const int n = static_cast<int>(points.size());
  std::vector<Vec3d> pts(points.size());
  for (int i = 0; i < n; ++i) pts[i] = points[i].cast<double>();
  double extent2 = 0.0;
  for (int i = 0; i < n; ++i) extent2 = std::max(extent2, (pts[i] - pts[0]).squaredNorm());
  Vec3d best_c = pts[0];
  double best_r2 = std::numeric_limits<double>::infinity();
  auto consider = [&](const Vec3d* sup, int k) {
    Vec3d c;
    if (!CircumBall(sup, k, &c)) return;
    const double r2 = (sup[0] - c).squaredNorm();
    if (!(r2 < best_r2)) return;
    const double slack = 1e-9 * r2 + 1e-18 * extent2;  // rounding of the circumcentre
    for (const Vec3d& p : pts) {
      if ((p - c).squaredNorm() > r2 + slack) return;
    }
    best_r2 = r2;
    best_c = c;
  };
  Vec3d sup[4];
  for (int a = 0; a < n; ++a) {
    sup[0] = pts[a];
    consider(sup, 1);
    for (int b = a + 1; b < n; ++b) {
      sup[1] = pts[b];
      consider(sup, 2);
      for (int c = b + 1; c < n; ++c) {
        sup[2] = pts[c];
        consider(sup, 3);
        for (int d = c + 1; d < n; ++d) {
          sup[3] = pts[d];
          consider(sup, 4);
        }
      }
    }
  }
  return Finalize(best_c, points);
}

Ball AdjustM1(const Ball& m1, std::span<const Eigen::Vector3f> points, const Eigen::Vector3f& disk_center,
              const Eigen::Vector3f& n0, const Eigen::Vector3f& n1) {
  if (points.empty()) return m1;
  const Ball fallback = ContainsAll(m1, points) ? m1 : Finalize(m1.center.cast<double>(), points);
  const FitErrorStats m1_error = FitError(fallback, points);
  const double max_f_limit = m1_error.max;  // max F of M1: never raised

  const Vec3d g0 = n0.cast<double>(), g1 = n1.cast<double>(), star_c = disk_center.cast<double>();
  Vec3d c = m1.center.cast<double>();
  Eval cur = Evaluate(c, points);  // scaling: r = max distance at c
  const double tiny = 1e-12 * std::max(cur.r, 1e-30);
  for (int round = 0; round < 64; ++round) {
    const Vec3d n = star_c - c;        // N: from the centre of ○ to the disk centre *.c
    const Vec3d n_0 = n.dot(g0) * g0;  // N_0
    const Vec3d n_1 = n.dot(g1) * g1;  // N_1
    const std::array<Vec3d, 3> dirs = {n_0 + n_1, n_0, n_1};
    Vec3d best_c = c;
    Eval best = cur;
    bool found = false;
    for (const Vec3d& d : dirs) {
      if (!(d.squaredNorm() > 0.0)) continue;
      double s = 1.0;
      for (int k = 0; k <= 10; ++k, s *= 0.5) {
        const Vec3d cand = c + s * d;
        const Eval e = Evaluate(cand, points);
        // Allowed: no point leaves the current sphere, max F within M1's, F lowered.
        if (e.r <= cur.r && e.max_f <= max_f_limit && e.mean_f < best.mean_f - tiny) {
          best = e;
          best_c = cand;
          found = true;
        }
      }
    }
    if (!found) break;
    c = best_c;
    cur = best;
  }
  const Ball adjusted = Finalize(c, points);
  const FitErrorStats adjusted_error = FitError(adjusted, points);
  if (adjusted_error.max > m1_error.max || adjusted_error.mean > m1_error.mean || adjusted.radius > fallback.radius) {
    return fallback;
  }
  return adjusted;
}

}  // namespace skinspheres::lib
