// Bounding volume hierarchy over one region's triangles for the disk rays (paper §4.1, §5: "∀ r_i,
// ∀ Δ_j ∈ R: Ray Triangle Intersection Test(r_i, Δ_j)", done here in O(log n) per ray instead of
// O(n)). Binned SAH build; nearest-first stack traversal; exact same per-triangle test and
// (t, triangle index) ordering as the brute-force oracle, so both return the same hit.
#include "skinspheres/lib/geometry/triangle_bvh.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "skinspheres/lib/geometry/ray_triangle.h"

namespace skinspheres::lib {
namespace {

constexpr int kBins = 16;
constexpr uint32_t kMaxLeafSize = 4;      // nodes this small are leaves
constexpr uint32_t kForcedLeafSize = 16;  // above this the build always splits
constexpr int kMaxDepth = 96;
constexpr int kStackSize = kMaxDepth + 4;
// Boxes are padded by this fraction of the mesh's coordinate magnitude so that float rounding in
// the slab test and the 1e-9 barycentric widening of ray_triangle.h can never cull a real hit.
constexpr float kBoxPadRelative = 1e-5f;
// Relative slack on the node culling limit (min(t_max, best t so far)).
constexpr float kCullSlack = 1e-5f;

struct Aabb {
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::infinity());
  Eigen::Vector3f hi = Eigen::Vector3f::Constant(-std::numeric_limits<float>::infinity());
  void Grow(const Eigen::Vector3f& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  void Grow(const Aabb& b) {
    lo = lo.cwiseMin(b.lo);
    hi = hi.cwiseMax(b.hi);
  }
  bool Empty() const { return !(lo.x() <= hi.x()); }
  float HalfArea() const {
    if (Empty()) return 0.0f;
    const Eigen::Vector3f e = hi - lo;
    return e.x() * e.y() + e.y() * e.z() + e.z() * e.x();
  }
};

struct BuildPrim {
  Aabb box;
  Eigen::Vector3f centroid;
  uint32_t prim = 0;  // index into TriangleBvh::prims_ before reordering
};

TriangleHit MakeHit(const RayTriangleHit& h, const Eigen::Vector3f& a, const Eigen::Vector3f& b,
                    const Eigen::Vector3f& c, int32_t triangle) {
  TriangleHit out;
  out.t = h.t;
  out.triangle = triangle;
  const double u = h.u, v = h.v;
  out.point = (a.cast<double>() * (1.0 - u - v) + b.cast<double>() * u + c.cast<double>() * v).cast<float>();
  out.u = h.u;
  out.v = h.v;
  out.front_face = h.front_face;
  return out;
}

// (t, triangle) lexicographic order: the nearest hit, ties to the smallest triangle index.
bool Better(float t, int32_t tri, const std::optional<TriangleHit>& best) {
  return !best || t < best->t || (t == best->t && tri < best->triangle);
}

class Builder {
 public:
  Builder(std::vector<BuildPrim>& prims, float pad) : prims_(prims), pad_(pad) {}

  int depth = 0;
  std::vector<uint32_t> node_first, node_count;  // mirrors of Node fields during build
  std::vector<Aabb> node_box;

  void Recurse(uint32_t begin, uint32_t end, int level) {
    depth = std::max(depth, level + 1);
    const uint32_t node = static_cast<uint32_t>(node_box.size());
    Aabb box, cbox;
    for (uint32_t i = begin; i < end; ++i) {
      box.Grow(prims_[i].box);
      cbox.Grow(prims_[i].centroid);
    }
    box.lo.array() -= pad_;
    box.hi.array() += pad_;
    node_box.push_back(box);
    node_first.push_back(begin);
    node_count.push_back(end - begin);
    const uint32_t n = end - begin;
    if (n <= kMaxLeafSize || level + 1 >= kMaxDepth) return;

    uint32_t mid = begin;
    if (!FindSahSplit(begin, end, cbox, &mid)) {
      if (n <= kForcedLeafSize) return;  // stays a leaf
      mid = begin + n / 2;               // unsplittable by SAH (e.g. equal centroids): halve in order
    }
    node_count[node] = 0;
    Recurse(begin, mid, level + 1);
    node_first[node] = static_cast<uint32_t>(node_box.size());  // right child
    Recurse(mid, end, level + 1);
  }

