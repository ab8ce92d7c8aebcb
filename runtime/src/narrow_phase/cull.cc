// Per sphere pair and per self-tested sphere (internal.h, frame step 4): the two spheres' boxes, the
// clusters of each that reach into the other sphere, the cluster pairs rule 2 leaves whose boxes
// meet, the triangles whose boxes meet, rules 1 and 3, then the exact test on the whole triangles
// (triangle_contact.h). Every step only drops what cannot meet or what the rules exclude, so nothing
// is lost with exact or fast spheres.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "narrow_phase/internal.h"
#include "simd/float4.h"
#include "skinspheres/runtime/narrow_phase/contact_rules.h"
#include "skinspheres/runtime/narrow_phase/triangle_contact.h"

namespace skinspheres::runtime::narrow_phase {

namespace {

// One point per Float4 (simd/float4.h, as PositionBox): min and max, and p - p, which stays 0 only
// while every coordinate is finite.
bool CornerBox(const Eigen::Vector3f& a, const Eigen::Vector3f& b, const Eigen::Vector3f& d, uint32_t id, Box* box) {
  namespace F = simd::native;
  const F::Float4 pa = F::Load3(a.data()), pb = F::Load3(b.data()), pd = F::Load3(d.data());
  const F::Float4 lo = F::Min(F::Min(pa, pb), pd), hi = F::Max(F::Max(pa, pb), pd);
  float l[4], h[4], z[4];
  F::Store4(l, lo);
  F::Store4(h, hi);
  F::Store4(z, F::Sub(hi, lo));
  for (int k = 0; k < 3; ++k) {
    box->lo[k] = l[k];
    box->hi[k] = h[k];
  }
  box->id = id;
  return std::isfinite(z[0] + z[1] + z[2]);
}

}  // namespace

bool TriangleBox(const Frame& f, uint32_t id, Box* box) {
  if (id < Of(f.data).triangle_count) {  // the usual case: a whole triangle, read in place
    return CornerBox(Vertex(f, id, 0), Vertex(f, id, 1), Vertex(f, id, 2), id, box);
  }
  Eigen::Vector3f c[3];
  ItemCorners(f.set, Of(f.data), f.pos, f.grid_pos, id, c);
  const bool finite = CornerBox(c[0], c[1], c[2], id, box);
  // The whole triangle's own points near this piece lie within the corners' rounding of its box.
  const uint32_t t = ItemTriangle(Of(f.data), id);
  float scale = Of(f.data).rest_size;
  for (int v = 0; v < 3; ++v) scale = std::max(scale, Vertex(f, t, v).cwiseAbs().maxCoeff());
  GrowForGridRounding(box, scale);
  return finite;
}

void GrowForGridRounding(Box* box, float scale) {
  const float grow = scale * kGridRounding;
  for (int k = 0; k < 3; ++k) {
    box->lo[k] -= grow;
    box->hi[k] += grow;
  }
}

bool BoxReachesSphere(const Box& box, const Vec4f& s, float margin) {
  double d2 = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double x = s[k];
    const double e = std::max({double(box.lo[k]) - x, 0.0, x - double(box.hi[k])});
    d2 += e * e;
  }
  const double r = (double(s.w()) + double(margin)) * (1.0 + 1e-9);
  return d2 <= r * r;
}

bool SpheresMeet(const Vec4f& a, const Vec4f& b, float margin) {
  const double dx = double(a.x()) - b.x(), dy = double(a.y()) - b.y(), dz = double(a.z()) - b.z();
  const double reach = (double(a.w()) + double(b.w()) + double(margin)) * (1.0 + 1e-9);
  return dx * dx + dy * dy + dz * dz <= reach * reach;
}

void TestTriangles(const Frame& f, uint32_t t, uint32_t u, Chunk& chunk) {
  if (f.data.ShareVertex(t, u)) return;  // rule 1 (also two pieces of one triangle)
  ++chunk.stats.triangle_tests;
  TriangleContactGeometry g;
  if (!TriangleContactOf(Vertex(f, t, 0), Vertex(f, t, 1), Vertex(f, t, 2), Vertex(f, u, 0), Vertex(f, u, 1),
                         Vertex(f, u, 2), f.margin, &g)) {
    return;
  }
  if (RestNear(f, t, u)) return;  // rule 3
  chunk.hits.push_back(HitOf(t, u, g));
}

