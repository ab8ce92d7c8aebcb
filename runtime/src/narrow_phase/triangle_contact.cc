// Triangle-triangle intersection (exact signs, Guigue-Devillers) and closest points (double).
// See triangle_contact.h for what the answers mean at the boundaries.
#include "skinspheres/runtime/narrow_phase/triangle_contact.h"

#include <algorithm>
#include <cmath>

#include "narrow_phase/exact_predicates.h"

namespace skinspheres::runtime {
namespace {

using Eigen::Vector3d;
using Eigen::Vector3f;
using exact::P3;

P3 ToP3(const Vector3f& v) { return {double(v.x()), double(v.y()), double(v.z())}; }
Vector3d ToD(const P3& p) { return {p.x, p.y, p.z}; }

bool Degenerate(const P3& a, const P3& b, const P3& c) {
  // (b - a) x (c - a) is zero exactly when its three components are: the 2D orientations of the
  // yz, zx and xy projections.
  return exact::Orient2d(a.y, a.z, b.y, b.z, c.y, c.z) == 0 && exact::Orient2d(a.z, a.x, b.z, b.x, c.z, c.x) == 0 &&
         exact::Orient2d(a.x, a.y, b.x, b.y, c.x, c.y) == 0;
}

// ---------------------------------------------------------------- coplanar triangles (2D, exact)

struct P2 {
  double x, y;
};

int O2(const P2& a, const P2& b, const P2& c) { return exact::Orient2d(a.x, a.y, b.x, b.y, c.x, c.y); }

// r is collinear with p, q: is it on the closed segment? (coordinates compared exactly)
bool OnSegment(const P2& p, const P2& q, const P2& r) {
  return std::min(p.x, q.x) <= r.x && r.x <= std::max(p.x, q.x) && std::min(p.y, q.y) <= r.y &&
         r.y <= std::max(p.y, q.y);
}

bool SegmentsMeet(const P2& p1, const P2& q1, const P2& p2, const P2& q2) {
  const int o1 = O2(p1, q1, p2), o2 = O2(p1, q1, q2), o3 = O2(p2, q2, p1), o4 = O2(p2, q2, q1);
  if (o1 * o2 < 0 && o3 * o4 < 0) return true;
  return (o1 == 0 && OnSegment(p1, q1, p2)) || (o2 == 0 && OnSegment(p1, q1, q2)) ||
         (o3 == 0 && OnSegment(p2, q2, p1)) || (o4 == 0 && OnSegment(p2, q2, q1));
}

// p inside or on the counter-clockwise triangle t.
bool InTriangle(const P2& p, const P2 t[3]) {
  return O2(t[0], t[1], p) >= 0 && O2(t[1], t[2], p) >= 0 && O2(t[2], t[0], p) >= 0;
}

// The projection dropping axis k (the other two in cyclic order).
P2 Project(const P3& p, int k) {
  switch (k) {
    case 0: return {p.y, p.z};
    case 1: return {p.z, p.x};
    default: return {p.x, p.y};
  }
}

// Axis of the largest component of a's normal (computed in double: any axis whose exact component
// is non-zero gives a faithful projection, and the largest computed one is far from zero).
int DominantAxis(const P3& a0, const P3& a1, const P3& a2) {
  const Vector3d n = (ToD(a1) - ToD(a0)).cross(ToD(a2) - ToD(a0)).cwiseAbs();
  return n.x() >= n.y() ? (n.x() >= n.z() ? 0 : 2) : (n.y() >= n.z() ? 1 : 2);
}

// Closed overlap of two coplanar, non-degenerate triangles.
bool CoplanarOverlap(const P3 a[3], const P3 b[3]) {
  const int k = DominantAxis(a[0], a[1], a[2]);
  P2 pa[3], pb[3];
  for (int v = 0; v < 3; ++v) {
    pa[v] = Project(a[v], k);
    pb[v] = Project(b[v], k);
  }
  if (O2(pa[0], pa[1], pa[2]) < 0) std::swap(pa[1], pa[2]);
  if (O2(pb[0], pb[1], pb[2]) < 0) std::swap(pb[1], pb[2]);
  for (int v = 0; v < 3; ++v) {
    if (InTriangle(pa[v], pb) || InTriangle(pb[v], pa)) return true;
  }
  for (int e = 0; e < 3; ++e) {
    for (int f = 0; f < 3; ++f) {
      if (SegmentsMeet(pa[e], pa[(e + 1) % 3], pb[f], pb[(f + 1) % 3])) return true;
    }
  }
  return false;
}

// ---------------------------------------------------------------- Guigue-Devillers (exact signs)

int O3(const P3& a, const P3& b, const P3& c, const P3& d) { return exact::Orient3d(a, b, c, d); }

// Both triangles straddle or touch the other's plane, in canonical form: p1 alone on its side of
// plane 2 and p2 alone on its side of plane 1. They meet when the intervals they cut on the
// planes' common line overlap, which two orientations decide.
bool CheckMinMax(const P3& p1, const P3& q1, const P3& r1, const P3& p2, const P3& q2, const P3& r2) {
  if (O3(q1, p2, p1, q2) > 0) return false;
  if (O3(p1, p2, r1, r2) > 0) return false;
  return true;
}

// Permutes triangle 2 into canonical form (dp2, dq2, dr2: its vertices' signs w.r.t. plane 1).
// 'coplanar' is set when every sign is zero (handled by the caller). Ten parameters: the signature
// of Guigue and Devillers' published routine, kept so the code can be checked against theirs.
// NOLINTNEXTLINE(readability-function-size)
bool TriTri3d(const P3& p1, const P3& q1, const P3& r1, const P3& p2, const P3& q2, const P3& r2, int dp2, int dq2,
              int dr2, bool* coplanar) {
  if (dp2 > 0) {
    if (dq2 > 0) return CheckMinMax(p1, r1, q1, r2, p2, q2);
    if (dr2 > 0) return CheckMinMax(p1, r1, q1, q2, r2, p2);
    return CheckMinMax(p1, q1, r1, p2, q2, r2);
  }
  if (dp2 < 0) {
    if (dq2 < 0) return CheckMinMax(p1, q1, r1, r2, p2, q2);
    if (dr2 < 0) return CheckMinMax(p1, q1, r1, q2, r2, p2);
    return CheckMinMax(p1, r1, q1, p2, q2, r2);
  }
  if (dq2 < 0) {
    if (dr2 >= 0) return CheckMinMax(p1, r1, q1, q2, r2, p2);
    return CheckMinMax(p1, q1, r1, p2, q2, r2);
  }
  if (dq2 > 0) {
    if (dr2 > 0) return CheckMinMax(p1, r1, q1, p2, q2, r2);
    return CheckMinMax(p1, q1, r1, q2, r2, p2);
  }
  if (dr2 > 0) return CheckMinMax(p1, q1, r1, r2, p2, q2);
  if (dr2 < 0) return CheckMinMax(p1, r1, q1, r2, p2, q2);
  *coplanar = true;
  return false;
}

enum class Overlap { kNone, kCrossing, kCoplanar };

// The exact test on non-degenerate, finite triangles.
Overlap Classify(const P3 a[3], const P3 b[3]) {
  const P3 &p1 = a[0], &q1 = a[1], &r1 = a[2], &p2 = b[0], &q2 = b[1], &r2 = b[2];
  const int dp1 = O3(p2, q2, r2, p1), dq1 = O3(p2, q2, r2, q1), dr1 = O3(p2, q2, r2, r1);
  if (dp1 * dq1 > 0 && dp1 * dr1 > 0) return Overlap::kNone;
  const int dp2 = O3(p1, q1, r1, p2), dq2 = O3(p1, q1, r1, q2), dr2 = O3(p1, q1, r1, r2);
  if (dp2 * dq2 > 0 && dp2 * dr2 > 0) return Overlap::kNone;
  bool coplanar = false;
  bool meet;
  if (dp1 > 0) {
    if (dq1 > 0)
      meet = TriTri3d(r1, p1, q1, p2, r2, q2, dp2, dr2, dq2, &coplanar);
    else if (dr1 > 0)
      meet = TriTri3d(q1, r1, p1, p2, r2, q2, dp2, dr2, dq2, &coplanar);
    else
      meet = TriTri3d(p1, q1, r1, p2, q2, r2, dp2, dq2, dr2, &coplanar);
  } else if (dp1 < 0) {
    if (dq1 < 0)
      meet = TriTri3d(r1, p1, q1, p2, q2, r2, dp2, dq2, dr2, &coplanar);
    else if (dr1 < 0)
      meet = TriTri3d(q1, r1, p1, p2, q2, r2, dp2, dq2, dr2, &coplanar);
    else
      meet = TriTri3d(p1, q1, r1, p2, r2, q2, dp2, dr2, dq2, &coplanar);
  } else if (dq1 < 0) {
    if (dr1 >= 0)
      meet = TriTri3d(q1, r1, p1, p2, r2, q2, dp2, dr2, dq2, &coplanar);
    else
      meet = TriTri3d(p1, q1, r1, p2, q2, r2, dp2, dq2, dr2, &coplanar);
  } else if (dq1 > 0) {
    if (dr1 > 0)
      meet = TriTri3d(p1, q1, r1, p2, r2, q2, dp2, dr2, dq2, &coplanar);
    else
      meet = TriTri3d(q1, r1, p1, p2, q2, r2, dp2, dq2, dr2, &coplanar);
  } else if (dr1 > 0) {
    meet = TriTri3d(r1, p1, q1, p2, q2, r2, dp2, dq2, dr2, &coplanar);
  } else if (dr1 < 0) {
    meet = TriTri3d(r1, p1, q1, p2, r2, q2, dp2, dr2, dq2, &coplanar);
  } else {
    coplanar = true;
    meet = false;
  }
  if (coplanar) return CoplanarOverlap(a, b) ? Overlap::kCoplanar : Overlap::kNone;
  return meet ? Overlap::kCrossing : Overlap::kNone;
}

bool Finite(const Vector3f& v) { return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z()); }

// Converts and checks both triangles; false when either is degenerate or not finite.
bool Prepare(const Vector3f& a0, const Vector3f& a1, const Vector3f& a2, const Vector3f& b0, const Vector3f& b1,
             const Vector3f& b2, P3 a[3], P3 b[3]) {
  if (!Finite(a0) || !Finite(a1) || !Finite(a2) || !Finite(b0) || !Finite(b1) || !Finite(b2)) return false;
  a[0] = ToP3(a0), a[1] = ToP3(a1), a[2] = ToP3(a2);
  b[0] = ToP3(b0), b[1] = ToP3(b1), b[2] = ToP3(b2);
  return !Degenerate(a[0], a[1], a[2]) && !Degenerate(b[0], b[1], b[2]);
}

// ---------------------------------------------------------------- points (double)

// Where triangle t meets the plane of s (signs: t's vertices against s's plane, exact; d: the
// same as doubles, for interpolation). Writes up to 2 points, returns how many.
int PlaneCut(const Vector3d t[3], const int sign[3], const double d[3], Vector3d out[2]) {
  int n = 0;
  for (int k = 0; k < 3 && n < 2; ++k) {
    if (sign[k] == 0) out[n++] = t[k];
  }
  for (int k = 0; k < 3 && n < 2; ++k) {
    const int l = (k + 1) % 3;
    if (sign[k] * sign[l] < 0) {
      const double denom = d[k] - d[l];
      const double s = denom != 0.0 ? std::clamp(d[k] / denom, 0.0, 1.0) : 0.5;
      out[n++] = t[k] + s * (t[l] - t[k]);
    }
  }
  if (n == 1) out[n++] = out[0];
  return n;
}

// The intersection segment of two crossing (not coplanar) triangles.
void CrossingSegment(const P3 pa[3], const P3 pb[3], Vector3d* e0, Vector3d* e1) {
  const Vector3d a[3] = {ToD(pa[0]), ToD(pa[1]), ToD(pa[2])}, b[3] = {ToD(pb[0]), ToD(pb[1]), ToD(pb[2])};
  const Vector3d na = (a[1] - a[0]).cross(a[2] - a[0]), nb = (b[1] - b[0]).cross(b[2] - b[0]);
  int sa[3], sb[3];
  double da[3], db[3];
  for (int k = 0; k < 3; ++k) {
    sa[k] = O3(pb[0], pb[1], pb[2], pa[k]);
    sb[k] = O3(pa[0], pa[1], pa[2], pb[k]);
    da[k] = (a[k] - b[0]).dot(nb);
    db[k] = (b[k] - a[0]).dot(na);
  }
  Vector3d ca[2], cb[2];
  PlaneCut(a, sa, da, ca);
  PlaneCut(b, sb, db, cb);
  const Vector3d dir = na.cross(nb);
  double ta[2] = {dir.dot(ca[0]), dir.dot(ca[1])}, tb[2] = {dir.dot(cb[0]), dir.dot(cb[1])};
  if (ta[0] > ta[1]) std::swap(ta[0], ta[1]), std::swap(ca[0], ca[1]);
  if (tb[0] > tb[1]) std::swap(tb[0], tb[1]), std::swap(cb[0], cb[1]);
  const Vector3d lo = ta[0] >= tb[0] ? ca[0] : cb[0];
  const Vector3d hi = ta[1] <= tb[1] ? ca[1] : cb[1];
  if (std::max(ta[0], tb[0]) <= std::min(ta[1], tb[1])) {
    *e0 = lo;
    *e1 = hi;
  } else {  // rounding on a (nearly) single-point contact: the middle of the two ends
    *e0 = *e1 = 0.5 * (lo + hi);
  }
}

// Centroid of the corners of the overlap of two coplanar triangles (a clipped by b's edges).
Vector3d CoplanarCentre(const P3 pa[3], const P3 pb[3]) {
  const Vector3d b[3] = {ToD(pb[0]), ToD(pb[1]), ToD(pb[2])};
  const Vector3d n = (b[1] - b[0]).cross(b[2] - b[0]);
  Vector3d poly[9], next[9];
  int count = 3;
  for (int k = 0; k < 3; ++k) poly[k] = ToD(pa[k]);
  for (int e = 0; e < 3 && count > 0; ++e) {
    const Vector3d& p = b[e];
    const Vector3d inward = n.cross(b[(e + 1) % 3] - p);  // points to the triangle's side of edge e
    int m = 0;
    for (int k = 0; k < count; ++k) {
      const Vector3d& s = poly[k];
      const Vector3d& t = poly[(k + 1) % count];
      const double ds = inward.dot(s - p), dt = inward.dot(t - p);
      if (ds >= 0.0 && m < 9) next[m++] = s;
      if (((ds >= 0.0) != (dt >= 0.0)) && m < 9) next[m++] = s + (ds / (ds - dt)) * (t - s);
    }
    count = m;
    for (int k = 0; k < m; ++k) poly[k] = next[k];
  }
  if (count == 0) {  // rounding on a touching contact: between the two centroids
    Vector3d c = Vector3d::Zero();
    for (int k = 0; k < 3; ++k) c += ToD(pa[k]) + b[k];
    return c / 6.0;
  }
  Vector3d c = Vector3d::Zero();
  for (int k = 0; k < count; ++k) c += poly[k];
  return c / double(count);
}

// Closest points of segments [p1, q1] and [p2, q2] (Ericson 5.1.9, with a relative parallel test).
void ClosestOnSegments(const Vector3d& p1, const Vector3d& q1, const Vector3d& p2, const Vector3d& q2, Vector3d* c1,
                       Vector3d* c2) {
  const Vector3d d1 = q1 - p1, d2 = q2 - p2, r = p1 - p2;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  double s = 0.0, t = 0.0;
  if (a <= 0.0 && e <= 0.0) {
  } else if (a <= 0.0) {
    t = std::clamp(f / e, 0.0, 1.0);
  } else {
    const double c = d1.dot(r);
    if (e <= 0.0) {
      s = std::clamp(-c / a, 0.0, 1.0);
    } else {
      const double b = d1.dot(d2);
      const double denom = a * e - b * b;
      s = denom > 1e-14 * a * e ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
      t = (b * s + f) / e;
      if (t < 0.0) {
        t = 0.0;
        s = std::clamp(-c / a, 0.0, 1.0);
      } else if (t > 1.0) {
        t = 1.0;
        s = std::clamp((b - c) / a, 0.0, 1.0);
      }
    }
  }
  *c1 = p1 + s * d1;
  *c2 = p2 + t * d2;
}

double DistanceD(const Vector3d a[3], const Vector3d b[3], Vector3d* on_a, Vector3d* on_b) {
  double best = INFINITY;
  auto consider = [&](const Vector3d& x, const Vector3d& y) {
    const double d2 = (x - y).squaredNorm();
    if (d2 < best) {
      best = d2;
      *on_a = x;
      *on_b = y;
    }
  };
  for (int k = 0; k < 3; ++k) {
    consider(a[k], ClosestPointOnTriangle(a[k], b[0], b[1], b[2]));
    consider(ClosestPointOnTriangle(b[k], a[0], a[1], a[2]), b[k]);
  }
  for (int k = 0; k < 3; ++k) {
    for (int l = 0; l < 3; ++l) {
      Vector3d x, y;
      ClosestOnSegments(a[k], a[(k + 1) % 3], b[l], b[(l + 1) % 3], &x, &y);
      consider(x, y);
    }
  }
  return std::sqrt(best);
}

}  // namespace

