// Narrow phase (narrow_phase.h): set-up of the exclusions, per sphere pair culling and triangle
// tests, the merge into part-pair groups, the penetration depth, and the brute-force oracle.
#include "skinspheres/runtime/narrow_phase/narrow_phase.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <optional>
#include <string>
#include <unordered_map>

#include "simd/float4.h"
#include "skinspheres/runtime/narrow_phase/triangle_contact.h"
#include "skinspheres/skinning/skinning_job.h"
#include "skinspheres/skinning/skinning_matrices_job.h"

namespace skinspheres::runtime {

const char* ToString(TriangleContactKind kind) {
  switch (kind) {
    case TriangleContactKind::kIntersecting: return "intersecting";
    case TriangleContactKind::kWithinMargin: return "within_margin";
  }
  return "unknown";
}

void FrameContacts::Reserve(size_t triangle_pairs_capacity) {
  parts.reserve(triangle_pairs_capacity);
  sphere_pairs.reserve(triangle_pairs_capacity);
  triangle_pairs.reserve(triangle_pairs_capacity);
}

bool NarrowPhaseData::ShareVertex(uint32_t t, uint32_t u) const {
  const uint32_t* a = &welded_[3 * size_t{t}];
  const uint32_t* b = &welded_[3 * size_t{u}];
  for (int k = 0; k < 3; ++k) {
    if (a[k] == b[0] || a[k] == b[1] || a[k] == b[2]) return true;
  }
  return false;
}

bool NarrowPhaseData::RestExcluded(uint32_t t, uint32_t u) const {
  if (t > u) std::swap(t, u);
  const uint64_t key = (uint64_t{t} << 32) | u;
  return std::binary_search(rest_excluded_.begin(), rest_excluded_.end(), key);
}

// The internals shared by set-up, the job and the oracle.
struct NarrowPhaseAccess {
  using Hit = NarrowPhaseContext::Hit;
  using Box = NarrowPhaseContext::Box;
  using Chunk = NarrowPhaseContext::Chunk;

  // A contour is planar when its smallest spread is at most this share of the middle one.
  static constexpr double kPlanarContour = 0.1;

  struct Frame {
    const SphereSet& set;
    const NarrowPhaseData& data;
    const Eigen::Vector3f* pos;
    float margin;
    bool rest_rule;                    // apply rule 3 (false while rule 3 itself is being computed)
    const Box* cluster_box = nullptr;  // this frame's cluster boxes (set for the spheres in pairs)
    const Box* sphere_box = nullptr;   // and the unions of each sphere's cluster boxes
  };

  static float Slack(float margin) { return margin * (1.0f + 1e-5f); }

  static const Eigen::Vector3f& Vertex(const Frame& f, uint32_t t, int k) {
    return f.pos[f.set.triangle_vertices[3 * size_t{t} + k]];
  }

  // Box of triangle t; false when a coordinate is not finite.
  static bool TriangleBox(const Frame& f, uint32_t t, Box* box) {
    const Eigen::Vector3f& a = Vertex(f, t, 0);
    const Eigen::Vector3f& b = Vertex(f, t, 1);
    const Eigen::Vector3f& d = Vertex(f, t, 2);
    for (int k = 0; k < 3; ++k) {
      box->lo[k] = std::min({a[k], b[k], d[k]});
      box->hi[k] = std::max({a[k], b[k], d[k]});
    }
    box->id = t;
    return std::isfinite(box->lo[0] + box->lo[1] + box->lo[2] + box->hi[0] + box->hi[1] + box->hi[2]);
  }

  // Does the box come within radius of the sphere's centre? (double: the sphere holds its
  // triangles exactly, so a tiny relative slack covers the arithmetic here)
  static bool BoxReachesSphere(const Box& box, const Vec4f& s, float margin) {
    double d2 = 0.0;
    for (int k = 0; k < 3; ++k) {
      const double x = s[k];
      const double e = std::max({double(box.lo[k]) - x, 0.0, x - double(box.hi[k])});
      d2 += e * e;
    }
    const double r = (double(s.w()) + double(margin)) * (1.0 + 1e-9);
    return d2 <= r * r;
  }

  // Do balls a and b come within margin of each other? (double, tiny slack)
  static bool SpheresMeet(const Vec4f& a, const Vec4f& b, float margin) {
    const double dx = double(a.x()) - b.x(), dy = double(a.y()) - b.y(), dz = double(a.z()) - b.z();
    const double reach = (double(a.w()) + double(b.w()) + double(margin)) * (1.0 + 1e-9);
    return dx * dx + dy * dy + dz * dz <= reach * reach;
  }

  // Boxes within `slack` of each other on every axis (float subtraction: exact in sign, so slack 0
  // is the exact closed test).
  static bool BoxesMeet(const Box& a, const Box& b, float slack) {
    return a.lo[0] - b.hi[0] <= slack && b.lo[0] - a.hi[0] <= slack && a.lo[1] - b.hi[1] <= slack &&
           b.lo[1] - a.hi[1] <= slack && a.lo[2] - b.hi[2] <= slack && b.lo[2] - a.hi[2] <= slack;
  }

  // Triangles t (of sphere i) and u (of sphere j) whose boxes meet: the rules, then the exact test.
  static void Test(const Frame& f, uint32_t i, uint32_t j, const Box& a, const Box& b, Chunk& chunk) {
    ++chunk.stats.box_tests;
    if (!BoxesMeet(a, b, Slack(f.margin))) return;
    if (f.data.ShareVertex(a.id, b.id)) return;
    ++chunk.stats.triangle_tests;
    TriangleContactGeometry g;
    if (!TriangleContactOf(Vertex(f, a.id, 0), Vertex(f, a.id, 1), Vertex(f, a.id, 2), Vertex(f, b.id, 0),
                           Vertex(f, b.id, 1), Vertex(f, b.id, 2), f.margin, &g)) {
      return;
    }
    if (f.rest_rule && f.data.RestExcluded(a.id, b.id)) return;
    Hit h;
    h.i = i;
    h.j = j;
    h.t = a.id;
    h.u = b.id;
    h.kind = g.intersecting ? TriangleContactKind::kIntersecting : TriangleContactKind::kWithinMargin;
    h.distance = g.distance;
    for (int k = 0; k < 3; ++k) {
      h.on_t[k] = g.on_a[k];
      h.on_u[k] = g.on_b[k];
    }
    chunk.hits.push_back(h);
  }

  // ----------------------------------------------------------------- cluster boxes

