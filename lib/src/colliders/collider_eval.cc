// PoseCharacter, EvaluateColliders and the per-bone baseline.
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "colliders/joint_vertices.h"
#include "colliders/shape_fit.h"
#include "skinspheres/lib/colliders/colliders.h"
#include "skinspheres/lib/geometry/mesh_distance.h"
#include "skinspheres/lib/geometry/mesh_helpers.h"
#include "skinspheres/skinning/local_to_model_job.h"

namespace skinspheres::lib {

namespace {

colliders::RoundCone Cone(const PlacedCollider& c) { return {c.head, c.tail, c.head_radius, c.tail_radius}; }

float Percentile(std::vector<float> xs, float q) {
  if (xs.empty()) return 0.0f;
  const size_t k = std::min(xs.size() - 1, static_cast<size_t>(std::floor(q * static_cast<float>(xs.size() - 1))));
  std::nth_element(xs.begin(), xs.begin() + static_cast<std::ptrdiff_t>(k), xs.end());
  return xs[k];
}

// How far vertices lie outside every shape, as counts: exact zeros apart, positive distances in
// bins of 2e-5 of the height (the last bin holds everything from the height on).
class PokeHistogram {
 public:
  explicit PokeHistogram(float height) : width_(std::max(height, 1e-30f) * 2e-5f), bins_(50001, 0) {}
  void Add(float poke) {
    ++count_;
    if (!(poke > 0.0f)) {
      ++zeros_;
      return;
    }
    ++bins_[std::min(bins_.size() - 1, static_cast<size_t>(poke / width_))];
  }
  // The value below which a share q lies (as the k-th smallest, k = floor(q (n - 1))), to the bin.
  float Percentile(double q) const {
    if (count_ == 0) return 0.0f;
    const uint64_t k =
        std::min<uint64_t>(count_ - 1, static_cast<uint64_t>(std::floor(q * static_cast<double>(count_ - 1))));
    if (k < zeros_) return 0.0f;
    uint64_t seen = zeros_;
    for (size_t b = 0; b < bins_.size(); ++b) {
      seen += bins_[b];
      if (seen > k) return (static_cast<float>(b) + 0.5f) * width_;
    }
    return static_cast<float>(bins_.size()) * width_;
  }

