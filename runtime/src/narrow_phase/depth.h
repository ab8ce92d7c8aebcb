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

struct DepthScratch {
  std::vector<uint32_t>& sphere_mark;
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
// (narrow_phase.h); `ensure(s)` makes the positions of sphere s's vertices available. side_t: part_a,
// measured as (C - v) . n; otherwise part_b, (v - C) . n.
template <class Ensure>
inline double Flood(const Frame& f, std::span<const Hit> hits, bool side_t, const Contour& contour, Ensure&& ensure,
                    DepthScratch& s) {
  const Eigen::Vector3d& c = contour.c;
  const Eigen::Vector3d& n = contour.n;
  const double r2 = contour.r2;
  if (++s.stamp == 0) {
    std::fill(s.sphere_mark.begin(), s.sphere_mark.end(), 0u);
    s.stamp = 1;
  }
  size_t queued = 0;
  for (const Hit& hit : hits) {
    const uint32_t sphere = side_t ? hit.i : hit.j;
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