void Test(const Frame& f, const Box& a, const Box& b, Chunk& chunk) {
  const NarrowPhaseData::Layout& d = Of(f.data);
  const uint32_t t = ItemTriangle(d, a.id), u = ItemTriangle(d, b.id);
  if (a.id >= d.triangle_count || b.id >= d.triangle_count) {
    // Pieces: their triangles are tested whole, once per run of piece pairs naming them.
    const uint64_t key = (uint64_t{std::min(t, u)} << 32) | std::max(t, u);
    if (key == chunk.last_tested) return;
    chunk.last_tested = key;
  }
  TestTriangles(f, t, u, chunk);
}

bool PositionBox(const SphereSet& set, const NarrowPhaseData& d, const Eigen::Vector3f* pos, uint32_t c, Box* box,
                 Eigen::Vector3f* grid_out) {
  const uint32_t* vertex = Of(d).cluster_vertices.data() + Of(d).cluster_vertex_offsets[c];
  const uint32_t* const end = Of(d).cluster_vertices.data() + Of(d).cluster_vertex_offsets[c + 1];
  // One vertex per Float4 (x, y, z, 0; simd/float4.h: SSE on x86-64, portable elsewhere, the same
  // bits); p - p is 0 exactly when p is finite, so a sum of them stays 0 only if every vertex was.
  // Min / Max return the second operand on ties, so a bound may be -0 where std::min gave +0:
  // equal in every comparison.
  namespace F = simd::native;
  F::Float4 lo = F::Set1(INFINITY), hi = F::Set1(-INFINITY), zero = F::Zero();
  for (; vertex != end; ++vertex) {
    const F::Float4 p = F::Load3(pos[*vertex].data());
    zero = F::Add(zero, F::Sub(p, p));
    lo = F::Min(lo, p);
    hi = F::Max(hi, p);
  }
  // Pieces' corners inside their triangles, computed as TriangleBox computes them (the same bits).
  const uint32_t grid_begin = Of(d).cluster_grid_offsets[c], grid_end = Of(d).cluster_grid_offsets[c + 1];
  float scale = Of(d).rest_size;
  for (uint32_t k = grid_begin; k < grid_end; ++k) {
    const PiecePoint& g = Of(d).cluster_grid[k];
    const uint32_t* v = set.triangle_vertices.data() + 3 * size_t{g.triangle};
    const Eigen::Vector3f& q = grid_out[k] =
        runtime::internal::GridPointInline(pos[v[0]], pos[v[1]], pos[v[2]], g.level, g.i, g.j);
    for (int e = 0; e < 3; ++e) scale = std::max(scale, pos[v[e]].cwiseAbs().maxCoeff());
    const F::Float4 p = F::Load3(q.data());
    zero = F::Add(zero, F::Sub(p, p));
    lo = F::Min(lo, p);
    hi = F::Max(hi, p);
  }
  float l[4], h[4], z[4];
  F::Store4(l, lo);
  F::Store4(h, hi);
  F::Store4(z, zero);
  const bool finite = z[0] == 0.0f && z[1] == 0.0f && z[2] == 0.0f;
  for (int k = 0; k < 3; ++k) {
    box->lo[k] = l[k];
    box->hi[k] = h[k];
  }
  box->id = c;
  if (grid_begin != grid_end) GrowForGridRounding(box, scale);
  return finite;
}

bool RestNear(const Frame& f, uint32_t t, uint32_t u) {
  const NarrowPhaseData::Layout& d = Of(f.data);
  return NearAtRest(d.rest_positions.data(), &f.set.triangle_vertices[3 * size_t{t}],
                    &f.set.triangle_vertices[3 * size_t{u}], d.rest_distance);
}

