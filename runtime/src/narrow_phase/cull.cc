// Per sphere pair (internal.h, frame step 4): the two spheres' boxes, the clusters of each that
// reach into the other sphere, the cluster pairs whose boxes meet, the triangles whose boxes meet,
// the exclusion rules, then the exact triangle test (triangle_contact.h). Every step only drops
// what cannot meet, so nothing is lost with exact or fast spheres.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "narrow_phase/internal.h"
#include "simd/float4.h"
#include "skinspheres/runtime/narrow_phase/triangle_contact.h"

namespace skinspheres::runtime::narrow_phase {

namespace {

bool CornerBox(const Eigen::Vector3f& a, const Eigen::Vector3f& b, const Eigen::Vector3f& d, uint32_t id, Box* box) {
  for (int k = 0; k < 3; ++k) {
    box->lo[k] = std::min({a[k], b[k], d[k]});
    box->hi[k] = std::max({a[k], b[k], d[k]});
  }
  box->id = id;
  return std::isfinite(box->lo[0] + box->lo[1] + box->lo[2] + box->hi[0] + box->hi[1] + box->hi[2]);
}

}  // namespace

bool TriangleBox(const Frame& f, uint32_t id, Box* box) {
  if (id < Of(f.data).triangle_count) {  // the usual case: a whole triangle, read in place
    return CornerBox(Vertex(f, id, 0), Vertex(f, id, 1), Vertex(f, id, 2), id, box);
  }
  Eigen::Vector3f c[3];
  ItemCorners(f.set, Of(f.data), f.pos, f.grid_pos, id, c);
  return CornerBox(c[0], c[1], c[2], id, box);
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

bool BoxesMeet(const Box& a, const Box& b, float slack) {
  return a.lo[0] - b.hi[0] <= slack && b.lo[0] - a.hi[0] <= slack && a.lo[1] - b.hi[1] <= slack &&
         b.lo[1] - a.hi[1] <= slack && a.lo[2] - b.hi[2] <= slack && b.lo[2] - a.hi[2] <= slack;
}

void Test(const Frame& f, uint32_t i, uint32_t j, const Box& a, const Box& b, Chunk& chunk) {
  ++chunk.stats.box_tests;
  if (!BoxesMeet(a, b, Slack(f.margin))) return;
  const NarrowPhaseData::Layout& d = Of(f.data);
  const bool whole = a.id < d.triangle_count && b.id < d.triangle_count;
  const uint32_t t = whole ? a.id : ItemTriangle(d, a.id), u = whole ? b.id : ItemTriangle(d, b.id);
  if (f.data.ShareVertex(t, u)) return;  // also two pieces of one triangle
  ++chunk.stats.triangle_tests;
  TriangleContactGeometry g;
  if (whole) {  // the usual case: the triangles' vertices read in place
    if (!TriangleContactOf(Vertex(f, t, 0), Vertex(f, t, 1), Vertex(f, t, 2), Vertex(f, u, 0), Vertex(f, u, 1),
                           Vertex(f, u, 2), f.margin, &g)) {
      return;
    }
  } else {
    Eigen::Vector3f p[3], q[3];
    ItemCorners(f.set, d, f.pos, f.grid_pos, a.id, p);
    ItemCorners(f.set, d, f.pos, f.grid_pos, b.id, q);
    if (!TriangleContactOf(p[0], p[1], p[2], q[0], q[1], q[2], f.margin, &g)) return;
  }
  if (f.rest_rule && f.data.RestExcluded(t, u)) return;
  if (!whole) {
    // The whole triangles hold the pieces, so they meet too; their geometry is what is reported
    // (kept from the pieces in the rare case float rounding puts the wholes a hair beyond the margin).
    TriangleContactGeometry of_wholes;
    if (TriangleContactOf(Vertex(f, t, 0), Vertex(f, t, 1), Vertex(f, t, 2), Vertex(f, u, 0), Vertex(f, u, 1),
                          Vertex(f, u, 2), f.margin, &of_wholes)) {
      g = of_wholes;
    }
  }
  Hit h;
  h.i = i;
  h.j = j;
  h.t = t;
  h.u = u;
  h.a = a.id;
  h.b = b.id;
  h.kind = g.intersecting ? TriangleContactKind::kIntersecting : TriangleContactKind::kWithinMargin;
  h.distance = g.distance;
  for (int k = 0; k < 3; ++k) {
    h.on_t[k] = g.on_a[k];
    h.on_u[k] = g.on_b[k];
  }
  chunk.hits.push_back(h);
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
  for (uint32_t k = Of(d).cluster_grid_offsets[c]; k < Of(d).cluster_grid_offsets[c + 1]; ++k) {
    const PiecePoint& g = Of(d).cluster_grid[k];
    const uint32_t* v = set.triangle_vertices.data() + 3 * size_t{g.triangle};
    const Eigen::Vector3f& q = grid_out[k] =
        runtime::internal::GridPointInline(pos[v[0]], pos[v[1]], pos[v[2]], g.level, g.i, g.j);
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
  return finite;
}

size_t Reaching(const Frame& f, uint32_t s, const Vec4f& other, uint32_t* out) {
  const NarrowPhaseData& d = f.data;
  size_t n = 0;
  for (uint32_t c = Of(d).cluster_offsets[s]; c < Of(d).cluster_offsets[s + 1]; ++c) {
    if (BoxReachesSphere(f.cluster_box[c], other, f.margin)) out[n++] = c;
  }
  return n;
}

// Calls fn(a, b) for every pair of clusters (a of sphere i, b of sphere j) whose boxes meet,
// both having reached into the other sphere; counted in chunk.stats.cluster_pairs. Scratch: chunk.ka,
// chunk.kb (max_sphere_clusters entries each).
template <class Fn>
void ClusterPairs(const Frame& f, uint32_t i, uint32_t j, const Vec4f& si, const Vec4f& sj, Chunk& chunk, Fn&& fn) {
  uint32_t* ka = chunk.ka.data();
  uint32_t* kb = chunk.kb.data();
  // The spheres' own boxes (unions of their clusters' boxes, often much tighter than fast spheres)
  // first.
  if (!BoxesMeet(f.sphere_box[i], f.sphere_box[j], Slack(f.margin))) return;
  const size_t na = Reaching(f, i, sj, ka);
  if (na == 0) return;
  const size_t nb = Reaching(f, j, si, kb);
  const float slack = Slack(f.margin);
  for (size_t x = 0; x < na; ++x) {
    for (size_t y = 0; y < nb; ++y) {
      ++chunk.stats.cluster_pairs;
      if (BoxesMeet(f.cluster_box[ka[x]], f.cluster_box[kb[y]], slack)) fn(ka[x], kb[y]);
    }
  }
}

bool TestClusters(const Frame& f, uint32_t i, uint32_t j, uint32_t ca, uint32_t cb, Chunk& chunk) {
  const NarrowPhaseData& d = f.data;
  const float slack = Slack(f.margin);
  bool ok = true;
  auto gather = [&](uint32_t c, const Box& other, Box* list) {
    size_t n = 0;
    for (uint32_t k = Of(d).cluster_triangle_offsets[c]; k < Of(d).cluster_triangle_offsets[c + 1]; ++k) {
      ok &= TriangleBox(f, Of(d).cluster_triangles[k], &list[n]);
      if (BoxesMeet(list[n], other, slack)) ++n;
    }
    return n;
  };
  const size_t na = gather(ca, f.cluster_box[cb], chunk.a.data());
  if (na == 0) return ok;
  const size_t nb = gather(cb, f.cluster_box[ca], chunk.b.data());
  chunk.stats.culled_triangles += na + nb;
  for (size_t x = 0; x < na; ++x) {
    for (size_t y = 0; y < nb; ++y) Test(f, i, j, chunk.a[x], chunk.b[y], chunk);
  }
  return ok;
}

bool TestPair(const Frame& f, uint32_t i, uint32_t j, const Vec4f& si, const Vec4f& sj, Chunk& chunk) {
  ++chunk.stats.sphere_pairs;
  bool ok = true;
  ClusterPairs(f, i, j, si, sj, chunk, [&](uint32_t a, uint32_t b) { ok &= TestClusters(f, i, j, a, b, chunk); });
  return ok;
}

}  // namespace skinspheres::runtime::narrow_phase
