// Private: the penetration depth of each part pair (internal.h, frame step 6; narrow_phase.h
// says what it measures). Templates on how the vertices of a sphere are made available: the
// caller's positions (NoSkinning) or skinned on demand (LazySkinner, lazy_skinning.h).
#pragma once

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <span>
#include <vector>

#include "narrow_phase/internal.h"

namespace skinspheres::runtime::narrow_phase {

// Per triangle: its visit stamp and room in the queue.
struct DepthScratch {
  std::vector<uint32_t>& triangle_mark;
  std::vector<uint32_t>& queue;
  uint32_t& stamp;
  size_t vertices = 0;
};

// Every vertex is already where the frame reads it.
struct NoSkinning {
  void operator()(uint32_t) const {}
};

// A part pair's contour: its centre, its normal (unit) and the squared radius of the cylinder along
// the normal that holds it.
struct Contour {
  Eigen::Vector3d c, n;
  double r2;
};

// How far the vertices of one side of `hits` (one part pair's) reach past the contour
// (narrow_phase.h): the side's triangles in the hits, then, triangle by triangle, the triangles of the
// same part sharing a (welded) vertex with a visited triangle that has a vertex past the contour and
// inside its cylinder: the connected penetrating cap, on the mesh alone. `ensure(s)` makes the
// positions of sphere s's vertices available (each triangle's are its owner's). side_t: part_a,
// measured as (C - v) . n; otherwise part_b, (v - C) . n.
template <class Ensure>
inline double Flood(const Frame& f, std::span<const Hit> hits, bool side_t, const Contour& contour, Ensure&& ensure,
                    DepthScratch& s) {
  const NarrowPhaseData::Layout& d = Of(f.data);
  const Eigen::Vector3d& c = contour.c;
  const Eigen::Vector3d& n = contour.n;
  const double r2 = contour.r2;
  if (++s.stamp == 0) {
    std::fill(s.triangle_mark.begin(), s.triangle_mark.end(), 0u);
    s.stamp = 1;
  }
  size_t queued = 0;
  for (const Hit& hit : hits) {
    const uint32_t t = side_t ? hit.t : hit.u;
    if (s.triangle_mark[t] != s.stamp) {
      s.triangle_mark[t] = s.stamp;
      s.queue[queued++] = t;
    }
  }
  if (queued == 0) return 0.0;
  const uint16_t part = d.triangle_part[s.queue[0]];
  const double sign = side_t ? -1.0 : 1.0;
  const double r2_slack = r2 * (1.0 + 1e-9);
  const uint32_t* tv = f.set.triangle_vertices.data();
  double h = 0.0;
  for (size_t q = 0; q < queued; ++q) {
    const uint32_t t = s.queue[q];
    ensure(OwnerSphere(d, t));
    bool inside = false;
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d v = f.pos[tv[3 * size_t{t} + k]].cast<double>() - c;
      const double along = v.dot(n);
      const double axial = sign * along;
      const double radial2 = v.squaredNorm() - along * along;
      if (axial > 0.0 && radial2 <= r2_slack) {
        inside = true;
        h = std::max(h, axial);
      }
    }
    s.vertices += 3;
    if (!inside) continue;
    for (int k = 0; k < 3; ++k) {
      const uint32_t w = d.welded[3 * size_t{t} + k];
      for (uint32_t e = d.vertex_triangle_offsets[w]; e < d.vertex_triangle_offsets[w + 1]; ++e) {
        const uint32_t next = d.vertex_triangles[e];
        if (s.triangle_mark[next] != s.stamp && d.triangle_part[next] == part) {
          s.triangle_mark[next] = s.stamp;
          s.queue[queued++] = next;
        }
      }
    }
  }
  return h;
}

// Fills depth, normal, centre and kind (touching or penetrating) of every part pair with
// intersections. hits: the merged hits (same order as out->triangle_pairs).
template <class Ensure>
inline void Depths(const Frame& f, const std::vector<Hit>& hits, Ensure&& ensure, DepthScratch& scratch,
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
    const std::span<const Hit> pair_hits(hits.data() + begin, end - begin);
    const Contour contour{c, n, r2};
    const double ha = Flood(f, pair_hits, true, contour, ensure, scratch);
    const double hb = Flood(f, pair_hits, false, contour, ensure, scratch);
    pc.depth = float(ha + hb);
    pc.kind = pc.depth > f.data.touch_tolerance() ? PartContactKind::kPenetrating : PartContactKind::kTouching;
    for (int k = 0; k < 3; ++k) {
      pc.normal[k] = float(n[k]);
      pc.center[k] = float(c[k]);
    }
  }
}

}  // namespace skinspheres::runtime::narrow_phase