double MeasuredDeviation(const Frame& f, uint32_t c, const JointMotion& motion) {
  const NarrowPhaseData::Layout& d = Of(f.data);
  const internal::Mat4d& m = motion.h;
  double worst = 0.0;
  auto add = [&](uint32_t v) {
    const Eigen::Vector3d r = d.rest_positions[v].cast<double>(), p = f.pos[v].cast<double>();
    const double x = p.x() - (m(0, 0) * r.x() + m(0, 1) * r.y() + m(0, 2) * r.z() + m(0, 3));
    const double y = p.y() - (m(1, 0) * r.x() + m(1, 1) * r.y() + m(1, 2) * r.z() + m(1, 3));
    const double z = p.z() - (m(2, 0) * r.x() + m(2, 1) * r.y() + m(2, 2) * r.z() + m(2, 3));
    const double e = x * x + y * y + z * z;
    worst = e > worst || e != e ? e : worst;  // a NaN stays (and fails every bound)
  };
  for (uint32_t k = d.cluster_vertex_offsets[c]; k < d.cluster_vertex_offsets[c + 1]; ++k) add(d.cluster_vertices[k]);
  for (uint32_t k = d.cluster_far_offsets[c]; k < d.cluster_far_offsets[c + 1]; ++k) add(d.cluster_far_vertices[k]);
  return std::sqrt(worst);
}

namespace {

// |(H_j - H_a) m| + |L_j - L_a|_F r: how far points of the ball (m, r) carried by j's motion lie from
// the same points carried by a's.
double Apart(const internal::Mat4d& hj, const internal::Mat4d& ha, const std::array<double, 4>& ball) {
  const Eigen::Matrix<double, 3, 4> diff = hj.topRows<3>() - ha.topRows<3>();
  const Eigen::Vector3d m(ball[0], ball[1], ball[2]);
  return (diff.leftCols<3>() * m + diff.col(3)).norm() + diff.leftCols<3>().norm() * ball[3];
}

}  // namespace

void WeightDeviations(const Frame& f, uint32_t s, double* patch_deviation) {
  const NarrowPhaseData::Layout& d = Of(f.data);
  for (uint32_t p = d.patch_offsets[s]; p < d.patch_offsets[s + 1]; ++p) {
    if (!d.patch_still_ok[p]) {
      patch_deviation[p] = INFINITY;
      continue;
    }
    const internal::Mat4d& ha = f.joint_motion[d.patch_joint[p]].h;
    double largest = 0.0, weighted = 0.0;
    for (uint32_t e = d.patch_copy_offsets[p]; e < d.patch_copy_offsets[p + 1]; ++e) {
      const uint16_t j = d.patch_copy_joint[e];
      if (j == d.patch_joint[p]) continue;  // carried by A itself: no deviation
      const double apart = Apart(f.joint_motion[j].h, ha, d.patch_copy_ball[e]);
      largest = std::max(largest, apart);
      weighted += d.patch_copy_reach[e] * apart;
    }
    const double e = std::min(largest, weighted);
    patch_deviation[p] = e == e ? e : INFINITY;
  }
}

namespace {

// Still's test once the patches' deviations sum to `deviations`.
bool StillWith(const Frame& f, uint32_t a, uint32_t b, double deviations) {
  const NarrowPhaseData::Layout& d = Of(f.data);
  if (f.joint_motion == nullptr || !d.patch_still_ok[a] || !d.patch_still_ok[b]) return false;
  const JointMotion& ma = f.joint_motion[d.patch_joint[a]];
  const double e = deviations + Apart(f.joint_motion[d.patch_joint[b]].h, ma.h, d.patch_rest_ball[b]);
  const double moved = ma.inv_norm * e;  // in a's frame, both patches together
  if (!(moved < INFINITY)) return false;
  const double left = double(d.rest_distance) * (1.0 - 1e-6) - moved - f.motion_slack;
  return f.margin > 0.0f ? left > double(f.margin) * ma.inv_norm : left > 0.0;
}

}  // namespace

bool Still(const Frame& f, uint32_t a, uint32_t b) {
  return StillWith(f, a, b, f.patch_deviation[a] + f.patch_deviation[b]);
}

bool CouldBeStill(const Frame& f, uint32_t a, uint32_t b) { return StillWith(f, a, b, 0.0); }

// Whether rule 2 leaves the triangles of patches a and b (their joints more than the hops apart).
bool JointsApart(const Frame& f, uint32_t a, uint32_t b) {
  const NarrowPhaseData::Layout& d = Of(f.data);
  return d.rules == ContactRules::kSpherePairs || !d.near(d.patch_joint[a], d.patch_joint[b]);
}

