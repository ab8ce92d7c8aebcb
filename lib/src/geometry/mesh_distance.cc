// Point-to-mesh distances through an AABB tree of triangles. See mesh_distance.h.
#include "skinspheres/lib/geometry/mesh_distance.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "skinspheres/lib/geometry/closest_point.h"

namespace skinspheres::lib {
namespace {

// AABB tree of triangles (median split on the longest centroid axis, leaves of <= 4), nearest-point
// queries by branch and bound.
struct TriangleTree {
  struct Node {
    Eigen::Vector3f lo, hi;
    uint32_t left = 0, right = 0;   // children (inner nodes)
    uint32_t first = 0, count = 0;  // range in order (leaves: count > 0)
  };
  std::vector<Node> nodes;
  std::vector<uint32_t> order;
  std::span<const Eigen::Vector3f> positions;
  std::span<const Eigen::Vector3i> triangles;

  TriangleTree(std::span<const Eigen::Vector3f> pos, std::span<const Eigen::Vector3i> tris)
      : positions(pos), triangles(tris) {
    order.resize(tris.size());
    std::vector<Eigen::Vector3f> centroid(tris.size());
    for (size_t t = 0; t < tris.size(); ++t) {
      order[t] = uint32_t(t);
      centroid[t] = (pos[tris[t][0]] + pos[tris[t][1]] + pos[tris[t][2]]) / 3.f;
    }
    nodes.reserve(2 * tris.size() / 3 + 2);
    Build(0, uint32_t(tris.size()), centroid);
  }

  uint32_t Build(uint32_t first, uint32_t count, const std::vector<Eigen::Vector3f>& centroid) {
    const uint32_t id = uint32_t(nodes.size());
    nodes.emplace_back();
    Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max()), hi = -lo;
    Eigen::Vector3f clo = lo, chi = hi;
    for (uint32_t i = first; i < first + count; ++i) {
      for (int k = 0; k < 3; ++k) {
        lo = lo.cwiseMin(positions[triangles[order[i]][k]]);
        hi = hi.cwiseMax(positions[triangles[order[i]][k]]);
      }
      clo = clo.cwiseMin(centroid[order[i]]);
      chi = chi.cwiseMax(centroid[order[i]]);
    }
    nodes[id].lo = lo;
    nodes[id].hi = hi;
    if (count <= 4) {
      nodes[id].first = first;
      nodes[id].count = count;
      return id;
    }
    int axis = 0;
    (chi - clo).maxCoeff(&axis);
    const uint32_t half = count / 2;
    std::nth_element(order.begin() + first, order.begin() + first + half, order.begin() + first + count,
                     [&](uint32_t x, uint32_t y) {
                       return centroid[x][axis] < centroid[y][axis] ||
                              (centroid[x][axis] == centroid[y][axis] && x < y);
                     });
    const uint32_t l = Build(first, half, centroid);
    const uint32_t r = Build(first + half, count - half, centroid);
    nodes[id].left = l;
    nodes[id].right = r;
    return id;
  }

  static float BoxDistance2(const Node& n, const Eigen::Vector3f& p) {
    const Eigen::Vector3f d = (n.lo - p).cwiseMax(p - n.hi).cwiseMax(0.f);
    return d.squaredNorm();
  }

  float Distance(const Eigen::Vector3f& p) const {
    float best = std::numeric_limits<float>::infinity();
    std::array<uint32_t, 128> stack;
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const Node& n = nodes[stack[--top]];
      if (BoxDistance2(n, p) >= best) continue;
      if (n.count > 0) {
        for (uint32_t i = n.first; i < n.first + n.count; ++i) {
          const Eigen::Vector3i& t = triangles[order[i]];
          const float d2 =
              (ClosestPointOnTriangle(p, positions[t[0]], positions[t[1]], positions[t[2]]) - p).squaredNorm();
          best = std::min(best, d2);
        }
        continue;
      }
      const float dl = BoxDistance2(nodes[n.left], p), dr = BoxDistance2(nodes[n.right], p);
      if (dl < dr) {  // nearer child on top of the stack
        stack[top++] = n.right;
        stack[top++] = n.left;
      } else {
        stack[top++] = n.left;
        stack[top++] = n.right;
      }
    }
    return std::sqrt(best);
  }
};

}  // namespace

void MeshDistances(std::span<const Eigen::Vector3f> positions, std::span<const Eigen::Vector3i> triangles,
                   std::span<const Eigen::Vector3f> queries, std::span<float> out) {
  if (triangles.empty() || out.size() != queries.size()) return;
  const TriangleTree tree(positions, triangles);
  for (size_t i = 0; i < queries.size(); ++i) out[i] = tree.Distance(queries[i]);
}

}  // namespace skinspheres::lib
