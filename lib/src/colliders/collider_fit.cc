// FitColliders: one shape per group of vertices; groups start as the vertices each joint dominates,
// merge (a child group into its parent's) while over budget, and split while under it, each step
// the one that adds the least volume (or saves the most).
#include <tbb/parallel_for.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numeric>
#include <optional>

#include "colliders/joint_vertices.h"
#include "colliders/shape_fit.h"
#include "skinspheres/lib/colliders/colliders.h"
#include "skinspheres/lib/geometry/mesh_helpers.h"

namespace skinspheres::lib {

namespace {

using colliders::FitShape;
using colliders::ShapeFitResult;
using colliders::ShapeFitSettings;

struct Group {
  uint32_t joint = 0;
  std::vector<uint32_t> vertices;
  ShapeFitResult fit;
  bool alive = true;
};

// What every fit reads: the fit poses' skinned vertices and joint frames.
struct FitContext {
  const RawCharacter* character = nullptr;
  std::vector<PosedCharacter> poses;
  std::vector<std::vector<Mat4f>> frames;  // [pose][joint]: rigid frames
  std::vector<Eigen::Vector3f> hints;      // per joint: the bone's direction in its rigid frame at rest
  ShapeFitSettings shape;
};

std::vector<Eigen::Vector3f> Cloud(const FitContext& ctx, uint32_t joint, std::span<const uint32_t> vertices) {
  std::vector<Eigen::Vector3f> out;
  out.reserve(vertices.size() * ctx.poses.size());
  for (size_t p = 0; p < ctx.poses.size(); ++p) {
    const Mat4f& f = ctx.frames[p][joint];
    const Eigen::Matrix3f rt = f.block<3, 3>(0, 0).transpose();
    const Eigen::Vector3f t = f.block<3, 1>(0, 3);
    for (uint32_t v : vertices) out.push_back(rt * (ctx.poses[p].vertices[v] - t));
  }
  return out;
}

ShapeFitResult Fit(const FitContext& ctx, uint32_t joint, std::span<const uint32_t> vertices) {
  const std::vector<Eigen::Vector3f> cloud = Cloud(ctx, joint, vertices);
  return FitShape(cloud, ctx.hints[joint], ctx.shape);
}

// Per joint, the direction to the child joint with the most vertices below it, in the joint's
// rigid frame at rest (zero for a leaf).
std::vector<Eigen::Vector3f> BoneHints(const RawCharacter& c, const std::vector<uint32_t>& dominant,
                                       const std::vector<Mat4f>& rest_world) {
  const size_t n = c.skeleton.size();
  std::vector<size_t> owned(n, 0);
  for (uint32_t j : dominant) ++owned[j];
  const std::vector<int32_t> child = colliders::HeaviestChildren(c.skeleton.parents, owned);
  std::vector<Eigen::Vector3f> out(n, Eigen::Vector3f::Zero());
  for (size_t j = 0; j < n; ++j) {
    if (child[j] < 0) continue;
    const Mat4f f = RigidFrame(rest_world[j]);
    const Eigen::Vector3f d = rest_world[static_cast<size_t>(child[j])].block<3, 1>(0, 3) - f.block<3, 1>(0, 3);
    out[j] = f.block<3, 3>(0, 0).transpose() * d;
  }
  return out;
}

// The group a group merges into: the one holding its joint's nearest ancestor, else (a root group)
// the nearest by rest centroid.
int Partner(const FitContext& ctx, const std::vector<Group>& groups, size_t g) {
  std::map<uint32_t, int> group_of_joint;
  for (size_t i = 0; i < groups.size(); ++i) {
    if (groups[i].alive && i != g) group_of_joint.emplace(groups[i].joint, static_cast<int>(i));
  }
  const auto& parents = ctx.character->skeleton.parents;
  for (int32_t j = parents[groups[g].joint]; j >= 0; j = parents[static_cast<size_t>(j)]) {
    if (auto it = group_of_joint.find(static_cast<uint32_t>(j)); it != group_of_joint.end()) return it->second;
  }
  auto centroid = [&](const Group& gr) {
    Eigen::Vector3f s = Eigen::Vector3f::Zero();
    for (uint32_t v : gr.vertices) s += ctx.character->positions_rest[v];
    return Eigen::Vector3f(s / static_cast<float>(gr.vertices.size()));
  };
  int best = -1;
  float best_d = std::numeric_limits<float>::max();
  for (size_t i = 0; i < groups.size(); ++i) {
    if (!groups[i].alive || i == g) continue;
    const float d = (centroid(groups[i]) - centroid(groups[g])).norm();
    if (d < best_d) best_d = d, best = static_cast<int>(i);
  }
  return best;
}

std::vector<uint32_t> Union(const std::vector<uint32_t>& a, const std::vector<uint32_t>& b) {
  std::vector<uint32_t> out;
  std::merge(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(out));
  return out;
}

using MergeCache = std::map<std::pair<size_t, size_t>, ShapeFitResult>;
struct Merge {
  size_t g = 0, h = 0;  // g merges into h
  ShapeFitResult fit;
  double delta = std::numeric_limits<double>::infinity();  // volume added
};

// The merge that adds the least volume (delta infinite when none can merge).
Merge BestMerge(const FitContext& ctx, const std::vector<Group>& groups, MergeCache* cache) {
  std::vector<std::pair<size_t, size_t>> pairs;
  for (size_t g = 0; g < groups.size(); ++g) {
    if (!groups[g].alive) continue;
    const int h = Partner(ctx, groups, g);
    if (h >= 0) pairs.emplace_back(g, static_cast<size_t>(h));
  }
  std::vector<ShapeFitResult> fits(pairs.size());
  tbb::parallel_for(size_t{0}, pairs.size(), [&](size_t k) {
    const auto [g, h] = pairs[k];
    if (auto it = cache->find(pairs[k]); it != cache->end()) {
      fits[k] = it->second;
      return;
    }
    fits[k] = Fit(ctx, groups[h].joint, Union(groups[g].vertices, groups[h].vertices));
  });
  Merge best;
  for (size_t k = 0; k < pairs.size(); ++k) {
    (*cache)[pairs[k]] = fits[k];
    const auto [g, h] = pairs[k];
    const double delta = fits[k].cost - groups[g].fit.cost - groups[h].fit.cost;
    if (delta < best.delta) best = Merge{g, h, fits[k], delta};
  }
  return best;
}

void ApplyMerge(const Merge& m, std::vector<Group>* groups) {
  Group merged{(*groups)[m.h].joint, Union((*groups)[m.g].vertices, (*groups)[m.h].vertices), m.fit, true};
  (*groups)[m.g].alive = (*groups)[m.h].alive = false;
  groups->push_back(std::move(merged));
}

size_t Alive(const std::vector<Group>& groups) {
  return static_cast<size_t>(std::count_if(groups.begin(), groups.end(), [](const Group& g) { return g.alive; }));
}

// The two halves of a group split at the median along its rest cloud's first or second axis.
std::array<std::vector<uint32_t>, 2> Halves(const FitContext& ctx, const Group& g, int axis) {
  const Mat4f& f = ctx.frames[0][g.joint];
  std::vector<Eigen::Vector3f> pts;
  Eigen::Vector3f mean = Eigen::Vector3f::Zero();
  for (uint32_t v : g.vertices) {
    pts.push_back(f.block<3, 3>(0, 0).transpose() * (ctx.poses[0].vertices[v] - f.block<3, 1>(0, 3)));
    mean += pts.back();
  }
  mean /= static_cast<float>(pts.size());
  Eigen::Matrix3f cov = Eigen::Matrix3f::Zero();
  for (const auto& p : pts) cov += (p - mean) * (p - mean).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3f> eig(cov);
  const Eigen::Vector3f d = eig.eigenvectors().col(2 - axis);
  std::vector<std::pair<float, uint32_t>> order;
  for (size_t i = 0; i < pts.size(); ++i) order.emplace_back((pts[i] - mean).dot(d), g.vertices[i]);
  std::sort(order.begin(), order.end());
  std::array<std::vector<uint32_t>, 2> out;
  for (size_t i = 0; i < order.size(); ++i) out[i < order.size() / 2 ? 0 : 1].push_back(order[i].second);
  for (auto& h : out) std::sort(h.begin(), h.end());
  return out;
}

struct Split {
  std::array<Group, 2> halves;
  double gain = -1.0;  // volume saved
};
using SplitCache = std::map<size_t, Split>;

// The split that saves the most volume, among groups of at least 16 vertices: *group gets its
// index (the gain is negative when none saves).
const Split* BestSplit(const FitContext& ctx, const std::vector<Group>& groups, SplitCache* cache, size_t* group) {
  std::vector<size_t> todo;
  for (size_t g = 0; g < groups.size(); ++g) {
    if (groups[g].alive && !cache->count(g)) todo.push_back(g);
  }
  std::vector<Split> splits(todo.size());
  tbb::parallel_for(size_t{0}, todo.size(), [&](size_t k) {
    const Group& g = groups[todo[k]];
    if (g.vertices.size() < 16) return;
    for (int axis = 0; axis < 2; ++axis) {
      auto halves = Halves(ctx, g, axis);
      Split s;
      for (int i = 0; i < 2; ++i) s.halves[i] = Group{g.joint, halves[i], Fit(ctx, g.joint, halves[i]), true};
      s.gain = g.fit.cost - s.halves[0].fit.cost - s.halves[1].fit.cost;
      if (s.gain > splits[k].gain) splits[k] = std::move(s);
    }
  });
  for (size_t k = 0; k < todo.size(); ++k) (*cache)[todo[k]] = std::move(splits[k]);
  const Split* best = nullptr;
  for (size_t g = 0; g < groups.size(); ++g) {
    if (!groups[g].alive) continue;
    const Split& s = (*cache)[g];
    if (!best || s.gain > best->gain) best = &s, *group = g;
  }
  return best;
}

void ApplySplit(size_t g, const Split& s, std::vector<Group>* groups) {
  (*groups)[g].alive = false;
  for (const auto& h : s.halves) groups->push_back(h);
}

// Merges while over budget, splits while under it, then trades a merge for a split while the
// split saves more volume than the merge adds.
void ReachBudget(const FitContext& ctx, std::vector<Group>* groups, size_t budget) {
  MergeCache merges;
  SplitCache splits;
  while (Alive(*groups) > budget) {
    const Merge m = BestMerge(ctx, *groups, &merges);
    if (!std::isfinite(m.delta)) break;
    ApplyMerge(m, groups);
  }
  while (Alive(*groups) < budget) {
    size_t g = 0;
    const Split* s = BestSplit(ctx, *groups, &splits, &g);
    if (!s || !(s->gain > 0.01 * (*groups)[g].fit.cost)) break;
    ApplySplit(g, *s, groups);
  }
  for (size_t round = 0; round < 4 * budget; ++round) {
    size_t g = 0;
    const Split* s = BestSplit(ctx, *groups, &splits, &g);
    if (!s || !(s->gain > 0.0)) return;
    const Split split = *s;
    MergeCache scratch = merges;
    const Merge m = BestMerge(ctx, *groups, &scratch);
    merges = std::move(scratch);
    if (!std::isfinite(m.delta) || !(split.gain > 1.05 * m.delta + 1e-12) || m.g == g || m.h == g) return;
    ApplyMerge(m, groups);
    ApplySplit(g, split, groups);
  }
}

// Regroups the vertices of each joint holding several groups by k-means on their rest positions
// (the groups' centroids to start, ten rounds), refits, and keeps the result when the summed depth
// goes down: compact groups fit tighter than the halves of halves the splits made.
void Regroup(const FitContext& ctx, std::vector<Group>* groups) {
  std::map<uint32_t, std::vector<size_t>> by_joint;
  for (size_t g = 0; g < groups->size(); ++g) {
    if ((*groups)[g].alive) by_joint[(*groups)[g].joint].push_back(g);
  }
  for (const auto& [joint, members] : by_joint) {
    if (members.size() < 2) continue;
    const Mat4f& f = ctx.frames[0][joint];
    auto local = [&](uint32_t v) {
      return Eigen::Vector3f(f.block<3, 3>(0, 0).transpose() * (ctx.poses[0].vertices[v] - f.block<3, 1>(0, 3)));
    };
    std::vector<uint32_t> vertices;
    std::vector<Eigen::Vector3f> centres;
    for (size_t g : members) {
      Eigen::Vector3f c = Eigen::Vector3f::Zero();
      for (uint32_t v : (*groups)[g].vertices) c += local(v), vertices.push_back(v);
      centres.push_back(c / static_cast<float>((*groups)[g].vertices.size()));
    }
    std::sort(vertices.begin(), vertices.end());
    std::vector<size_t> label(vertices.size(), 0);
    for (int round = 0; round < 10; ++round) {
      for (size_t i = 0; i < vertices.size(); ++i) {
        const Eigen::Vector3f p = local(vertices[i]);
        for (size_t k = 1; k < centres.size(); ++k) {
          if ((p - centres[k]).squaredNorm() < (p - centres[label[i]]).squaredNorm()) label[i] = k;
        }
      }
      std::vector<Eigen::Vector3f> sum(centres.size(), Eigen::Vector3f::Zero());
      std::vector<size_t> count(centres.size(), 0);
      for (size_t i = 0; i < vertices.size(); ++i) sum[label[i]] += local(vertices[i]), ++count[label[i]];
      for (size_t k = 0; k < centres.size(); ++k) {
        if (count[k]) centres[k] = sum[k] / static_cast<float>(count[k]);
      }
    }
    std::vector<std::vector<uint32_t>> parts(centres.size());
    for (size_t i = 0; i < vertices.size(); ++i) parts[label[i]].push_back(vertices[i]);
    if (std::any_of(parts.begin(), parts.end(), [](const auto& p) { return p.empty(); })) continue;
    std::vector<ShapeFitResult> fits(parts.size());
    tbb::parallel_for(size_t{0}, parts.size(), [&, j = joint](size_t k) { fits[k] = Fit(ctx, j, parts[k]); });
    double before = 0.0, after = 0.0;
    for (size_t g : members) before += (*groups)[g].fit.cost;
    for (const auto& fit : fits) after += fit.cost;
    if (!(after < before)) continue;
    for (size_t k = 0; k < members.size(); ++k) {
      (*groups)[members[k]].vertices = std::move(parts[k]);
      (*groups)[members[k]].fit = fits[k];
    }
  }
}

}  // namespace

namespace colliders {

std::vector<uint32_t> DominantJoints(const RawCharacter& c) {
  std::vector<uint32_t> out(c.vertex_count(), 0);
  const auto& skin = c.skin;
  if (skin.vertex_count() != c.vertex_count()) return out;
  for (size_t v = 0; v < out.size(); ++v) {
    float best = -1.0f;
    for (uint32_t k = skin.influence_offsets[v]; k < skin.influence_offsets[v + 1]; ++k) {
      if (skin.influence_weights[k] > best) {
        best = skin.influence_weights[k];
        out[v] = static_cast<uint32_t>(skin.binds[skin.influence_binds[k]].joint);
      }
    }
  }
  return out;
}

std::vector<int32_t> HeaviestChildren(std::span<const int32_t> parents, std::span<const size_t> owned) {
  const size_t n = parents.size();
  std::vector<size_t> below(owned.begin(), owned.end());
  for (size_t j = n; j-- > 1;) {
    if (parents[j] >= 0) below[static_cast<size_t>(parents[j])] += below[j];
  }
  std::vector<int32_t> child(n, -1);
  for (size_t j = 0; j < n; ++j) {
    const int32_t p = parents[j];
    if (p >= 0 &&
        (child[static_cast<size_t>(p)] < 0 || below[j] > below[static_cast<size_t>(child[static_cast<size_t>(p)])])) {
      child[static_cast<size_t>(p)] = static_cast<int32_t>(j);
    }
  }
  return child;
}

}  // namespace colliders

Mat4f RigidFrame(const Mat4f& joint_world) {
  Mat4f out = joint_world;
  for (int c = 0; c < 3; ++c) {
    const float n = out.block<3, 1>(0, c).norm();
    if (n > 0.0f) out.block<3, 1>(0, c) /= n;
  }
  out.row(3) << 0.0f, 0.0f, 0.0f, 1.0f;
  return out;
}

Result<ColliderFit> FitColliders(const RawCharacter& character, std::span<const std::vector<skinning::Transform>> poses,
                                 std::span<const std::string> joint_part, const ColliderSettings& settings) {
  if (settings.budget < 1) return Error{ErrorCode::kInvalidArgument, "colliders: the budget must be at least 1"};
  if (character.vertex_count() == 0)
    return Error{ErrorCode::kInvalidArgument, "colliders: the character has no vertices"};
  FitContext ctx;
  ctx.character = &character;
  const float height = BodyHeight(character.positions_rest);
  ctx.shape.slack = settings.slack_share * settings.tolerance_share * height;
  ctx.shape.quantile = settings.covered_quantile;
  ctx.shape.allow_sphere = settings.shapes != ColliderShapes::kCapsules;
  ctx.shape.allow_capsule = settings.shapes != ColliderShapes::kSpheres;
  ctx.shape.tapered = settings.tapered;

  std::vector<std::vector<skinning::Transform>> chosen{character.skeleton.rest_local};
  const size_t room = static_cast<size_t>(std::max(settings.max_fit_poses - 1, 0));
  for (size_t k = 0; k < std::min(room, poses.size()); ++k)
    chosen.push_back(poses[k * poses.size() / std::min(room, poses.size())]);
  ctx.poses.resize(chosen.size());
  ctx.frames.resize(chosen.size());
  std::vector<std::optional<Error>> errors(chosen.size());
  tbb::parallel_for(size_t{0}, chosen.size(), [&](size_t p) {
    auto posed = PoseCharacter(character, chosen[p]);
    if (!posed) {
      errors[p] = posed.error();
      return;
    }
    ctx.poses[p] = std::move(*posed);
    for (const Mat4f& g : ctx.poses[p].joint_world) ctx.frames[p].push_back(RigidFrame(g));
  });
  for (auto& e : errors) {
    if (e) return *e;
  }
  const std::vector<uint32_t> dominant = colliders::DominantJoints(character);
  ctx.hints = BoneHints(character, dominant, ctx.poses[0].joint_world);

  std::vector<Group> groups;
  {
    std::map<uint32_t, std::vector<uint32_t>> by_joint;
    for (uint32_t v = 0; v < dominant.size(); ++v) by_joint[dominant[v]].push_back(v);
    for (auto& [j, vs] : by_joint) groups.push_back(Group{j, std::move(vs), {}, true});
  }
  tbb::parallel_for(size_t{0}, groups.size(),
                    [&](size_t g) { groups[g].fit = Fit(ctx, groups[g].joint, groups[g].vertices); });
  const size_t budget = static_cast<size_t>(settings.budget);
  ReachBudget(ctx, &groups, budget);
  Regroup(ctx, &groups);

  ColliderFit out;
  out.height = height;
  out.fit_poses = chosen.size();
  out.vertex_group.assign(character.vertex_count(), 0);
  for (const Group& g : groups) {
    if (!g.alive) continue;
    const auto& s = g.fit.shape;
    Collider c{g.joint, s.a, s.b, s.ra, s.rb, g.joint < joint_part.size() ? joint_part[g.joint] : std::string{}};
    if ((s.a - s.b).norm() <= std::abs(s.ra - s.rb)) {  // one ball holds the other: a sphere
      if (s.rb > s.ra) c.head = s.b, c.head_radius = s.rb;
      c.tail = c.head, c.tail_radius = c.head_radius;
    }
    for (uint32_t v : g.vertices) out.vertex_group[v] = static_cast<uint32_t>(out.colliders.size());
    out.colliders.push_back(std::move(c));
  }
  return out;
}

}  // namespace skinspheres::lib
