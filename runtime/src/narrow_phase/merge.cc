// The frame's hits grouped by body-part pair (internal.h, frame step 5): part pairs sorted, each
// with its triangle pairs sorted by (t, u) and the sphere pairs that own their points.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "narrow_phase/internal.h"

namespace skinspheres::runtime::narrow_phase {

uint32_t SphereAt(const Frame& f, uint32_t t, const float p[3]) {
  const NarrowPhaseData::Layout& d = Of(f.data);
  const uint32_t owner = d.triangle_owner[t];
  if ((owner & NarrowPhaseData::Layout::kCut) == 0) return owner;
  const uint32_t k = owner & ~NarrowPhaseData::Layout::kCut;
  const int level = d.piece_level[k];
  // Barycentric coordinates (b1, b2) of p in t, in double, from the larger of the normal's axes.
  const Eigen::Vector3d a = Vertex(f, t, 0).cast<double>(), e1 = Vertex(f, t, 1).cast<double>() - a,
                        e2 = Vertex(f, t, 2).cast<double>() - a, q = Eigen::Vector3d(p[0], p[1], p[2]) - a;
  const double d11 = e1.dot(e1), d12 = e1.dot(e2), d22 = e2.dot(e2), q1 = q.dot(e1), q2 = q.dot(e2);
  const double det = d11 * d22 - d12 * d12;
  double b1 = 0.0, b2 = 0.0;
  if (det > 0.0 && std::isfinite(det)) {
    b1 = (d22 * q1 - d12 * q2) / det;
    b2 = (d11 * q2 - d12 * q1) / det;
  }
  // The grid cell (i, j) holding (b1, b2) * level, and which of its two pieces.
  const double x = std::clamp(b1, 0.0, 1.0) * level, y = std::clamp(b2, 0.0, 1.0) * level;
  int i = std::clamp(int(std::floor(x)), 0, level - 1), j = std::clamp(int(std::floor(y)), 0, level - 1);
  if (i + j > level - 1) {  // past the hypotenuse by rounding: the nearest upward cell on it
    const int over = i + j - (level - 1);
    (i >= over ? i : j) -= over;
  }
  const bool upward = i + j == level - 1 || (x - i) + (y - j) <= 1.0;
  // PieceCorners' numbering: upward pieces row by row, then downward ones.
  uint32_t index = 0;
  for (int r = 0; r < j; ++r) index += upward ? uint32_t(level - r) : uint32_t(level - 1 - r);
  index += uint32_t(i);
  if (!upward) index += uint32_t(level) * uint32_t(level + 1) / 2;
  return d.piece_owner[d.piece_owner_offsets[k] + index];
}

void Normalise(const NarrowPhaseData& data, Hit& h) {
  const auto& part = Of(data).triangle_part;
  const uint16_t pa = part[h.t], pb = part[h.u];
  if (pa > pb || (pa == pb && h.t > h.u)) {
    std::swap(h.t, h.u);
    for (int k = 0; k < 3; ++k) std::swap(h.on_t[k], h.on_u[k]);
  }
}

void Merge(const Frame& f, std::vector<Hit>& hits, std::vector<uint64_t>& keys, FrameContacts* out) {
  const auto& part = Of(f.data).triangle_part;
  for (Hit& h : hits) Normalise(f.data, h);
  // A total order; the copies of one triangle pair (found through several pieces or sphere pairs)
  // are equal, their geometry that of the whole triangles.
  std::sort(hits.begin(), hits.end(), [&part](const Hit& p, const Hit& q) {
    const uint32_t kp = (uint32_t{part[p.t]} << 16) | part[p.u];
    const uint32_t kq = (uint32_t{part[q.t]} << 16) | part[q.u];
    if (kp != kq) return kp < kq;
    return p.t != q.t ? p.t < q.t : p.u < q.u;
  });
  size_t begin = 0, kept = 0;
  while (begin < hits.size()) {
    const uint16_t pa = part[hits[begin].t], pb = part[hits[begin].u];
    size_t end = begin;
    while (end < hits.size() && part[hits[end].t] == pa && part[hits[end].u] == pb) ++end;
    PartContact pc;
    pc.part_a = pa;
    pc.part_b = pb;
    pc.first_triangle_pair = uint32_t(out->triangle_pairs.size());
    pc.min_distance = INFINITY;
    keys.clear();
    for (size_t k = begin; k < end; ++k) {
      if (k > begin && hits[k].t == hits[k - 1].t && hits[k].u == hits[k - 1].u) continue;
      Hit& h = hits[kept++] = hits[k];  // k >= kept: not overwritten before it is read
      TriangleContact c;
      c.triangle_a = h.t;
      c.triangle_b = h.u;
      c.kind = h.kind;
      c.distance = h.distance;
      for (int d = 0; d < 3; ++d) {
        c.on_a[d] = h.on_t[d];
        c.on_b[d] = h.on_u[d];
        c.point[d] = 0.5f * (h.on_t[d] + h.on_u[d]);
      }
      // The spheres owning the contact: at the point both triangles share, or at each closest point.
      const bool meet = h.kind == TriangleContactKind::kIntersecting;
      h.i = SphereAt(f, h.t, meet ? c.point : c.on_a);
      h.j = SphereAt(f, h.u, meet ? c.point : c.on_b);
      keys.push_back((uint64_t{std::min(h.i, h.j)} << 32) | std::max(h.i, h.j));
      out->triangle_pairs.push_back(c);
      if (meet) {
        ++pc.intersecting_count;
        pc.min_distance = 0.0f;
      } else if (h.distance < pc.min_distance) {
        pc.min_distance = h.distance;
        std::memcpy(pc.center, c.point, sizeof(pc.center));
      }
    }
    std::sort(keys.begin(), keys.end());
    keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
    pc.triangle_pair_count = uint32_t(out->triangle_pairs.size() - pc.first_triangle_pair);
    pc.first_sphere_pair = uint32_t(out->sphere_pairs.size());
    pc.sphere_pair_count = uint32_t(keys.size());
    for (uint64_t key : keys) out->sphere_pairs.push_back({uint32_t(key >> 32), uint32_t(key & 0xffffffffu)});
    if (pc.intersecting_count > 0) std::memset(pc.center, 0, sizeof(pc.center));
    out->parts.push_back(pc);
    begin = end;
  }
  hits.resize(kept);
}

}  // namespace skinspheres::runtime::narrow_phase