 private:
  float width_;
  std::vector<uint64_t> bins_;
  uint64_t count_ = 0, zeros_ = 0;
};

// One pose's figures; per shape: covered / total vertices nearest it, their poke distances, and the
// exposed area with its summed distance.
struct PoseResult {
  ColliderPoseStats stats;
  std::vector<uint32_t> nearest;  // per vertex
  std::vector<float> poke;        // per vertex, >= 0
  std::vector<float> depth;       // per vertex, >= 0: under the surface
  std::vector<double> area, area_distance;
};

PoseResult EvaluatePose(const RawCharacter& character, const PosedCharacter& posed, std::span<const Collider> colliders,
                        float tolerance) {
  std::vector<PlacedCollider> placed;
  for (const auto& c : colliders) placed.push_back(PlaceCollider(c, posed.joint_world[c.joint]));
  PoseResult r;
  const size_t n = posed.vertices.size();
  r.nearest.assign(n, 0);
  r.poke.assign(n, 0.0f);
  r.depth.assign(n, 0.0f);
  size_t covered = 0;
  double depth_sum = 0.0;
  for (size_t v = 0; v < n; ++v) {
    float best = std::numeric_limits<float>::infinity();
    for (size_t s = 0; s < placed.size(); ++s) {
      const float d = colliders::SignedDistance(Cone(placed[s]), posed.vertices[v]);
      if (d < best) best = d, r.nearest[v] = static_cast<uint32_t>(s);
    }
    r.poke[v] = std::max(best, 0.0f);
    r.depth[v] = std::max(-best, 0.0f);
    depth_sum += r.depth[v];
    covered += best <= tolerance ? 1 : 0;
  }
  r.stats.standoff = n ? static_cast<float>(depth_sum / static_cast<double>(n)) : 0.0f;
  r.stats.covered = n ? static_cast<float>(covered) / static_cast<float>(n) : 1.0f;
  r.stats.poke_p95 = Percentile(r.poke, 0.95f);
  r.stats.poke_max = n ? *std::max_element(r.poke.begin(), r.poke.end()) : 0.0f;

  // Exposed surface: samples inside no other shape, measured to the skinned mesh.
  std::vector<Eigen::Vector3f> queries;
  std::vector<float> weights;
  std::vector<uint32_t> owner;
  std::vector<Eigen::Vector3f> pts;
  std::vector<float> areas;
  for (size_t s = 0; s < placed.size(); ++s) {
    colliders::SurfaceSamples(Cone(placed[s]), 96, &pts, &areas);
    for (size_t i = 0; i < pts.size(); ++i) {
      bool hidden = false;
      for (size_t o = 0; o < placed.size() && !hidden; ++o) {
        hidden = o != s && colliders::SignedDistance(Cone(placed[o]), pts[i]) < 0.0f;
      }
      if (hidden) continue;
      queries.push_back(pts[i]);
      weights.push_back(areas[i]);
      owner.push_back(static_cast<uint32_t>(s));
    }
  }
  std::vector<float> dist(queries.size(), 0.0f);
  if (!queries.empty() && !character.triangles.empty())
    MeshDistances(posed.vertices, character.triangles, queries, dist);
  r.area.assign(placed.size(), 0.0);
  r.area_distance.assign(placed.size(), 0.0);
  double total = 0.0, weighted = 0.0;
  for (size_t i = 0; i < queries.size(); ++i) {
    r.area[owner[i]] += weights[i];
    r.area_distance[owner[i]] += static_cast<double>(weights[i]) * dist[i];
    total += weights[i];
    weighted += static_cast<double>(weights[i]) * dist[i];
  }
  r.stats.surface_gap = total > 0.0 ? static_cast<float>(weighted / total) : 0.0f;
  return r;
}

}  // namespace

Result<PosedCharacter> PoseCharacter(const RawCharacter& character, std::span<const skinning::Transform> local) {
  const auto& skeleton = character.skeleton;
  if (local.size() != skeleton.size()) {
    return Error{ErrorCode::kInvalidArgument, "colliders: a pose has " + std::to_string(local.size()) +
                                                  " joint transforms, the skeleton " + std::to_string(skeleton.size())};
  }
  PosedCharacter out;
  out.joint_world.resize(skeleton.size());
  skinning::LocalToModelJob l2m;
  l2m.skeleton = &skeleton;
  l2m.input = local;
  l2m.output = out.joint_world;
  if (!l2m.Run()) return Error{ErrorCode::kInvalidArgument, "colliders: a pose could not be put together"};
  const auto& skin = character.skin;
  if (skin.vertex_count() != character.vertex_count()) {
    out.vertices = character.positions_rest;
    return out;
  }
  std::vector<Mat4f> skinning(skin.binds.size());
  for (size_t b = 0; b < skin.binds.size(); ++b) {
    skinning[b] = out.joint_world[static_cast<size_t>(skin.binds[b].joint)] * skin.binds[b].inverse_bind;
  }
  out.vertices.resize(skin.vertex_count());
  for (size_t v = 0; v < skin.vertex_count(); ++v) {
    const Eigen::Vector4f p = skin.positions_bind[v].homogeneous();
    Eigen::Vector4f acc = Eigen::Vector4f::Zero();
    for (uint32_t k = skin.influence_offsets[v]; k < skin.influence_offsets[v + 1]; ++k) {
      acc += skin.influence_weights[k] * (skinning[skin.influence_binds[k]] * p);
    }
    out.vertices[v] = acc.head<3>();
  }
  return out;
}

float ColliderDistance(const Eigen::Vector3f& p, const Eigen::Vector3f& head, float head_radius,
                       const Eigen::Vector3f& tail, float tail_radius) {
  return colliders::SignedDistance(colliders::RoundCone{head, tail, head_radius, tail_radius}, p);
}

PlacedCollider PlaceCollider(const Collider& c, const Mat4f& joint_world) {
  const Mat4f f = RigidFrame(joint_world);
  const Eigen::Matrix3f r = f.block<3, 3>(0, 0);
  const Eigen::Vector3f t = f.block<3, 1>(0, 3);
  return PlacedCollider{r * c.head + t, r * c.tail + t, c.head_radius, c.tail_radius};
}

Result<ColliderCoverage> EvaluateColliders(const RawCharacter& character,
                                           std::span<const std::vector<skinning::Transform>> poses,
                                           std::span<const Collider> colliders, float tolerance_share) {
  ColliderCoverage out;
  out.height = BodyHeight(character.positions_rest);
  out.tolerance = tolerance_share * out.height;
  for (const auto& c : colliders) {
    if (c.joint >= character.skeleton.size())
      return Error{ErrorCode::kInvalidArgument, "colliders: a collider's joint is out of range"};
  }
  // Poses in chunks (in parallel within one), folded into totals as they come: memory stays that of
  // one chunk whatever the number of poses. Percentiles come from histograms of 2e-5 of the height.
  const size_t n_shapes = colliders.size();
  PokeHistogram all_poke(out.height);
  std::vector<PokeHistogram> shape_poke(n_shapes, PokeHistogram(out.height));
  std::vector<size_t> shape_total(n_shapes, 0), shape_covered(n_shapes, 0);
  std::vector<double> area(n_shapes, 0.0), area_distance(n_shapes, 0.0), depth(n_shapes, 0.0);
  out.min_covered = poses.empty() ? 0.0f : 1.0f;
  double covered_sum = 0.0, standoff_sum = 0.0, gap_sum = 0.0;
  constexpr size_t kChunk = 32;
  for (size_t first = 0; first < poses.size(); first += kChunk) {
    const size_t count = std::min(kChunk, poses.size() - first);
    std::vector<PoseResult> results(count);
    std::vector<std::optional<Error>> errors(count);
    tbb::parallel_for(size_t{0}, count, [&](size_t k) {
      auto posed = PoseCharacter(character, poses[first + k]);
      if (!posed) {
        errors[k] = posed.error();
        return;
      }
      results[k] = EvaluatePose(character, *posed, colliders, out.tolerance);
    });
    for (auto& e : errors) {
      if (e) return *e;
    }
    for (const auto& r : results) {
      out.poses.push_back(r.stats);
      out.min_covered = std::min(out.min_covered, r.stats.covered);
      covered_sum += r.stats.covered;
      standoff_sum += r.stats.standoff;
      out.max_standoff = std::max(out.max_standoff, r.stats.standoff);
      gap_sum += r.stats.surface_gap;
      out.max_surface_gap = std::max(out.max_surface_gap, r.stats.surface_gap);
      for (size_t v = 0; v < r.nearest.size(); ++v) {
        const uint32_t sh = r.nearest[v];
        ++shape_total[sh];
        shape_covered[sh] += r.poke[v] <= out.tolerance ? 1 : 0;
        shape_poke[sh].Add(r.poke[v]);
        all_poke.Add(r.poke[v]);
        depth[sh] += r.depth[v];
      }
      for (size_t sh = 0; sh < n_shapes; ++sh) area[sh] += r.area[sh], area_distance[sh] += r.area_distance[sh];
    }
  }
  const double np = std::max<size_t>(poses.size(), 1);
  out.mean_covered = static_cast<float>(covered_sum / np);
  out.mean_standoff = static_cast<float>(standoff_sum / np);
  out.mean_surface_gap = static_cast<float>(gap_sum / np);
  out.poke_p95 = all_poke.Percentile(0.95);
  for (size_t s = 0; s < n_shapes; ++s) {
    ColliderShapeStats st;
    st.covered = shape_total[s] ? static_cast<float>(shape_covered[s]) / static_cast<float>(shape_total[s]) : 1.0f;
    st.poke_p95 = shape_poke[s].Percentile(0.95);
    st.standoff = shape_total[s] ? static_cast<float>(depth[s] / static_cast<double>(shape_total[s])) : 0.0f;
    st.surface_gap = area[s] > 0.0 ? static_cast<float>(area_distance[s] / area[s]) : 0.0f;
    out.shapes.push_back(st);
  }
  return out;
}

std::vector<Collider> PerBoneCapsules(const RawCharacter& character, int count, bool covering) {
  const auto& skeleton = character.skeleton;
  const size_t n = skeleton.size();
  std::vector<Mat4f> rest(n);
  skeleton.RestWorld(rest);
  std::vector<std::vector<uint32_t>> owned(n);
  const std::vector<uint32_t> dominant = colliders::DominantJoints(character);
  for (uint32_t v = 0; v < dominant.size(); ++v) owned[dominant[v]].push_back(v);
  std::vector<size_t> counts(n);
  for (size_t j = 0; j < n; ++j) counts[j] = owned[j].size();
  const std::vector<int32_t> child = colliders::HeaviestChildren(skeleton.parents, counts);
  std::vector<uint32_t> order;
  for (uint32_t j = 0; j < n; ++j) {
    if (!owned[j].empty()) order.push_back(j);
  }
  std::stable_sort(order.begin(), order.end(),
                   [&](uint32_t a, uint32_t b) { return owned[a].size() > owned[b].size(); });
  order.resize(std::min(order.size(), static_cast<size_t>(std::max(count, 0))));
  std::vector<Collider> out;
  for (uint32_t j : order) {
    const Mat4f f = RigidFrame(rest[j]);
    const Eigen::Vector3f a = f.block<3, 1>(0, 3);
    const Eigen::Vector3f b =
        child[j] >= 0 ? Eigen::Vector3f(rest[static_cast<size_t>(child[j])].block<3, 1>(0, 3)) : a;
    std::vector<float> d;
    for (uint32_t v : owned[j]) d.push_back(ColliderDistance(character.positions_rest[v], a, 0.0f, b, 0.0f));
    const float r = covering ? *std::max_element(d.begin(), d.end()) : Percentile(d, 0.5f);
    const Eigen::Matrix3f rt = f.block<3, 3>(0, 0).transpose();
    out.push_back(Collider{j, Eigen::Vector3f::Zero(), rt * (b - a), r, r, {}});
  }
  std::sort(out.begin(), out.end(), [](const Collider& x, const Collider& y) { return x.joint < y.joint; });
  return out;
}

}  // namespace skinspheres::lib