 private:
  // Binned SAH (Wald 2007) along the axis of largest centroid extent (with 16 bins a split with
  // both sides non-empty always exists when that extent is > 0). False when all centroids coincide.
  bool FindSahSplit(uint32_t begin, uint32_t end, const Aabb& cbox, uint32_t* mid) {
    int axis = 0;
    const Eigen::Vector3f cext = cbox.hi - cbox.lo;
    cext.maxCoeff(&axis);
    if (!(cext[axis] > 0.0f)) return false;
    const float lo = cbox.lo[axis], scale = kBins / cext[axis];
    auto bin_of = [&](const Eigen::Vector3f& centroid) {
      return std::min(kBins - 1, static_cast<int>((centroid[axis] - lo) * scale));
    };
    std::array<Aabb, kBins> bins;
    std::array<uint32_t, kBins> counts{};
    for (uint32_t i = begin; i < end; ++i) {
      const BuildPrim& p = prims_[i];
      const int b = bin_of(p.centroid);
      bins[b].Grow(p.box);
      ++counts[b];
    }
    float best_cost = std::numeric_limits<float>::infinity();
    int best_bin = -1;
    std::array<float, kBins> right_area{};
    std::array<uint32_t, kBins> right_count{};
    Aabb acc;
    uint32_t cnt = 0;
    for (int b = kBins - 1; b > 0; --b) {
      acc.Grow(bins[b]);
      cnt += counts[b];
      right_area[b] = acc.HalfArea();
      right_count[b] = cnt;
    }
    acc = Aabb();
    cnt = 0;
    for (int b = 0; b < kBins - 1; ++b) {
      acc.Grow(bins[b]);
      cnt += counts[b];
      if (cnt == 0 || right_count[b + 1] == 0) continue;
      // SAH cost ∝ A_L·N_L + A_R·N_R (C_traversal and 1/A_parent are common to all splits).
      const float cost = acc.HalfArea() * cnt + right_area[b + 1] * right_count[b + 1];
      if (cost < best_cost) {
        best_cost = cost;
        best_bin = b;
      }
    }
    if (best_bin < 0) return false;
    auto it = std::partition(prims_.begin() + begin, prims_.begin() + end,
                             [&](const BuildPrim& p) { return bin_of(p.centroid) <= best_bin; });
    *mid = static_cast<uint32_t>(it - prims_.begin());
    return *mid > begin && *mid < end;
  }