// The clusters of sphere s's patches (in order) whose box reaches into sphere `other`: out[] the
// clusters, first[p - patch_offsets[s]] where patch p's begin (first has a patch count + 1 entries).
size_t ReachingByPatch(const Frame& f, uint32_t s, const Vec4f& other, uint32_t* out, uint32_t* first) {
  const NarrowPhaseData::Layout& d = Of(f.data);
  size_t n = 0;
  for (uint32_t p = d.patch_offsets[s]; p < d.patch_offsets[s + 1]; ++p) {
    first[p - d.patch_offsets[s]] = uint32_t(n);
    if (!BoxReachesSphere(f.patch_box[p], other, f.margin)) continue;
    for (uint32_t c = d.patch_cluster_offsets[p]; c < d.patch_cluster_offsets[p + 1]; ++c) {
      if (BoxReachesSphere(f.cluster_box[c], other, f.margin)) out[n++] = c;
    }
  }
  first[d.patch_offsets[s + 1] - d.patch_offsets[s]] = uint32_t(n);
  return n;
}

// Whether patches a and b are to be searched: rule 2 leaves them, their boxes meet, and they are not
// Still; counted in chunk.stats.patch_pairs.
bool PatchesMeet(const Frame& f, uint32_t a, uint32_t b, Chunk& chunk) {
  if (!JointsApart(f, a, b)) return false;
  ++chunk.stats.patch_pairs;
  if (!BoxesMeet(f.patch_box[a], f.patch_box[b], Slack(f.margin))) return false;
  if (Still(f, a, b)) {
    ++chunk.stats.still_patch_pairs;
    return false;
  }
  return true;
}

void PlaneOf(const Frame& f, uint32_t t, Plane* out) {
  const Eigen::Vector3d p = Vertex(f, t, 0).cast<double>();
  const Eigen::Vector3d n = (Vertex(f, t, 1).cast<double>() - p).cross(Vertex(f, t, 2).cast<double>() - p);
  for (int k = 0; k < 3; ++k) {
    out->n[k] = n[k];
    out->p[k] = p[k];
  }
  out->norm = n.norm();
}

bool Beyond(const Frame& f, const Plane& plane, uint32_t u) {
  bool above = true, below = true;
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3f& v = Vertex(f, u, k);
    const double x = double(v.x()) - plane.p[0], y = double(v.y()) - plane.p[1], z = double(v.z()) - plane.p[2];
    const double s = plane.n[0] * x + plane.n[1] * y + plane.n[2] * z;
    // Certain: beyond the margin and beyond the arithmetic's error (far under 1e-12 of |n| |v - p|).
    const double reach =
        plane.norm * (double(f.margin) * (1.0 + 1e-9) + 1e-12 * (std::fabs(x) + std::fabs(y) + std::fabs(z)));
    above &= s > reach;
    below &= s < -reach;
  }
  return above || below;
}

bool TestClusters(const Frame& f, uint32_t ca, uint32_t cb, Chunk& chunk) {
  const NarrowPhaseData& d = f.data;
  const float slack = Slack(f.margin);
  bool ok = true;
  auto gather = [&](uint32_t c, const Box& other, Box* list, Plane* planes) {
    size_t n = 0;
    for (uint32_t k = Of(d).cluster_triangle_offsets[c]; k < Of(d).cluster_triangle_offsets[c + 1]; ++k) {
      ok &= TriangleBox(f, Of(d).cluster_triangles[k], &list[n]);
      if (!BoxesMeet(list[n], other, slack)) continue;
      PlaneOf(f, ItemTriangle(Of(d), list[n].id), &planes[n]);
      ++n;
    }
    return n;
  };
  const size_t na = gather(ca, f.cluster_box[cb], chunk.a.data(), chunk.plane_a.data());
  if (na == 0) return ok;
  const size_t nb = gather(cb, f.cluster_box[ca], chunk.b.data(), chunk.plane_b.data());
  chunk.stats.culled_triangles += na + nb;
  for (size_t x = 0; x < na; ++x) {
    for (size_t y = 0; y < nb; ++y) {
      const Box &a = chunk.a[x], &b = chunk.b[y];
      ++chunk.stats.box_tests;
      if (!BoxesMeet(a, b, slack)) continue;
      // Either whole triangle wholly beyond the other's plane (and the margin): no contact.
      if (Beyond(f, chunk.plane_a[x], ItemTriangle(Of(d), b.id)) ||
          Beyond(f, chunk.plane_b[y], ItemTriangle(Of(d), a.id))) {
        continue;
      }
      Test(f, a, b, chunk);
    }
  }
  return ok;
}

