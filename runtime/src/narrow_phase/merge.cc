// The frame's hits grouped by body-part pair (internal.h, frame step 5): part pairs sorted, each
// with its triangle pairs sorted by (t, u) and the sphere pairs that own them.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "narrow_phase/internal.h"

namespace skinspheres::runtime::narrow_phase {

void Normalise(const SphereSet& set, Hit& h) {
  const uint16_t pa = Part(set, h.i), pb = Part(set, h.j);
  if (pa > pb || (pa == pb && h.t > h.u)) {
    std::swap(h.i, h.j);
    std::swap(h.t, h.u);
    std::swap(h.a, h.b);
    for (int k = 0; k < 3; ++k) std::swap(h.on_t[k], h.on_u[k]);
  }
}

void Merge(const SphereSet& set, std::vector<Hit>& hits, std::vector<uint64_t>& keys, FrameContacts* out) {
  for (Hit& h : hits) Normalise(set, h);
  // A total order (sphere pairs last), so what is kept below does not depend on the order found.
  std::sort(hits.begin(), hits.end(), [&set](const Hit& p, const Hit& q) {
    const uint32_t kp = (uint32_t{Part(set, p.i)} << 16) | Part(set, p.j);
    const uint32_t kq = (uint32_t{Part(set, q.i)} << 16) | Part(set, q.j);
    if (kp != kq) return kp < kq;
    if (p.t != q.t) return p.t < q.t;
    if (p.u != q.u) return p.u < q.u;
    if (p.i != q.i) return p.i < q.i;
    if (p.j != q.j) return p.j < q.j;
    return p.a != q.a ? p.a < q.a : p.b < q.b;
  });
  size_t begin = 0, kept = 0;
  while (begin < hits.size()) {
    const uint16_t pa = Part(set, hits[begin].i), pb = Part(set, hits[begin].j);
    size_t end = begin;
    while (end < hits.size() && Part(set, hits[end].i) == pa && Part(set, hits[end].j) == pb) ++end;
    PartContact pc;
    pc.part_a = pa;
    pc.part_b = pb;
    pc.first_triangle_pair = uint32_t(out->triangle_pairs.size());
    pc.min_distance = INFINITY;
    keys.clear();
    for (size_t k = begin; k < end; ++k) {
      const Hit& h = hits[k];
      keys.push_back((uint64_t{std::min(h.i, h.j)} << 32) | std::max(h.i, h.j));
      // A cut triangle (docs/TRIANGLE_PIECES.md) meets another through several piece pairs, each
      // with the whole triangles' geometry: the pair is reported once, its sphere pairs all kept.
      if (k > begin && h.t == hits[k - 1].t && h.u == hits[k - 1].u) continue;
      hits[kept++] = h;  // k >= kept: h is not overwritten before it is read
      TriangleContact c;
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
