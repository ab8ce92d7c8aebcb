// Enclosing spheres for one partition S_k of the contact points of a disk level (paper §4.2-4.4,
// §5 "Sphere Construction" and "Sphere Adjustment"), and the paper's accuracy measure F (§4.4, §6).
//
// Contract (all functions)
//   - Points are float; everything is computed in double and rounded once at the end.
//   - Every returned Ball contains every input point: its radius is the holding radius below (the
//     largest double-precision distance from the float centre to a point, enlarged by
//     kBallRadiusPad and rounded up to float), so ||p - center|| <= radius holds in float and in
//     double.
//   - Deterministic: a pure function of the inputs (MinimumBall shuffles with a fixed seed).
//   - An empty point set gives Ball{0, 0}. Non-finite points are the caller's problem (the result
//     is then unspecified but the functions do not crash or loop).
#pragma once

#include <Eigen/Core>
#include <span>

namespace skinspheres::lib {

// Relative outward enlargement of every returned radius (a few float ulps).
inline constexpr double kBallRadiusPad = 1e-6;

// The smallest float >= r: a radius computed in double, stored in float without losing a point.
float RoundUpRadius(double r);

// The holding radius: the radius at which a sphere holds points whose largest squared distance to
// its (float) centre, computed in double, is max_sq: sqrt(max_sq), enlarged by `pad` (relative),
// rounded up to float. pad = kBallRadiusPad is the rule of every Ball below and of every radius
// the fitter writes; the tightening pass moves its spheres on the unpadded radius (pad = 0) and
// the fitter holds what it keeps again with the pad (fit/sphere_fitter.h).
float HoldingRadius(double max_sq, double pad = kBallRadiusPad);
// The same for `points` around `center`.
float HoldingRadius(std::span<const Eigen::Vector3f> points, const Eigen::Vector3f& center,
                    double pad = kBallRadiusPad);

// A sphere: what every function below returns, and what the fitter's stages pass around.
struct Ball {
  Eigen::Vector3f center = Eigen::Vector3f::Zero();
  float radius = 0.0f;
};

// The paper's F (§4.4): F_i = | r - ||c - v_i|| |, over the points v_i.
struct FitErrorStats {
  float mean = 0.0f;  // F = (1/n) Σ F_i
  float max = 0.0f;   // max_i F_i
};
FitErrorStats FitError(const Ball& ball, std::span<const Eigen::Vector3f> points);

// M1 (§5): centre = mean of the points, radius = largest distance to it.
Ball CentroidBall(std::span<const Eigen::Vector3f> points);

// M2 (§5): the minimum enclosing ball (Welzl 1991), move-to-front variant with Gärtner's
// numerically stable support-set update ("Fast and robust smallest enclosing balls", 1999):
// a support point that is affinely dependent on the current support set (collinear, coplanar or
// duplicate points) is rejected instead of producing an ill-conditioned ball. After the pass the
// farthest point is checked and the pass repeated from it (at most 8 times) in case rounding left
// a point outside. Expected O(n). The radius matches ExhaustiveMinimumBall to ~1e-6 relative.
Ball MinimumBall(std::span<const Eigen::Vector3f> points);

// Oracle for MinimumBall: every ball with 1..4 of the points on its boundary (a point, the
// diametral ball of 2, the circumcircle-ball of 3 non-collinear, the circumsphere of 4
// non-coplanar), the smallest that contains all points. O(n^5): for n <= ~12 only.
Ball ExhaustiveMinimumBall(std::span<const Eigen::Vector3f> points);

// M1-A (§4.4, Sphere Adjustment). The paper: "Let N be the vector that comes from the centre of
// ○_0 and goes to the centre of * [the disk], we could translate ○_0 towards N. It could happen
// that some points lie outside ○_0, so that the translation will not be allowed. Decomposing
// N = N_0 × N_1, we could try to move ○_0 towards N_0, or N_1. As a move is performed, we can try
// with the scaling transformation to reduce the circumference size." The goal is to lower F.
//
// Procedure implemented (deterministic pattern search in the disk plane γ0γ1 = span(n0, n1)):
//   state: centre c (starts at m1.center), radius r(c) = max_i ||c - v_i|| (the "scaling" step:
//   the smallest radius at c keeping every point inside), objective F(c) = mean_i (r(c) - ||c - v_i||).
//   repeat (at most 64 rounds):
//     N = disk_center - c;  N_0 = (N·n0) n0;  N_1 = (N·n1) n1;  directions {N_0 + N_1, N_0, N_1}
//     (N_0 + N_1 is N projected on the disk plane);
//     candidates c' = c + s·d for each direction d and s in {1, 1/2, ..., 1/1024};
//     a candidate is allowed when it would not leave a point outside the current sphere
//     (r(c') <= r(c), so the sphere never grows), when max_i F_i does not exceed that of M1,
//     and when it lowers F; take the allowed candidate with the lowest F (first in the order
//     above on ties); stop when there is none.
// n0, n1 must be orthonormal (the disk's γ0, γ1). `m1` is normally CentroidBall(points).
// Guarantees (checked on the rounded result): every point inside; max F, mean F and the radius
// are never larger than those of m1. If rounding the final centre to float would break one of
// them, m1 itself is returned (re-fitted at its centre if it did not contain every point).
Ball AdjustM1(const Ball& m1, std::span<const Eigen::Vector3f> points, const Eigen::Vector3f& disk_center,
              const Eigen::Vector3f& n0, const Eigen::Vector3f& n1);

}  // namespace skinspheres::lib