// Patches a and b that meet: of the given clusters of each, those whose box meets the other patch's,
// then the pairs of those whose boxes meet, and their triangles.
bool TestPatchPair(const Frame& f, uint32_t a, uint32_t b, std::span<const uint32_t> ca, std::span<const uint32_t> cb,
                   Chunk& chunk) {
  const float slack = Slack(f.margin);
  uint32_t* xa = chunk.xa.data();
  uint32_t* xb = chunk.xb.data();
  size_t na = 0, nb = 0;
  for (uint32_t c : ca) {
    xa[na] = c;
    na += BoxesMeet(f.cluster_box[c], f.patch_box[b], slack);
  }
  if (na == 0) return true;
  for (uint32_t c : cb) {
    xb[nb] = c;
    nb += BoxesMeet(f.cluster_box[c], f.patch_box[a], slack);
  }
  bool ok = true;
  for (size_t x = 0; x < na; ++x) {
    for (size_t y = 0; y < nb; ++y) {
      ++chunk.stats.cluster_pairs;
      if (BoxesMeet(f.cluster_box[xa[x]], f.cluster_box[xb[y]], slack)) ok &= TestClusters(f, xa[x], xb[y], chunk);
    }
  }
  return ok;
}

bool TestPair(const Frame& f, uint32_t i, uint32_t j, const Vec4f& si, const Vec4f& sj, Chunk& chunk) {
  ++chunk.stats.sphere_pairs;
  // The spheres' own boxes (unions of their clusters' boxes, often much tighter than fast spheres)
  // first.
  if (!BoxesMeet(f.sphere_box[i], f.sphere_box[j], Slack(f.margin))) return true;
  const NarrowPhaseData::Layout& d = Of(f.data);
  uint32_t* ka = chunk.ka.data();
  uint32_t* kb = chunk.kb.data();
  uint32_t* fa = chunk.pa.data();
  uint32_t* fb = chunk.pb.data();
  if (ReachingByPatch(f, i, sj, ka, fa) == 0 || ReachingByPatch(f, j, si, kb, fb) == 0) return true;
  bool ok = true;
  const uint32_t pi = d.patch_offsets[i], pj = d.patch_offsets[j];
  for (uint32_t a = pi; a < d.patch_offsets[i + 1]; ++a) {
    if (fa[a - pi] == fa[a - pi + 1]) continue;
    for (uint32_t b = pj; b < d.patch_offsets[j + 1]; ++b) {
      if (fb[b - pj] == fb[b - pj + 1] || !PatchesMeet(f, a, b, chunk)) continue;
      ok &=
          TestPatchPair(f, a, b, {ka + fa[a - pi], ka + fa[a - pi + 1]}, {kb + fb[b - pj], kb + fb[b - pj + 1]}, chunk);
    }
  }
  return ok;
}

bool TestSelf(const Frame& f, uint32_t s, Chunk& chunk) {
  const NarrowPhaseData::Layout& d = Of(f.data);
  const std::vector<uint32_t>& all = d.cluster_ids;
  bool ok = true;
  for (uint32_t a = d.patch_offsets[s]; a < d.patch_offsets[s + 1]; ++a) {
    for (uint32_t b = a + 1; b < d.patch_offsets[s + 1]; ++b) {
      if (!PatchesMeet(f, a, b, chunk)) continue;
      ok &=
          TestPatchPair(f, a, b, {all.data() + d.patch_cluster_offsets[a], all.data() + d.patch_cluster_offsets[a + 1]},
                        {all.data() + d.patch_cluster_offsets[b], all.data() + d.patch_cluster_offsets[b + 1]}, chunk);
    }
  }
  return ok;
}

}  // namespace skinspheres::runtime::narrow_phase