  std::vector<BuildPrim>& prims_;
  float pad_;
};

}  // namespace

Result<TriangleBvh> TriangleBvh::Build(std::span<const Eigen::Vector3f> positions,
                                       std::span<const Eigen::Vector3i> triangles, std::span<const int32_t> subset) {
  std::vector<int32_t> selected;
  if (subset.empty()) {
    selected.resize(triangles.size());
    for (size_t i = 0; i < triangles.size(); ++i) selected[i] = static_cast<int32_t>(i);
  } else {
    selected.assign(subset.begin(), subset.end());
    std::sort(selected.begin(), selected.end());
    selected.erase(std::unique(selected.begin(), selected.end()), selected.end());
  }
  TriangleBvh bvh;
  std::vector<BuildPrim> build;
  build.reserve(selected.size());
  bvh.prims_.reserve(selected.size());
  float magnitude = 0.0f;
  for (int32_t t : selected) {
    if (t < 0 || static_cast<size_t>(t) >= triangles.size()) {
      return MakeError(ErrorCode::kInvalidArgument, "TriangleBvh: subset names triangle " + std::to_string(t) +
                                                        " but the mesh has " + std::to_string(triangles.size()) +
                                                        " triangles");
    }
    const Eigen::Vector3i& tri = triangles[t];
    for (int k = 0; k < 3; ++k) {
      if (tri[k] < 0 || static_cast<size_t>(tri[k]) >= positions.size()) {
        return MakeError(ErrorCode::kInvalidArgument, "TriangleBvh: triangle " + std::to_string(t) + " uses vertex " +
                                                          std::to_string(tri[k]) + " but the mesh has " +
                                                          std::to_string(positions.size()) + " vertices");
      }
    }
    const Eigen::Vector3f& a = positions[tri[0]];
    const Eigen::Vector3f& b = positions[tri[1]];
    const Eigen::Vector3f& c = positions[tri[2]];
    if (IsDegenerateTriangle(a, b, c)) continue;
    BuildPrim p;
    p.box.Grow(a);
    p.box.Grow(b);
    p.box.Grow(c);
    p.centroid = (a + b + c) / 3.0f;
    p.prim = static_cast<uint32_t>(build.size());
    magnitude = std::max({magnitude, p.box.lo.cwiseAbs().maxCoeff(), p.box.hi.cwiseAbs().maxCoeff()});
    build.push_back(p);
    bvh.prims_.push_back(Prim{a, b, c, t});
  }
  if (build.empty()) return bvh;

  const float pad = kBoxPadRelative * magnitude + std::numeric_limits<float>::min();
  Builder builder(build, pad);
  builder.Recurse(0, static_cast<uint32_t>(build.size()), 0);

  bvh.nodes_.resize(builder.node_box.size());
  for (size_t i = 0; i < bvh.nodes_.size(); ++i) {
    bvh.nodes_[i] = Node{builder.node_box[i].lo, builder.node_box[i].hi, builder.node_first[i], builder.node_count[i]};
  }
  std::vector<Prim> reordered(build.size());
  for (size_t i = 0; i < build.size(); ++i) reordered[i] = bvh.prims_[build[i].prim];
  bvh.prims_ = std::move(reordered);
  bvh.depth_ = builder.depth;
  return bvh;
}

std::optional<TriangleHit> TriangleBvh::FirstHit(const Eigen::Vector3f& origin, const Eigen::Vector3f& dir,
                                                 float t_max) const {
  std::optional<TriangleHit> best;
  if (nodes_.empty() || !(t_max >= 0.0f)) return best;
  Eigen::Vector3f inv;
  for (int k = 0; k < 3; ++k) {
    // A zero (or denormal) component would give inf·0 = NaN in the slab test; a huge finite
    // inverse keeps the slab logic exact in sign.
    inv[k] = std::fabs(dir[k]) > 1e-30f ? 1.0f / dir[k] : std::copysign(1e30f, dir[k]);
  }
  if (!inv.allFinite() || !origin.allFinite()) return best;

  // Entry and exit t of the ray against a node box; returns false when culled.
  auto slab = [&](const Node& node, float limit, float* t_near) {
    const Eigen::Vector3f t0 = (node.lo - origin).cwiseProduct(inv);
    const Eigen::Vector3f t1 = (node.hi - origin).cwiseProduct(inv);
    const float tn = t0.cwiseMin(t1).maxCoeff();
    const float tf = t0.cwiseMax(t1).minCoeff();
    *t_near = tn;
    return tn <= tf * (1.0f + kCullSlack) && tf >= 0.0f && tn <= limit * (1.0f + kCullSlack);
  };

  uint32_t stack[kStackSize];
  int top = 0;
  float t_root;
  if (!slab(nodes_[0], t_max, &t_root)) return best;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[stack[--top]];
    const float limit = best ? std::min(best->t, t_max) : t_max;
    // Re-check against the current best (the node was pushed before better hits were found).
    float tn;
    if (!slab(node, limit, &tn)) continue;
    if (node.count > 0) {
      for (uint32_t i = node.first; i < node.first + node.count; ++i) {
        const Prim& p = prims_[i];
        const std::optional<RayTriangleHit> h = IntersectRayTriangle(origin, dir, p.a, p.b, p.c, 0.0f, t_max);
        if (h && Better(h->t, p.triangle, best)) best = MakeHit(*h, p.a, p.b, p.c, p.triangle);
      }
      continue;
    }
    const uint32_t left = static_cast<uint32_t>(&node - nodes_.data()) + 1, right = node.first;
    float tl, tr;
    const bool hit_l = slab(nodes_[left], limit, &tl);
    const bool hit_r = slab(nodes_[right], limit, &tr);
    if (hit_l && hit_r) {
      // Near child on top of the stack.
      if (tl <= tr) {
        stack[top++] = right;
        stack[top++] = left;
      } else {
        stack[top++] = left;
        stack[top++] = right;
      }
    } else if (hit_l) {
      stack[top++] = left;
    } else if (hit_r) {
      stack[top++] = right;
    }
  }
  return best;
}

std::optional<TriangleHit> BruteForceFirstHit(std::span<const Eigen::Vector3f> positions,
                                              std::span<const Eigen::Vector3i> triangles,
                                              std::span<const int32_t> subset, const Eigen::Vector3f& origin,
                                              const Eigen::Vector3f& dir, float t_max) {
  std::optional<TriangleHit> best;
  const size_t n = subset.empty() ? triangles.size() : subset.size();
  for (size_t i = 0; i < n; ++i) {
    const int32_t t = subset.empty() ? static_cast<int32_t>(i) : subset[i];
    if (t < 0 || static_cast<size_t>(t) >= triangles.size()) continue;
    const Eigen::Vector3i& tri = triangles[t];
    if ((tri.array() < 0).any() || (tri.array() >= static_cast<int>(positions.size())).any()) continue;
    const Eigen::Vector3f& a = positions[tri[0]];
    const Eigen::Vector3f& b = positions[tri[1]];
    const Eigen::Vector3f& c = positions[tri[2]];
    const std::optional<RayTriangleHit> h = IntersectRayTriangle(origin, dir, a, b, c, 0.0f, t_max);
    if (h && Better(h->t, t, best)) best = MakeHit(*h, a, b, c, t);
  }
  return best;
}

}  // namespace skinspheres::lib