  // The box of the cluster's skinned vertices. False when one is not finite.
  static bool PositionBox(const NarrowPhaseData& d, const Eigen::Vector3f* pos, uint32_t c, Box* box) {
    const uint32_t* vertex = d.cluster_vertices_.data() + d.cluster_vertex_offsets_[c];
    const uint32_t* const end = d.cluster_vertices_.data() + d.cluster_vertex_offsets_[c + 1];
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

  // ----------------------------------------------------------------- per sphere pair

  // The clusters of sphere s whose box reaches into sphere `other` (grown by the margin).
  static size_t Reaching(const Frame& f, uint32_t s, const Vec4f& other, uint32_t* out) {
    const NarrowPhaseData& d = f.data;
    size_t n = 0;
    for (uint32_t c = d.cluster_offsets_[s]; c < d.cluster_offsets_[s + 1]; ++c) {
      if (BoxReachesSphere(f.cluster_box[c], other, f.margin)) out[n++] = c;
    }
    return n;
  }

  // Calls fn(a, b) for every pair of clusters (a of sphere i, b of sphere j) whose boxes meet,
  // both having reached into the other sphere. ka, kb: scratch of max_sphere_clusters entries.
  template <class Fn>
  static void ClusterPairs(const Frame& f, uint32_t i, uint32_t j, const Vec4f& si, const Vec4f& sj, uint32_t* ka,
                           uint32_t* kb, size_t* tested, Fn&& fn) {
    // The spheres' own boxes (unions of their clusters' boxes, often much tighter than fast spheres)
    // first.
    if (!BoxesMeet(f.sphere_box[i], f.sphere_box[j], Slack(f.margin))) return;
    const size_t na = Reaching(f, i, sj, ka);
    if (na == 0) return;
    const size_t nb = Reaching(f, j, si, kb);
    const float slack = Slack(f.margin);
    for (size_t x = 0; x < na; ++x) {
      for (size_t y = 0; y < nb; ++y) {
        ++*tested;
        if (BoxesMeet(f.cluster_box[ka[x]], f.cluster_box[kb[y]], slack)) fn(ka[x], kb[y]);
      }
    }
  }

  // Triangles of cluster a against those of cluster b (each reduced to those reaching the other
  // cluster's box). False on a non-finite position.
  static bool TestClusters(const Frame& f, uint32_t i, uint32_t j, uint32_t ca, uint32_t cb, Chunk& chunk) {
    const NarrowPhaseData& d = f.data;
    const float slack = Slack(f.margin);
    bool ok = true;
    auto gather = [&](uint32_t c, const Box& other, Box* list) {
      size_t n = 0;
      for (uint32_t k = d.cluster_triangle_offsets_[c]; k < d.cluster_triangle_offsets_[c + 1]; ++k) {
        ok &= TriangleBox(f, d.cluster_triangles_[k], &list[n]);
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

  // One sphere pair: clusters reaching into the other sphere, cluster pairs whose boxes meet, their
  // triangles. False on non-finite input.
  static bool TestPair(const Frame& f, uint32_t i, uint32_t j, const Vec4f& si, const Vec4f& sj, Chunk& chunk) {
    ++chunk.stats.sphere_pairs;
    bool ok = true;
    ClusterPairs(f, i, j, si, sj, chunk.ka.data(), chunk.kb.data(), &chunk.stats.cluster_pairs,
                 [&](uint32_t a, uint32_t b) { ok &= TestClusters(f, i, j, a, b, chunk); });
    return ok;
  }

  // ----------------------------------------------------------------- merge into part-pair groups

  static uint16_t Part(const SphereSet& set, uint32_t sphere) { return set.sphere_part[sphere]; }

  // Puts t on part_a's side (the lower part; t < u within one part).
  static void Normalise(const SphereSet& set, Hit& h) {
    const uint16_t pa = Part(set, h.i), pb = Part(set, h.j);
    if (pa > pb || (pa == pb && h.t > h.u)) {
      std::swap(h.i, h.j);
      std::swap(h.t, h.u);
      for (int k = 0; k < 3; ++k) std::swap(h.on_t[k], h.on_u[k]);
    }
  }

  // hits -> out (parts, sphere pairs, triangle pairs; depth left at 0). keys: scratch.
  static void Merge(const SphereSet& set, std::vector<Hit>& hits, std::vector<uint64_t>& keys, FrameContacts* out) {
    for (Hit& h : hits) Normalise(set, h);
    std::sort(hits.begin(), hits.end(), [&set](const Hit& p, const Hit& q) {
      const uint32_t kp = (uint32_t{Part(set, p.i)} << 16) | Part(set, p.j);
      const uint32_t kq = (uint32_t{Part(set, q.i)} << 16) | Part(set, q.j);
      if (kp != kq) return kp < kq;
      return p.t != q.t ? p.t < q.t : p.u < q.u;
    });
    // A triangle owned twice (a malformed set) would show the same pair twice: keep one.
    hits.erase(std::unique(hits.begin(), hits.end(), [](const Hit& p, const Hit& q) { return p.t == q.t && p.u == q.u; }),
               hits.end());
    size_t begin = 0;
    while (begin < hits.size()) {
      const uint16_t pa = Part(set, hits[begin].i), pb = Part(set, hits[begin].j);
      size_t end = begin;
      while (end < hits.size() && Part(set, hits[end].i) == pa && Part(set, hits[end].j) == pb) ++end;
      PartContact pc;
      pc.part_a = pa;
      pc.part_b = pb;
      pc.first_triangle_pair = uint32_t(out->triangle_pairs.size());
      pc.triangle_pair_count = uint32_t(end - begin);
      pc.min_distance = INFINITY;
      keys.clear();
      for (size_t k = begin; k < end; ++k) {
        const Hit& h = hits[k];
        TrianglePairContact c;
        c.t = h.t;
        c.u = h.u;
        c.kind = h.kind;
        c.distance = h.distance;
        for (int d = 0; d < 3; ++d) {
          c.on_t[d] = h.on_t[d];
          c.on_u[d] = h.on_u[d];
          c.point[d] = 0.5f * (h.on_t[d] + h.on_u[d]);
        }
        out->triangle_pairs.push_back(c);
        if (h.kind == TriangleContactKind::kIntersecting) {
          ++pc.intersecting_count;
          pc.min_distance = 0.0f;
        } else if (h.distance < pc.min_distance) {
          pc.min_distance = h.distance;
          std::memcpy(pc.center, c.point, sizeof(pc.center));
        }
        keys.push_back((uint64_t{std::min(h.i, h.j)} << 32) | std::max(h.i, h.j));
      }
      std::sort(keys.begin(), keys.end());
      keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
      pc.first_sphere_pair = uint32_t(out->sphere_pairs.size());
      pc.sphere_pair_count = uint32_t(keys.size());
      for (uint64_t key : keys) out->sphere_pairs.push_back({uint32_t(key >> 32), uint32_t(key & 0xffffffffu)});
      if (pc.intersecting_count > 0) std::memset(pc.center, 0, sizeof(pc.center));
      out->parts.push_back(pc);
      begin = end;
    }
  }

  // ----------------------------------------------------------------- penetration depth

  struct DepthScratch {
    std::vector<uint32_t>& sphere_mark;
    std::vector<uint32_t>& queue;
    uint32_t& stamp;
    size_t vertices = 0;
  };

  // How far the vertices of one side reach past the contour (narrow_phase.h); `ensure(s)` makes the
  // positions of sphere s's vertices available. sign +1: part_a (C - v) . n; -1: part_b.
  template <class Ensure>
  static double Flood(const Frame& f, const std::vector<Hit>& hits, size_t begin, size_t end, bool side_t,
                      const Eigen::Vector3d& c, const Eigen::Vector3d& n, double r2, Ensure&& ensure, DepthScratch& s) {
    if (++s.stamp == 0) {
      std::fill(s.sphere_mark.begin(), s.sphere_mark.end(), 0u);
      s.stamp = 1;
    }
    size_t queued = 0;
    for (size_t k = begin; k < end; ++k) {
      const uint32_t sphere = side_t ? hits[k].i : hits[k].j;
      if (s.sphere_mark[sphere] != s.stamp) {
        s.sphere_mark[sphere] = s.stamp;
        s.queue[queued++] = sphere;
      }
    }
    const double sign = side_t ? -1.0 : 1.0;
    const double r2_slack = r2 * (1.0 + 1e-9);
    const auto offsets = f.data.sphere_vertex_offsets();
    const auto vertices = f.data.sphere_vertices();
    const auto nb_offsets = f.data.neighbour_offsets();
    const auto nbs = f.data.neighbours();
    double h = 0.0;
    for (size_t q = 0; q < queued; ++q) {
      const uint32_t sphere = s.queue[q];
      ensure(sphere);
      bool inside = false;
      for (uint32_t k = offsets[sphere]; k < offsets[sphere + 1]; ++k) {
        const Eigen::Vector3d d = f.pos[vertices[k]].cast<double>() - c;
        const double along = d.dot(n);
        const double axial = sign * along;
        const double radial2 = d.squaredNorm() - along * along;
        if (axial > 0.0 && radial2 <= r2_slack) {
          inside = true;
          h = std::max(h, axial);
        }
      }
      s.vertices += offsets[sphere + 1] - offsets[sphere];
      if (!inside) continue;
      for (uint32_t k = nb_offsets[sphere]; k < nb_offsets[sphere + 1]; ++k) {
        const uint32_t next = nbs[k];
        if (s.sphere_mark[next] != s.stamp) {
          s.sphere_mark[next] = s.stamp;
          s.queue[queued++] = next;
        }
      }
    }
    return h;
  }

  static Eigen::Vector3d Normal(const Frame& f, uint32_t t) {
    const Eigen::Vector3d a = Vertex(f, t, 0).cast<double>();
    return (Vertex(f, t, 1).cast<double>() - a).cross(Vertex(f, t, 2).cast<double>() - a);
  }

  // Fills depth, normal and centre of every part pair with intersections. hits: the merged hits
  // (same order as out->triangle_pairs).
  template <class Ensure>
  static void Depths(const Frame& f, const std::vector<Hit>& hits, Ensure&& ensure, DepthScratch& scratch,
                     FrameContacts* out) {
    for (PartContact& pc : out->parts) {
      if (pc.intersecting_count == 0) continue;
      const size_t begin = pc.first_triangle_pair, end = begin + pc.triangle_pair_count;
      Eigen::Vector3d nsum = Eigen::Vector3d::Zero(), csum = Eigen::Vector3d::Zero(), mids = Eigen::Vector3d::Zero();
      Eigen::Vector3d cent_t = Eigen::Vector3d::Zero(), cent_u = Eigen::Vector3d::Zero();
      double nabs = 0.0, length = 0.0;
      size_t count = 0;
      for (size_t k = begin; k < end; ++k) {
        const Hit& h = hits[k];
        if (h.kind != TriangleContactKind::kIntersecting) continue;
        const Eigen::Vector3d nt = Normal(f, h.t), nu = Normal(f, h.u);
        nsum += nu - nt;
        nabs += nu.norm() + nt.norm();
        for (int v = 0; v < 3; ++v) {
          cent_t += Vertex(f, h.t, v).cast<double>();
          cent_u += Vertex(f, h.u, v).cast<double>();
        }
        const Eigen::Vector3d e0(h.on_t[0], h.on_t[1], h.on_t[2]), e1(h.on_u[0], h.on_u[1], h.on_u[2]);
        const double len = (e1 - e0).norm();
        csum += len * 0.5 * (e0 + e1);
        mids += 0.5 * (e0 + e1);
        length += len;
        ++count;
      }
      const Eigen::Vector3d c = length > 0.0 ? Eigen::Vector3d(csum / length) : Eigen::Vector3d(mids / double(count));
      Eigen::Vector3d n = nsum;
      if (!(n.norm() > 1e-12 * nabs)) n = cent_t - cent_u;
      if (!(n.norm() > 0.0) || !n.allFinite()) continue;  // no direction at all: depth 0
      n.normalize();
      // A planar contour (the usual case: a loop where one surface passes through the other) gives
      // the normal more precisely than the triangles' normals: the least-squares plane of the
      // segment ends, oriented like n.
      Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
      for (size_t k = begin; k < end; ++k) {
        const Hit& h = hits[k];
        if (h.kind != TriangleContactKind::kIntersecting) continue;
        const Eigen::Vector3d e0(h.on_t[0], h.on_t[1], h.on_t[2]), e1(h.on_u[0], h.on_u[1], h.on_u[2]);
        const double w = length > 0.0 ? (e1 - e0).norm() : 1.0;
        for (const Eigen::Vector3d& e : {e0, e1}) cov += w * (e - c) * (e - c).transpose();
      }
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
      if (eig.info() == Eigen::Success && eig.eigenvalues()[1] > 0.0 &&
          eig.eigenvalues()[0] <= kPlanarContour * eig.eigenvalues()[1]) {
        const Eigen::Vector3d plane = eig.eigenvectors().col(0);
        n = plane.dot(n) >= 0.0 ? plane : Eigen::Vector3d(-plane);
      }
      double r2 = 0.0;
      for (size_t k = begin; k < end; ++k) {
        const Hit& h = hits[k];
        if (h.kind != TriangleContactKind::kIntersecting) continue;
        for (const float* e : {h.on_t, h.on_u}) {
          const Eigen::Vector3d d = Eigen::Vector3d(e[0], e[1], e[2]) - c;
          const double along = d.dot(n);
          r2 = std::max(r2, d.squaredNorm() - along * along);
        }
      }
      const double ha = Flood(f, hits, begin, end, true, c, n, r2, ensure, scratch);
      const double hb = Flood(f, hits, begin, end, false, c, n, r2, ensure, scratch);
      pc.depth = float(ha + hb);
      for (int k = 0; k < 3; ++k) {
        pc.normal[k] = float(n[k]);
        pc.center[k] = float(c[k]);
      }
    }
  }

  // ----------------------------------------------------------------- all pairs (oracle, set-up)

  // Every pair i < j the filter allows whose triangle boxes (grown by the margin) meet, every
  // triangle against every triangle. hits appended.
  static bool AllPairs(const Frame& f, const PairFilter& filter, std::vector<Hit>* hits) {
    const size_t n = f.set.size();
    // Each sphere's triangle boxes and their union.
    std::vector<std::vector<Box>> boxes(n);
    std::vector<Box> whole(n);
    bool ok = true;
    for (size_t s = 0; s < n; ++s) {
      Box all{{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}, 0};
      for (uint32_t k = f.set.triangle_offsets[s]; k < f.set.triangle_offsets[s + 1]; ++k) {
        Box box;
        ok &= TriangleBox(f, f.set.triangles[k], &box);
        for (int d = 0; d < 3; ++d) {
          all.lo[d] = std::min(all.lo[d], box.lo[d]);
          all.hi[d] = std::max(all.hi[d], box.hi[d]);
        }
        boxes[s].push_back(box);
      }
      whole[s] = all;
    }
    Chunk chunk;
    const float slack = Slack(f.margin);
    for (uint32_t i = 0; i < n; ++i) {
      for (uint32_t j = i + 1; j < n; ++j) {
        if (boxes[i].empty() || boxes[j].empty() || filter.excluded(i, j) || !BoxesMeet(whole[i], whole[j], slack)) continue;
        for (const Box& a : boxes[i]) {
          for (const Box& b : boxes[j]) Test(f, i, j, a, b, chunk);
        }
      }
    }
    hits->insert(hits->end(), chunk.hits.begin(), chunk.hits.end());
    return ok;
  }

  // Cuts each sphere's triangles into clusters of at most settings.cluster_triangles by median
  // splits of their rest centroids along the longest axis; each cluster lists its vertices.
  static void BuildClusters(const SphereSet& set, NarrowPhaseData* d) {
    const auto& rest = d->rest_positions_;
    auto centroid = [&](uint32_t t) {
      return (rest[set.triangle_vertices[3 * size_t{t}]] + rest[set.triangle_vertices[3 * size_t{t} + 1]] +
              rest[set.triangle_vertices[3 * size_t{t} + 2]]) / 3.0f;
    };
    d->cluster_offsets_.assign(1, 0);
    d->cluster_triangle_offsets_.assign(1, 0);
    d->cluster_vertex_offsets_.assign(1, 0);
    std::vector<uint32_t> tris, verts;
    struct Range {
      size_t begin, end;
    };
    std::vector<Range> stack;
    for (size_t s = 0; s < set.size(); ++s) {
      tris.assign(set.triangles.begin() + set.triangle_offsets[s], set.triangles.begin() + set.triangle_offsets[s + 1]);
      stack.clear();
      if (!tris.empty()) stack.push_back({0, tris.size()});
      std::vector<Range> leaves;
      while (!stack.empty()) {
        const Range r = stack.back();
        stack.pop_back();
        if (r.end - r.begin <= d->settings_.cluster_triangles) {
          leaves.push_back(r);
          continue;
        }
        Eigen::AlignedBox3f box;
        for (size_t k = r.begin; k < r.end; ++k) box.extend(centroid(tris[k]));
        int axis;
        box.sizes().maxCoeff(&axis);
        const size_t mid = (r.begin + r.end) / 2;
        std::nth_element(tris.begin() + r.begin, tris.begin() + mid, tris.begin() + r.end, [&](uint32_t a, uint32_t b) {
          const float ca = centroid(a)[axis], cb = centroid(b)[axis];
          return ca != cb ? ca < cb : a < b;
        });
        stack.push_back({mid, r.end});
        stack.push_back({r.begin, mid});
      }
      std::sort(leaves.begin(), leaves.end(), [](const Range& a, const Range& b) { return a.begin < b.begin; });
      for (const Range& r : leaves) {
        verts.clear();
        for (size_t k = r.begin; k < r.end; ++k) {
          d->cluster_triangles_.push_back(tris[k]);
          for (int c = 0; c < 3; ++c) verts.push_back(set.triangle_vertices[3 * size_t{tris[k]} + c]);
        }
        std::sort(verts.begin(), verts.end());
        verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
        d->cluster_vertices_.insert(d->cluster_vertices_.end(), verts.begin(), verts.end());
        d->cluster_triangle_offsets_.push_back(uint32_t(d->cluster_triangles_.size()));
        d->cluster_vertex_offsets_.push_back(uint32_t(d->cluster_vertices_.size()));
      }
      d->cluster_offsets_.push_back(uint32_t(d->cluster_vertex_offsets_.size() - 1));
    }
  }

  // Mode (b) skins the vertices of the spheres in pairs, each vertex once: the vertices are grouped
  // by the set of spheres whose triangles use them (a sphere's inside, the border it shares with a
  // neighbour, ...), and each sphere lists its groups. All grouped vertices go into one set of
  // prepared influences (the SIMD skinning layout), input group by group: the layout keeps the
  // input order inside each influence count, so a group is one run of slots per influence count it
  // has, and groups that follow each other in the input sit next to each other in every count.
  // False when the influences are inconsistent.
  static bool BuildVertexGroups(const SphereSet& set, NarrowPhaseData* d) {
    const size_t vertices = set.source_vertex_count;
    std::vector<std::vector<uint32_t>> spheres_of(vertices);
    for (uint32_t s = 0; s < set.size(); ++s) {
      for (uint32_t k = d->sphere_vertex_offsets_[s]; k < d->sphere_vertex_offsets_[s + 1]; ++k) {
        spheres_of[d->sphere_vertices_[k]].push_back(s);  // ascending s
      }
    }
    std::map<std::vector<uint32_t>, uint32_t> group_of;
    std::vector<std::vector<uint32_t>> members;
    for (uint32_t v = 0; v < vertices; ++v) {
      if (spheres_of[v].empty()) continue;
      auto [it, added] = group_of.emplace(spheres_of[v], uint32_t(members.size()));
      if (added) members.emplace_back();
      members[it->second].push_back(v);
    }
    const skinning::SkinnedMesh& mesh = set.mesh;
    std::vector<uint32_t> subset;
    for (const auto& m : members) subset.insert(subset.end(), m.begin(), m.end());
    if (!d->lazy_influences_.Build(mesh.vertex_count(), mesh.influence_offsets, mesh.influence_binds,
                                   mesh.influence_weights, subset)) {
      return false;
    }
    // Runs: for each influence count (the layout's groups, ascending), each vertex group's members
    // with that count, in group order.
    const size_t groups = members.size();
    d->run_begin_.assign(1, 0);
    std::vector<std::vector<uint32_t>> runs_of(groups);
    for (const skinning::PreparedInfluences::Group& layout : d->lazy_influences_.groups()) {
      for (size_t g = 0; g < groups; ++g) {
        uint32_t length = 0;
        for (uint32_t v : members[g]) {
          length += mesh.influence_offsets[v + 1] - mesh.influence_offsets[v] == layout.influence_count;
        }
        if (length == 0) continue;
        runs_of[g].push_back(uint32_t(d->run_begin_.size() - 1));
        d->run_begin_.push_back(d->run_begin_.back() + length);
      }
    }
    if (d->run_begin_.back() != d->lazy_influences_.size()) return false;
    d->group_run_offsets_.assign(1, 0);
    d->group_sizes_.clear();
    for (size_t g = 0; g < groups; ++g) {
      d->group_runs_.insert(d->group_runs_.end(), runs_of[g].begin(), runs_of[g].end());
      d->group_run_offsets_.push_back(uint32_t(d->group_runs_.size()));
      d->group_sizes_.push_back(uint32_t(members[g].size()));
    }
    std::vector<std::vector<uint32_t>> groups_of(set.size());
    for (const auto& [spheres, g] : group_of) {
      for (uint32_t s : spheres) groups_of[s].push_back(g);
    }
    d->sphere_group_offsets_.assign(1, 0);
    for (auto& list : groups_of) {
      std::sort(list.begin(), list.end());
      d->sphere_groups_.insert(d->sphere_groups_.end(), list.begin(), list.end());
      d->sphere_group_offsets_.push_back(uint32_t(d->sphere_groups_.size()));
    }
    // Per sphere, its groups' runs as the non-zero words of a run bitset.
    d->sphere_run_offsets_.assign(1, 0);
    std::vector<uint32_t> runs;
    for (const auto& list : groups_of) {
      runs.clear();
      for (uint32_t g : list) {
        for (uint32_t k = d->group_run_offsets_[g]; k < d->group_run_offsets_[g + 1]; ++k) runs.push_back(d->group_runs_[k]);
      }
      std::sort(runs.begin(), runs.end());
      for (uint32_t r : runs) {
        if (d->sphere_run_words_.size() == d->sphere_run_offsets_.back() || d->sphere_run_words_.back() != r >> 6) {
          d->sphere_run_words_.push_back(r >> 6);
          d->sphere_run_bits_.push_back(0);
        }
        d->sphere_run_bits_.back() |= uint64_t{1} << (r & 63);
      }
      d->sphere_run_offsets_.push_back(uint32_t(d->sphere_run_words_.size()));
    }
    return true;
  }

  // The spheres in this frame's pairs, once each (ctx.involved_).
  static void Involved(std::span<const Contact> pairs, NarrowPhaseContext& ctx) {
    ctx.involved_.clear();
    for (const Contact& p : pairs) {
      for (uint32_t s : {p.i, p.j}) {
        if (ctx.sphere_seen_[s] != ctx.frame_stamp_) {
          ctx.sphere_seen_[s] = ctx.frame_stamp_;
          ctx.involved_.push_back(s);
        }
      }
    }
  }

  // The boxes of the clusters of every involved sphere, and the spheres' unions of them. False on a
  // non-finite position.
  static bool PrepareClusters(const Frame& f, NarrowPhaseContext& ctx, const ParallelFor& parallel_for) {
    const NarrowPhaseData& d = f.data;
    std::atomic<bool> ok{true};
    parallel_for(ctx.involved_.size(), 4, [&](size_t begin, size_t end) {
      bool good = true;
      for (size_t k = begin; k < end; ++k) {
        const uint32_t s = ctx.involved_[k];
        for (uint32_t c = d.cluster_offsets_[s]; c < d.cluster_offsets_[s + 1]; ++c) {
          good &= PositionBox(d, f.pos, c, &ctx.cluster_box_[c]);
        }
        UniteClusters(d, s, ctx);
      }
      if (!good) ok.store(false, std::memory_order_relaxed);
    });
    for (uint32_t s : ctx.involved_) ctx.stats_.clusters_bounded += d.cluster_offsets_[s + 1] - d.cluster_offsets_[s];
    return ok.load();
  }

  // A sphere's box: the union of its clusters' boxes.
  static void UniteClusters(const NarrowPhaseData& d, uint32_t s, NarrowPhaseContext& ctx) {
    Box all{{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}, s};
    for (uint32_t c = d.cluster_offsets_[s]; c < d.cluster_offsets_[s + 1]; ++c) {
      for (int k = 0; k < 3; ++k) {
        all.lo[k] = std::min(all.lo[k], ctx.cluster_box_[c].lo[k]);
        all.hi[k] = std::max(all.hi[k], ctx.cluster_box_[c].hi[k]);
      }
    }
    ctx.sphere_box_[s] = all;
  }

  // Mode (b): skins the vertex groups of the spheres asked for, each group once per frame: Collect
  // marks a sphere's groups' runs (a few words of the run bitset, ORed), Skin skins the marked runs,
  // adjacent runs merged into one span. Every vertex is skinned by the same instructions as on the
  // whole-mesh path, so the positions are bit-identical to skinning the whole mesh with SkinningJob.
  struct LazySkinner {
    static constexpr uint32_t kBlock = 1024;  // slots per span at most: work items for parallel_for

    const SphereSet& set;
    const NarrowPhaseData& data;
    NarrowPhaseContext& ctx;
    std::span<const Mat4f> matrices;
    bool ok = true;

    // Marks the runs of sphere's groups not skinned yet this frame; false when there are none.
    bool Collect(uint32_t sphere) {
      const auto offsets = data.sphere_run_offsets();
      const auto words = data.sphere_run_words();
      const auto bits = data.sphere_run_bits();
      const uint32_t k0 = offsets[sphere], k1 = offsets[sphere + 1];
      if (k0 == k1) return false;
      uint64_t added = 0;
      for (uint32_t k = k0; k < k1; ++k) {
        const uint64_t mark = bits[k] & ~ctx.run_done_[words[k]];
        ctx.run_bits_[words[k]] |= mark;
        added |= mark;
      }
      // Words ascending: the range Skin scans grows to this sphere's first and last.
      ctx.marked_begin_ = std::min<size_t>(ctx.marked_begin_, words[k0]);
      ctx.marked_end_ = std::max<size_t>(ctx.marked_end_, size_t{words[k1 - 1]} + 1);
      return added != 0;
    }

    // Appends [begin, end) to the spans, cut into blocks of at most kBlock slots.
    void AddSpan(uint32_t begin, uint32_t end) {
      ctx.stats_.skinned_vertices += end - begin;
      for (; begin < end; begin += std::min(kBlock, end - begin)) {
        ctx.spans_.emplace_back(begin, begin + std::min(kBlock, end - begin));
      }
    }

    // Skins what Collect marked. False on a job the skinning library refuses.
    bool Skin(const ParallelFor& parallel_for) {
      const auto run_begin = data.run_begin();
      ctx.spans_.clear();
      // Maximal sequences of marked runs: runs tile the slots, so consecutive runs are adjacent.
      uint32_t open_begin = 0, open_end = 0;  // the span being extended (empty: none)
      for (size_t word = ctx.marked_begin_; word < ctx.marked_end_; ++word) {
        uint64_t bits = ctx.run_bits_[word];
        if (bits == 0) continue;
        ctx.run_bits_[word] = 0;
        ctx.run_done_[word] |= bits;
        while (bits != 0) {  // per sequence of set bits: runs [r, r + length), adjacent slots
          const int first = std::countr_zero(bits);
          const int length = std::countr_one(bits >> first);
          const uint32_t r = uint32_t(word * 64 + size_t(first));
          bits = first + length == 64 ? 0 : bits & (~uint64_t{0} << (first + length));
          if (open_end != run_begin[r]) {
            AddSpan(open_begin, open_end);
            open_begin = run_begin[r];
          }
          open_end = run_begin[r + size_t(length)];
        }
      }
      AddSpan(open_begin, open_end);
      ctx.marked_begin_ = ctx.run_bits_.size();
      ctx.marked_end_ = 0;
      if (ctx.spans_.empty()) return true;
      skinning::SkinningJob job;
      job.joint_matrices = matrices;
      job.vertex_count = set.mesh.vertex_count();
      job.in_positions = {reinterpret_cast<const float*>(set.mesh.positions_bind.data()), 3 * set.mesh.vertex_count()};
      job.out_positions = {reinterpret_cast<float*>(ctx.skinned_.data()), 3 * ctx.skinned_.size()};
      job.prepared = &data.lazy_influences();
      std::atomic<bool> good{true};
      parallel_for(ctx.spans_.size(), 1, [&](size_t begin, size_t end) {
        if (!job.RunRanges(std::span(ctx.spans_).subspan(begin, end - begin))) good.store(false, std::memory_order_relaxed);
      });
      ok &= good.load();
      return good.load();
    }

    // The depth estimate's on-demand call: one sphere, on this thread. The spheres in pairs were
    // checked finite by PrepareClusters; any other gets its vertices checked here, once a frame.
    void operator()(uint32_t sphere) {
      if (ctx.sphere_seen_[sphere] == ctx.frame_stamp_) return;
      ctx.sphere_seen_[sphere] = ctx.frame_stamp_;
      if (Collect(sphere)) Skin(SerialFor());
      const auto offsets = data.sphere_vertex_offsets();
      for (uint32_t k = offsets[sphere]; k < offsets[sphere + 1]; ++k) {
        ok &= ctx.skinned_[data.sphere_vertices()[k]].allFinite();
      }
    }
  };

  // Rest positions: the mesh skinned with the rest transforms.
  static bool RestPositions(const SphereSet& set, std::vector<Eigen::Vector3f>* out) {
    const skinning::SkinnedMesh& mesh = set.mesh;
    std::vector<Mat4f> matrices(mesh.binds.size());
    if (!skinning::SkinningMatricesJob{mesh.binds, set.joint_rest_world, matrices}.Run()) return false;
    out->assign(mesh.vertex_count(), Eigen::Vector3f::Zero());
    skinning::SkinningJob job;
    job.joint_matrices = matrices;
    job.vertex_count = mesh.vertex_count();
    job.in_positions = {reinterpret_cast<const float*>(mesh.positions_bind.data()), 3 * mesh.vertex_count()};
    job.out_positions = {reinterpret_cast<float*>(out->data()), 3 * out->size()};
    job.influence_offsets = mesh.influence_offsets;
    job.influence_binds = mesh.influence_binds;
    job.influence_weights = mesh.influence_weights;
    return mesh.vertex_count() == 0 || job.Run();
  }
};

using Access = NarrowPhaseAccess;

// ------------------------------------------------------------------------------- set-up

Result<NarrowPhaseData> NarrowPhaseData::Create(const SphereSet& set, const PairFilter& filter,
                                                const NarrowPhaseSettings& settings) {
  const std::string who = "sphere set '" + set.source_file + "'";
  if (!set.has_mesh()) {
    return MakeError(ErrorCode::kVersionMismatch,
                     who + " has no mesh (format version 1): the narrow phase needs a version-2 set; fit the character again");
  }
  if (auto err = set.Validate()) return MakeError(err->code, who + ": " + err->message);
  if (filter.size() != set.size()) {
    return MakeError(ErrorCode::kInvalidArgument, who + ": the pair filter has " + std::to_string(filter.size()) +
                                                      " spheres, the set " + std::to_string(set.size()));
  }
  if (!(settings.margin >= 0.0f) || !std::isfinite(settings.margin)) {
    return MakeError(ErrorCode::kInvalidArgument, who + ": the narrow-phase margin must be finite and >= 0");
  }
  if (settings.cluster_triangles < 1 || settings.cluster_triangles > 256) {
    return MakeError(ErrorCode::kInvalidArgument, who + ": the narrow-phase cluster size must be 1..256 triangles");
  }
  NarrowPhaseData d;
  d.settings_ = settings;
  if (!Access::RestPositions(set, &d.rest_positions_)) {
    return MakeError(ErrorCode::kInvalidData, who + ": the mesh cannot be skinned at rest (bind entries and skeleton disagree)");
  }
  Eigen::Vector3f low = Eigen::Vector3f::Constant(std::numeric_limits<float>::max()), high = -low;
  for (const auto& p : d.rest_positions_) {
    if (!p.allFinite()) return MakeError(ErrorCode::kInvalidData, who + ": the mesh skinned at rest is not finite");
    low = low.cwiseMin(p);
    high = high.cwiseMax(p);
  }
  // A margin is a contact distance, not a search radius: the rest-pose exclusions (and a frame's
  // contacts) grow with the square of the triangle count within it. Xbot (1.8 units tall) at a
  // margin of 0.1 peaked at 290 MB, at 0.18 at 2.7 GB and 100 s of set-up, at 1e30 past 4 GB.
  // Refused beyond the limit, with the size, so the caller can choose.
  const float size = d.rest_positions_.empty() ? 0.0f : (high - low).maxCoeff();
  if (settings.margin > kMaxMarginShareOfSize * size) {
    char text[200];
    std::snprintf(text, sizeof text,
                  ": the narrow-phase margin %g is more than %g of the character's rest size (%g units, its largest "
                  "extent): a contact distance, not a search radius",
                  double(settings.margin), double(kMaxMarginShareOfSize), double(size));
    return MakeError(ErrorCode::kInvalidArgument, who + text);
  }
  // Rule 2: weld vertices with bit-identical rest positions (-0 and +0 alike).
  const size_t vertices = set.source_vertex_count;
  std::vector<uint32_t> canonical(vertices);
  {
    struct KeyHash {
      size_t operator()(const std::array<uint32_t, 3>& k) const {
        return (size_t{k[0]} * 0x9E3779B97F4A7C15ull) ^ (size_t{k[1]} * 0xC2B2AE3D27D4EB4Full) ^ (size_t{k[2]} * 0x165667B19E3779F9ull);
      }
    };
    std::unordered_map<std::array<uint32_t, 3>, uint32_t, KeyHash> first;
    first.reserve(vertices);
    for (uint32_t v = 0; v < vertices; ++v) {
      std::array<uint32_t, 3> key;
      for (int k = 0; k < 3; ++k) {
        const float x = d.rest_positions_[v][k] + 0.0f;  // -0 -> +0
        std::memcpy(&key[k], &x, sizeof(float));
      }
      canonical[v] = first.emplace(key, v).first->second;
    }
  }
  d.welded_.resize(set.triangle_vertices.size());
  for (size_t k = 0; k < set.triangle_vertices.size(); ++k) d.welded_[k] = canonical[set.triangle_vertices[k]];

  // Each sphere's triangle vertices, and its largest triangle list.
  const size_t n = set.size();
  d.sphere_vertex_offsets_.assign(1, 0);
  std::vector<uint32_t> list;
  for (size_t s = 0; s < n; ++s) {
    list.clear();
    for (uint32_t k = set.triangle_offsets[s]; k < set.triangle_offsets[s + 1]; ++k) {
      for (int c = 0; c < 3; ++c) list.push_back(set.triangle_vertices[3 * size_t{set.triangles[k]} + c]);
    }
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
    d.sphere_vertices_.insert(d.sphere_vertices_.end(), list.begin(), list.end());
    d.sphere_vertex_offsets_.push_back(uint32_t(d.sphere_vertices_.size()));
    d.max_sphere_triangles_ = std::max<size_t>(d.max_sphere_triangles_, set.triangle_offsets[s + 1] - set.triangle_offsets[s]);
  }

  Access::BuildClusters(set, &d);
  if (!Access::BuildVertexGroups(set, &d)) {
    return MakeError(ErrorCode::kInvalidData, who + ": the mesh's influences do not fit its bind entries");
  }
  for (size_t s = 0; s < n; ++s) {
    d.max_sphere_clusters_ = std::max<size_t>(d.max_sphere_clusters_, d.cluster_offsets_[s + 1] - d.cluster_offsets_[s]);
  }

  // Neighbours for the depth estimate: same part, and overlapping at rest or sharing a (welded) vertex.
  {
    std::vector<std::vector<uint32_t>> spheres_of(vertices);
    for (uint32_t s = 0; s < n; ++s) {
      for (uint32_t k = d.sphere_vertex_offsets_[s]; k < d.sphere_vertex_offsets_[s + 1]; ++k) {
        auto& owners = spheres_of[canonical[d.sphere_vertices_[k]]];
        if (owners.empty() || owners.back() != s) owners.push_back(s);
      }
    }
    std::vector<std::vector<uint32_t>> adjacent(n);
    for (const auto& owners : spheres_of) {
      for (size_t x = 0; x < owners.size(); ++x) {
        for (size_t y = x + 1; y < owners.size(); ++y) {
          if (set.sphere_part[owners[x]] != set.sphere_part[owners[y]]) continue;
          adjacent[owners[x]].push_back(owners[y]);
          adjacent[owners[y]].push_back(owners[x]);
        }
      }
    }
    for (uint32_t i = 0; i < n; ++i) {
      for (uint32_t j = i + 1; j < n; ++j) {
        if (set.sphere_part[i] != set.sphere_part[j]) continue;
        const float reach = set.radii_rest[i] + set.radii_rest[j];
        if ((set.centers_rest[i] - set.centers_rest[j]).squaredNorm() <= reach * reach) {
          adjacent[i].push_back(j);
          adjacent[j].push_back(i);
        }
      }
    }
    d.neighbour_offsets_.assign(1, 0);
    for (auto& a : adjacent) {
      std::sort(a.begin(), a.end());
      a.erase(std::unique(a.begin(), a.end()), a.end());
      d.neighbours_.insert(d.neighbours_.end(), a.begin(), a.end());
      d.neighbour_offsets_.push_back(uint32_t(d.neighbours_.size()));
    }
  }

  // Rule 3: every pair the runtime could test that intersects or lies within the margin at rest.
  {
    const Access::Frame rest{set, d, d.rest_positions_.data(), settings.margin, /*rest_rule=*/false};
    std::vector<Access::Hit> hits;
    Access::AllPairs(rest, filter, &hits);
    d.rest_excluded_.reserve(hits.size());
    for (const auto& h : hits) {
      d.rest_excluded_.push_back((uint64_t{std::min(h.t, h.u)} << 32) | std::max(h.t, h.u));
    }
    std::sort(d.rest_excluded_.begin(), d.rest_excluded_.end());
    d.rest_excluded_.erase(std::unique(d.rest_excluded_.begin(), d.rest_excluded_.end()), d.rest_excluded_.end());
  }
  return d;
}

void NarrowPhaseContext::Resize(const NarrowPhaseData& data, bool lazy_skinning) {
  sized_for_ = &data;
  for (Chunk& c : chunks_) {
    c.a.assign(data.settings().cluster_triangles, Box{});
    c.b.assign(data.settings().cluster_triangles, Box{});
    c.ka.assign(data.max_sphere_clusters(), 0);
    c.kb.assign(data.max_sphere_clusters(), 0);
    c.hits.reserve(256);
  }
  merged_.reserve(256 * kChunks);
  keys_.reserve(256);
  sphere_mark_.assign(data.sphere_count(), 0);
  queue_.assign(data.sphere_count(), 0);
  sphere_stamp_ = 0;
  sphere_seen_.assign(data.sphere_count(), 0);
  involved_.reserve(data.sphere_count());
  cluster_box_.assign(data.cluster_count(), Box{});
  sphere_box_.assign(data.sphere_count(), Box{});
  frame_stamp_ = 0;
  if (lazy_skinning) {
    skinned_.assign(data.vertex_count(), Eigen::Vector3f::Zero());
    run_bits_.assign((data.run_count() + 63) / 64, 0);
    run_done_.assign(run_bits_.size(), 0);
    marked_begin_ = run_bits_.size();
    marked_end_ = 0;
    spans_.reserve(data.run_count() + data.lazy_influences().size() / Access::LazySkinner::kBlock + 1);
  } else {
    skinned_.clear();
    skinned_.shrink_to_fit();
    run_bits_.clear();
    run_bits_.shrink_to_fit();
    run_done_.clear();
    run_done_.shrink_to_fit();
    spans_.clear();
    spans_.shrink_to_fit();
  }
}

// ------------------------------------------------------------------------------- per frame

bool NarrowPhaseJob::Validate() const {
  if (set == nullptr || data == nullptr || context == nullptr || out == nullptr) return false;
  if (!set->has_mesh() || data->sphere_count() != set->size() || data->triangle_count() != set->source_triangle_count ||
      data->vertex_count() != set->source_vertex_count) {
    return false;
  }
  if (spheres.size() != set->size() || !context->sized_for(*data)) return false;
  if (!positions.empty()) return positions.size() >= set->source_vertex_count;
  return joint_world.size() >= set->joint_count() && !joint_world.empty();
}

namespace {

struct NoSkinning {
  void operator()(uint32_t) const {}
};

}  // namespace

bool NarrowPhaseJob::RunParallel(const ParallelFor& parallel_for) const {
  if (out != nullptr) out->clear();
  if (!Validate()) return false;
  NarrowPhaseContext& ctx = *context;
  ctx.stats_ = {};
  const size_t n = set->size();
  for (const Contact& p : pairs) {
    if (p.i >= p.j || p.j >= n) return false;
  }
  const bool lazy = positions.empty();
  if (lazy && !ctx.has_lazy_skinning()) ctx.Resize(*data, true);  // first mode-(b) run: warm-up allocation
  if (++ctx.frame_stamp_ == 0) {
    std::fill(ctx.sphere_seen_.begin(), ctx.sphere_seen_.end(), 0u);
    ctx.frame_stamp_ = 1;
  }
  Access::Involved(pairs, ctx);
  Access::Frame frame{*set,  *data, positions.data(), data->margin(), /*rest_rule=*/true, ctx.cluster_box_.data(),
                      ctx.sphere_box_.data()};
  // Positions: the caller's (mode a), or skinned here, the involved spheres' vertices only (mode b).
  std::optional<Access::LazySkinner> skinner;
  if (lazy) {
    ctx.bind_matrices_.resize(set->mesh.binds.size());
    if (!skinning::SkinningMatricesJob{set->mesh.binds, joint_world.first(set->joint_count()), ctx.bind_matrices_}.Run()) {
      return false;
    }
    std::fill(ctx.run_done_.begin(), ctx.run_done_.end(), uint64_t{0});
    skinner.emplace(Access::LazySkinner{*set, *data, ctx, ctx.bind_matrices_});
    for (uint32_t s : ctx.involved_) skinner->Collect(s);
    // Non-finite positions are caught by PrepareClusters, which boxes every vertex skinned here.
    if (!skinner->Skin(parallel_for)) return false;
    frame.pos = ctx.skinned_.data();
  }
  if (!Access::PrepareClusters(frame, ctx, parallel_for)) return false;
  const size_t chunks = std::min(pairs.size(), NarrowPhaseContext::kChunks);
  for (size_t c = 0; c < chunks; ++c) {
    ctx.chunks_[c].hits.clear();
    ctx.chunks_[c].stats = {};
    ctx.chunks_[c].ok = true;
  }
  parallel_for(chunks, 1, [&](size_t begin, size_t end) {
    for (size_t c = begin; c < end; ++c) {
      NarrowPhaseContext::Chunk& chunk = ctx.chunks_[c];
      const size_t first = c * pairs.size() / chunks, last = (c + 1) * pairs.size() / chunks;
      for (size_t k = first; k < last; ++k) {
        const Contact& p = pairs[k];
        chunk.ok &= Access::TestPair(frame, p.i, p.j, spheres[p.i], spheres[p.j], chunk);
      }
    }
  });
  bool ok = true;
  ctx.merged_.clear();
  for (size_t c = 0; c < chunks; ++c) {
    const NarrowPhaseContext::Chunk& chunk = ctx.chunks_[c];
    ok &= chunk.ok;
    ctx.merged_.insert(ctx.merged_.end(), chunk.hits.begin(), chunk.hits.end());
    ctx.stats_.sphere_pairs += chunk.stats.sphere_pairs;
    ctx.stats_.cluster_pairs += chunk.stats.cluster_pairs;
    ctx.stats_.culled_triangles += chunk.stats.culled_triangles;
    ctx.stats_.box_tests += chunk.stats.box_tests;
    ctx.stats_.triangle_tests += chunk.stats.triangle_tests;
  }
  if (!ok) {
    out->clear();
    return false;
  }
  Access::Merge(*set, ctx.merged_, ctx.keys_, out);
  Access::DepthScratch scratch{ctx.sphere_mark_, ctx.queue_, ctx.sphere_stamp_};
  if (lazy) {
    Access::Depths(frame, ctx.merged_, *skinner, scratch, out);
    if (!skinner->ok) {
      out->clear();
      return false;
    }
  } else {
    Access::Depths(frame, ctx.merged_, NoSkinning{}, scratch, out);
  }
  ctx.stats_.depth_vertices = scratch.vertices;
  return true;
}

bool NarrowPhaseJob::Run() const { return RunParallel(SerialFor()); }

bool FindContactsBruteForce(const SphereSet& set, const NarrowPhaseData& data, const PairFilter& filter,
                            std::span<const Eigen::Vector3f> positions, FrameContacts* out) {
  if (out == nullptr) return false;
  out->clear();
  if (!set.has_mesh() || data.sphere_count() != set.size() || data.triangle_count() != set.source_triangle_count ||
      data.vertex_count() != set.source_vertex_count || filter.size() != set.size() ||
      positions.size() < set.source_vertex_count) {
    return false;
  }
  const Access::Frame frame{set, data, positions.data(), data.margin(), /*rest_rule=*/true};
  std::vector<Access::Hit> hits;
  if (!Access::AllPairs(frame, filter, &hits)) return false;
  std::vector<uint64_t> keys;
  Access::Merge(set, hits, keys, out);
  std::vector<uint32_t> marks(set.size(), 0), queue(set.size(), 0);
  uint32_t stamp = 0;
  Access::DepthScratch scratch{marks, queue, stamp};
  Access::Depths(frame, hits, NoSkinning{}, scratch, out);
  return true;
}

}  // namespace skinspheres::runtime