// Ericson, Real-Time Collision Detection, 5.1.5 (Voronoi regions of the vertices, edges, face).
Eigen::Vector3d ClosestPointOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                       const Eigen::Vector3d& c) {
  const Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) return a;
  const Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) return a + (d1 / (d1 - d3)) * ab;
  const Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) return a + (d2 / (d2 - d6)) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

bool TriangleIsDegenerate(const Vector3f& a0, const Vector3f& a1, const Vector3f& a2) {
  if (!Finite(a0) || !Finite(a1) || !Finite(a2)) return true;
  return Degenerate(ToP3(a0), ToP3(a1), ToP3(a2));
}

bool TrianglesIntersect(const Vector3f& a0, const Vector3f& a1, const Vector3f& a2, const Vector3f& b0,
                        const Vector3f& b1, const Vector3f& b2) {
  P3 a[3], b[3];
  if (!Prepare(a0, a1, a2, b0, b1, b2, a, b)) return false;
  return Classify(a, b) != Overlap::kNone;
}

bool TriangleContactOf(const Vector3f& a0, const Vector3f& a1, const Vector3f& a2, const Vector3f& b0,
                       const Vector3f& b1, const Vector3f& b2, float margin, TriangleContactGeometry* out) {
  P3 a[3], b[3];
  if (!Prepare(a0, a1, a2, b0, b1, b2, a, b)) return false;
  const Overlap overlap = Classify(a, b);
  if (overlap != Overlap::kNone) {
    out->intersecting = true;
    out->distance = 0.0f;
    Vector3d e0, e1;
    if (overlap == Overlap::kCrossing) {
      CrossingSegment(a, b, &e0, &e1);
    } else {
      e0 = e1 = CoplanarCentre(a, b);
    }
    out->on_a = e0.cast<float>();
    out->on_b = e1.cast<float>();
    return true;
  }
  if (!(margin > 0.0f)) return false;
  const Vector3d da[3] = {ToD(a[0]), ToD(a[1]), ToD(a[2])}, db[3] = {ToD(b[0]), ToD(b[1]), ToD(b[2])};
  Vector3d pa, pb;
  const double d = DistanceD(da, db, &pa, &pb);
  if (!(d < double(margin))) return false;
  out->intersecting = false;
  out->distance = float(d);
  out->on_a = pa.cast<float>();
  out->on_b = pb.cast<float>();
  return true;
}

float TriangleDistance(const Vector3f& a0, const Vector3f& a1, const Vector3f& a2, const Vector3f& b0,
                       const Vector3f& b1, const Vector3f& b2, Vector3f* on_a, Vector3f* on_b) {
  const Vector3d da[3] = {a0.cast<double>(), a1.cast<double>(), a2.cast<double>()};
  const Vector3d db[3] = {b0.cast<double>(), b1.cast<double>(), b2.cast<double>()};
  Vector3d pa, pb;
  const double d = DistanceD(da, db, &pa, &pb);
  if (on_a) *on_a = pa.cast<float>();
  if (on_b) *on_b = pb.cast<float>();
  return float(d);
}

}  // namespace skinspheres::runtime
