// The fitter: paper §4.1-4.4 and §5 per body part, then the ownership (safety) pass, exclusions
// and fast-refit data. See sphere_fitter.h for the stages.
#include "skinspheres/lib/fit/sphere_fitter.h"

#include <tbb/parallel_for.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>

#include "skinspheres/lib/fit/disk_traversal.h"
#include "skinspheres/lib/geometry/enclosing_sphere.h"
#include "skinspheres/lib/geometry/mesh_helpers.h"
#include "skinspheres/lib/geometry/triangle_bvh.h"
#include "skinspheres/lib/tighten/sphere_tightener.h"

namespace skinspheres::lib {

const char* ToString(SphereMethod method) {
  switch (method) {
    case SphereMethod::kM1: return "m1";
    case SphereMethod::kM2: return "m2";
    case SphereMethod::kM1A: return "m1a";
  }
  return "?";
}

std::string FitSettings::Validate() const {
  if (rays < 3 || rays > 65535) return "rays must be in 3..65535 (got " + std::to_string(rays) + ")";
  if (per_level != 1 && per_level != 2 && per_level != 4) return "per-level must be 1, 2 or 4 (got " + std::to_string(per_level) + ")";
  if (!(overlap >= 0.0f && overlap < 1.0f)) return "overlap (PD) must be in [0, 1) (got " + std::to_string(overlap) + ")";
  if (!(step >= 1e-4f && step <= 1.0f)) return "step must be in [0.0001, 1], a fraction of each part's length (got " + std::to_string(step) + ")";
  if (adjacent_hops < 0 || adjacent_hops > 2) return "adjacent hops must be 0, 1 or 2 (got " + std::to_string(adjacent_hops) + ")";
  if (refine_iterations < 0 || refine_iterations > 16) return "refine iterations must be in 0..16 (got " + std::to_string(refine_iterations) + ")";
  if (!(split_gain >= 0.0f && split_gain <= 1.0f)) return "split gain must be in [0, 1] (got " + std::to_string(split_gain) + ")";
  if (!(target_standoff >= 0.0f && target_standoff <= 1.0f)) {
    return "target standoff must be in [0, 1] (got " + std::to_string(target_standoff) + ")";
  }
  if (max_spheres < 1 || max_spheres > 8192) return "max spheres must be in 1..8192 (got " + std::to_string(max_spheres) + ")";
  return "";
}

std::string FitSettings::ToJson() const {
  nlohmann::json j = {{"rays", rays},
                      {"per_level", per_level},
                      {"per_level_all_parts", per_level_all_parts},
                      {"method", ToString(method)},
                      {"overlap", overlap},
                      {"step", step},
                      {"adjacent_hops", adjacent_hops},
                      {"exclude_bind_overlaps", exclude_bind_overlaps},
                      {"refine_iterations", refine_iterations},
                      {"tighten", tighten},
                      {"split_gain", split_gain},
                      {"max_spheres", max_spheres},
                      {"target_standoff", target_standoff}};
  return j.dump();
}

namespace {

// One sphere of a part before ownership.
struct CandidateSphere {
  Ball ball;        // as fitted by M1 / M2 / M1-A on its sector
  uint16_t level = 0;
  FitErrorStats f;  // the paper's F on its sector's contact points
  int points = 0;
};

struct PartResult {
  std::vector<CandidateSphere> spheres;
  PartFitReport report;
  Error error;
};

Ball MakeBall(SphereMethod method, std::span<const Eigen::Vector3f> pts, const Eigen::Vector3f& disk_center,
              const Eigen::Vector3f& n0, const Eigen::Vector3f& n1) {
  switch (method) {
    case SphereMethod::kM1: return CentroidBall(pts);
    case SphereMethod::kM2: return MinimumBall(pts);
    case SphereMethod::kM1A: return AdjustM1(CentroidBall(pts), pts, disk_center, n0, n1);
  }
  return CentroidBall(pts);
}

// §4.2-4.3: the spheres of one disk level, its contact points split into p contiguous angular
// sectors of rays. Sectors are centred on the principal axes of the section (in the disk plane),
// so p = 2 cuts an ellipse across its long axis and p = 4 gives one sphere per side.
std::vector<CandidateSphere> LevelSpheres(const DiskLevel& level, int rays, int p, SphereMethod method) {
  std::vector<CandidateSphere> out;
  if (level.contacts.size() < 2) return out;
  Eigen::Vector3f mean = Eigen::Vector3f::Zero();
  for (const auto& c : level.contacts) mean += c.point;
  mean /= static_cast<float>(level.contacts.size());  // *.c of this level (Disk Centered)
  const double two_pi = 2.0 * std::numbers::pi;
  double theta = 0.0;
  if (p > 1) {
    Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
    for (const auto& c : level.contacts) {
      const Eigen::Vector3f d = c.point - mean;
      const Eigen::Vector2d q(d.dot(level.n0), d.dot(level.n1));
      cov += q * q.transpose();
    }
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(cov);
    const Eigen::Vector2d major = eig.eigenvectors().col(1);
    theta = std::atan2(major.y(), major.x());
  }
  const double alpha = two_pi / rays;  // α
  const double width = two_pi / p;
  std::vector<std::vector<Eigen::Vector3f>> sectors(p);
  for (const auto& c : level.contacts) {
    double phi = c.ray * alpha - theta + width / 2.0;
    phi -= two_pi * std::floor(phi / two_pi);
    const int k = std::min(p - 1, static_cast<int>(phi / width));
    sectors[k].push_back(c.point);
  }
  for (const auto& pts : sectors) {
    if (pts.empty()) continue;
    CandidateSphere s;
    s.ball = MakeBall(method, pts, mean, level.n0, level.n1);
    s.f = FitError(s.ball, pts);
    s.points = static_cast<int>(pts.size());
    out.push_back(s);
  }
  return out;
}

float MeanRadius(const std::vector<CandidateSphere>& spheres) {
  float r = 0.0f;
  for (const auto& s : spheres) r += s.ball.radius;
  return spheres.empty() ? 0.0f : r / static_cast<float>(spheres.size());
}

PartResult FitPart(const RawCharacter& ch, const BodyPart& part, const std::vector<Mat4f>& rest_world,
                   const FitSettings& settings) {
  PartResult result;
  result.report.name = part.name;
  result.report.triangles = static_cast<int>(part.triangles.size());
  if (part.triangles.empty()) return result;

  const std::vector<Eigen::Vector3f> verts =
      UniqueVertices(ch.triangles, ch.vertex_count()).Positions(ch.positions_rest, part.triangles);
  std::vector<Eigen::Vector3f> chain;
  for (int32_t j : part.chain) chain.push_back(rest_world[j].topRightCorner<3, 1>());
  const DiskPath path = BuildDiskPath(chain, verts);

  std::vector<int32_t> subset(part.triangles.begin(), part.triangles.end());
  auto bvh = TriangleBvh::Build(ch.positions_rest, ch.triangles, subset);
  if (!bvh.ok()) {
    result.error = bvh.error();
    return result;
  }
  Eigen::Vector3f lo = verts[0], hi = verts[0];
  for (const auto& v : verts) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  DiskSettings disk;
  disk.rays = settings.rays;
  disk.step = std::max(settings.step * path.length(), 1e-6f * (hi - lo).norm());  // δ
  disk.ray_length = 2.0f * (hi - lo).norm() + 1e-6f;
  const std::vector<DiskLevel> levels = TraverseDisk(*bvh, path, disk);

  const bool tubular = part.kind != PartKind::kTorso;
  const int p = (tubular && !settings.per_level_all_parts) ? 1 : settings.per_level;
  result.report.levels_traversed = static_cast<int>(levels.size());

  // §4.3: keep a level when it overlaps the last kept one by at most PD.
  std::vector<CandidateSphere> last_spheres;
  float last_s = 0.0f;
  bool have_last = false;
  std::vector<CandidateSphere> pending;  // the latest level not kept, kept if the path ends
  float pending_s = 0.0f;
  uint16_t level_index = 0;
  double f_sum = 0.0;
  int f_count = 0;
  auto keep = [&](std::vector<CandidateSphere> spheres, float s) {
    for (auto& sp : spheres) {
      sp.level = level_index;
      result.spheres.push_back(sp);
      f_sum += static_cast<double>(sp.f.mean) * sp.points;
      f_count += sp.points;
      result.report.f_max = std::max(result.report.f_max, sp.f.max);
    }
    ++level_index;
    last_spheres = std::move(spheres);
    last_s = s;
    have_last = true;
    pending.clear();
  };
  for (const auto& level : levels) {
    result.report.rays_cast += settings.rays;
    result.report.rays_hit += static_cast<int>(level.contacts.size());
    std::vector<CandidateSphere> spheres = LevelSpheres(level, settings.rays, p, settings.method);
    if (spheres.empty()) continue;
    const float d = level.s - last_s;
    if (!have_last || d >= (1.0f - settings.overlap) * (MeanRadius(last_spheres) + MeanRadius(spheres))) {
      keep(std::move(spheres), level.s);
    } else {
      pending = std::move(spheres);
      pending_s = level.s;
    }
  }
  if (!pending.empty()) keep(std::move(pending), pending_s);  // the end of the path is always covered
  if (result.spheres.empty()) {
    // No ray met the part (a sliver, a flat patch in the disk plane): one sphere holds it all.
    CandidateSphere s;
    s.ball = MinimumBall(verts);
    result.spheres.push_back(s);
  }
  result.report.levels_kept = level_index;
  result.report.f_mean = f_count ? static_cast<float>(f_sum / f_count) : 0.0f;
  return result;
}

// Skeleton distance (bones) between every pair of joints.
std::vector<std::vector<int>> JointHops(const std::vector<int32_t>& parents) {
  const size_t n = parents.size();
  std::vector<std::vector<int>> adj(n);
  for (size_t j = 0; j < n; ++j) {
    if (parents[j] >= 0) {
      adj[j].push_back(parents[j]);
      adj[parents[j]].push_back(static_cast<int>(j));
    }
  }
  std::vector<std::vector<int>> hops(n, std::vector<int>(n, std::numeric_limits<int>::max()));
  std::vector<int> queue;
  for (size_t s = 0; s < n; ++s) {
    hops[s][s] = 0;
    queue.assign(1, static_cast<int>(s));
    for (size_t head = 0; head < queue.size(); ++head) {
      const int u = queue[head];
      for (int v : adj[u]) {
        if (hops[s][v] == std::numeric_limits<int>::max()) {
          hops[s][v] = hops[s][u] + 1;
          queue.push_back(v);
        }
      }
    }
  }
  return hops;
}


}  // namespace

int CountUncoveredTriangles(const RawCharacter& ch, const runtime::SphereSet& set, int* first_bad) {
  std::vector<int32_t> owner(ch.triangle_count(), -1);
  for (size_t s = 0; s < set.size(); ++s) {
    for (uint32_t k = set.triangle_offsets[s]; k < set.triangle_offsets[s + 1]; ++k) {
      if (set.triangles[k] < owner.size()) owner[set.triangles[k]] = static_cast<int32_t>(s);
    }
  }
  int bad = 0;
  for (size_t t = 0; t < owner.size(); ++t) {
    bool inside = owner[t] >= 0;
    if (inside) {
      const Eigen::Vector3d c = set.centers_rest[owner[t]].cast<double>();
      const double r = set.radii_rest[owner[t]] * (1.0 + 1e-6);
      for (int k = 0; k < 3 && inside; ++k) {
        inside = (ch.positions_rest[ch.triangles[t][k]].cast<double>() - c).norm() <= r;
      }
    }
    if (!inside) {
      if (bad == 0 && first_bad) *first_bad = static_cast<int>(t);
      ++bad;
    }
  }
  return bad;
}

Result<FitResult> FitSpheres(const RawCharacter& ch, const BodyParts& parts, const FitSettings& settings) {
  const auto start = std::chrono::steady_clock::now();
  const std::string name = ch.source_file.empty() ? std::string("<character>") : ch.source_file;
  if (std::string why = settings.Validate(); !why.empty()) {
    return MakeError(ErrorCode::kInvalidArgument, "fit settings: " + why);
  }
  const size_t joints = ch.skeleton.size();
  if (!ch.skeleton.Validate() || joints == 0) return MakeError(ErrorCode::kInvalidData, name + ": invalid skeleton");
  if (parts.triangle_part.size() != ch.triangle_count() || parts.triangle_joint.size() != ch.triangle_count()) {
    return MakeError(ErrorCode::kInvalidData, name + ": body parts were made for another mesh");
  }
  for (const auto& tri : ch.triangles) {
    if ((tri.array() < 0).any() || (tri.array() >= static_cast<int>(ch.vertex_count())).any()) {
      return MakeError(ErrorCode::kInvalidData, name + ": a triangle index is out of range");
    }
  }
  // The sphere-set format refuses coordinates beyond 1e18 (runtime/sphere_set.h); say so up front
  // rather than after fitting (squared distances of such spreads overflow float).
  for (size_t v = 0; v < ch.vertex_count(); ++v) {
    const Eigen::Vector3f& p = ch.positions_rest[v];
    if (!p.allFinite() || p.cwiseAbs().maxCoeff() > 1e18f) {
      return MakeError(ErrorCode::kInvalidData, name + ": vertex " + std::to_string(v) +
                                                    " is not finite or lies beyond 1e18 units; nothing can be fitted");
    }
  }
  // The parts must partition the triangles and name joints that exist (parts run in parallel:
  // a triangle in two parts would make the result depend on the threads).
  for (size_t t = 0; t < ch.triangle_count(); ++t) {
    if (parts.triangle_joint[t] < 0 || parts.triangle_joint[t] >= static_cast<int32_t>(joints)) {
      return MakeError(ErrorCode::kInvalidData, name + ": body parts give triangle " + std::to_string(t) + " no valid joint");
    }
  }
  for (size_t k = 0; k < parts.parts.size(); ++k) {
    for (uint32_t t : parts.parts[k].triangles) {
      if (t >= ch.triangle_count() || parts.triangle_part[t] != static_cast<int32_t>(k)) {
        return MakeError(ErrorCode::kInvalidData, name + ": body part " + parts.parts[k].name + " lists triangle " +
                                                      std::to_string(t) + " that is not its own");
      }
    }
    for (int32_t j : parts.parts[k].chain) {
      if (j < 0 || j >= static_cast<int32_t>(joints)) {
        return MakeError(ErrorCode::kInvalidData, name + ": body part " + parts.parts[k].name + " names joint " + std::to_string(j));
      }
    }
  }
  std::vector<Mat4f> rest_world(joints);
  ch.skeleton.RestWorld(rest_world);

  // 1-3: the paper's spheres, part by part (in parallel; each part writes its own slot).
  std::vector<PartResult> fitted(parts.parts.size());
  tbb::parallel_for(size_t{0}, parts.parts.size(), [&](size_t k) {
    fitted[k] = FitPart(ch, parts.parts[k], rest_world, settings);
  });
  for (const auto& f : fitted) {
    if (f.error.code != ErrorCode::kOk) return MakeError(f.error.code, name + ": " + f.error.message);
  }

  // 4: ownership. Each triangle goes to the sphere of its part whose centre is nearest to its
  // farthest vertex (the sphere that holds it with the smallest radius; ties: lowest index).
  std::vector<uint32_t> part_first(parts.parts.size() + 1, 0);
  std::vector<CandidateSphere> cand;
  std::vector<uint16_t> cand_part;
  for (size_t k = 0; k < fitted.size(); ++k) {
    part_first[k] = static_cast<uint32_t>(cand.size());
    for (const auto& s : fitted[k].spheres) {
      cand.push_back(s);
      cand_part.push_back(static_cast<uint16_t>(k));
    }
  }
  part_first[fitted.size()] = static_cast<uint32_t>(cand.size());
  // Ownership, then (refine_iterations times) each sphere is replaced by the minimum ball of the
  // vertices it owns and ownership is redone against the new spheres (a Lloyd-style pass).
  std::vector<int32_t> owner(ch.triangle_count(), -1);
  UniqueVertices unique(ch.triangles, ch.vertex_count());
  std::vector<Ball> balls(cand.size());
  for (size_t s = 0; s < cand.size(); ++s) balls[s] = cand[s].ball;
  auto assign = [&] {
    tbb::parallel_for(size_t{0}, parts.parts.size(), [&](size_t k) {
      for (uint32_t t : parts.parts[k].triangles) {
        const Eigen::Vector3f& p0 = ch.positions_rest[ch.triangles[t][0]];
        const Eigen::Vector3f& p1 = ch.positions_rest[ch.triangles[t][1]];
        const Eigen::Vector3f& p2 = ch.positions_rest[ch.triangles[t][2]];
        float best = std::numeric_limits<float>::infinity();
        int32_t best_s = -1;
        for (uint32_t s = part_first[k]; s < part_first[k + 1]; ++s) {
          const Ball& b = balls[s];
          if (b.radius < 0.0f) continue;  // dropped
          // max_v |p_v - c| with one sqrt: sqrt is monotonic and correctly rounded, so this is
          // bit-identical to the max of the three norms.
          const float need = std::sqrt(std::max({(p0 - b.center).squaredNorm(), (p1 - b.center).squaredNorm(),
                                                 (p2 - b.center).squaredNorm()}));
          if (need < best) {
            best = need;
            best_s = static_cast<int32_t>(s);
          }
        }
        owner[t] = best_s;
      }
    });
  };
  assign();
  for (int round = 0; round < settings.refine_iterations; ++round) {
    // Each sphere's owned vertices, once each (a closed mesh lists a vertex in ~6 triangles, so
    // MinimumBall sees ~6x fewer points; the minimum ball of a set does not depend on repeats).
    // Triangles grouped by owner (counting sort, ascending t), then a stamp per vertex.
    std::vector<uint32_t> first(cand.size() + 1, 0);
    for (int32_t o : owner) {
      if (o >= 0) ++first[o + 1];
    }
    for (size_t s = 0; s < cand.size(); ++s) first[s + 1] += first[s];
    std::vector<uint32_t> by_owner(first.back()), fill(first.begin(), first.end() - 1);
    for (size_t t = 0; t < owner.size(); ++t) {
      if (owner[t] >= 0) by_owner[fill[owner[t]]++] = static_cast<uint32_t>(t);
    }
    std::vector<std::vector<Eigen::Vector3f>> pts(cand.size());
    for (size_t s = 0; s < cand.size(); ++s) {
      pts[s] = unique.Positions(ch.positions_rest, std::span(by_owner).subspan(first[s], first[s + 1] - first[s]));
    }
    tbb::parallel_for(size_t{0}, cand.size(), [&](size_t s) {
      if (pts[s].empty()) {
        balls[s].radius = -1.0f;  // owns nothing: out of the next assignment
      } else {
        balls[s] = MinimumBall(pts[s]);
      }
    });
    assign();
  }
  for (size_t s = 0; s < cand.size(); ++s) {
    if (balls[s].radius >= 0.0f) cand[s].ball.center = balls[s].center;  // radius: see below
  }
  std::vector<std::vector<uint32_t>> owned(cand.size());
  for (size_t t = 0; t < owner.size(); ++t) {
    if (owner[t] < 0) return MakeError(ErrorCode::kInvalidData, name + ": triangle " + std::to_string(t) + " belongs to no part");
    owned[owner[t]].push_back(static_cast<uint32_t>(t));
  }
  if (settings.refine_iterations > 0) {
    // The last refine round reassigned triangles after moving the spheres: centre each sphere
    // once more on the minimum ball of what it now owns (its radius stays the paper's, for the
    // growth report), its vertices in ascending index order.
    std::vector<std::vector<Eigen::Vector3f>> pts(cand.size());
    for (size_t s = 0; s < cand.size(); ++s) {
      std::vector<uint32_t> ids = unique.Indices(owned[s]);
      std::sort(ids.begin(), ids.end());
      pts[s].reserve(ids.size());
      for (uint32_t v : ids) pts[s].push_back(ch.positions_rest[v]);
    }
    tbb::parallel_for(size_t{0}, cand.size(), [&](size_t s) {
      if (!owned[s].empty()) cand[s].ball.center = MinimumBall(pts[s]).center;
    });
  }
  // Beyond the paper (tightness): centre search, hand-over and splitting (sphere_tightener.h).
  int dropped_before_tighten = 0;
  TightenReport tighten_report;
  if (settings.tighten) {
    std::vector<TightSphere> tight;
    for (size_t s = 0; s < cand.size(); ++s) {
      if (owned[s].empty()) {
        ++dropped_before_tighten;
        continue;
      }
      TightSphere t;
      t.center = cand[s].ball.center;
      t.reference_radius = cand[s].ball.radius;
      t.part = cand_part[s];
      t.origin = static_cast<uint32_t>(s);
      t.triangles = std::move(owned[s]);
      tight.push_back(std::move(t));
    }
    TightenSettings ts;
    ts.max_spheres = settings.max_spheres;
    ts.split_gain = settings.split_gain;
    ts.target_standoff = settings.target_standoff;
    tighten_report = TightenSpheres(ch, ts, &tight);
    std::vector<CandidateSphere> next;
    std::vector<uint16_t> next_part;
    owned.clear();
    for (auto& t : tight) {
      CandidateSphere c = cand[t.origin];
      c.ball.center = t.center;
      c.ball.radius = t.reference_radius;
      next.push_back(c);
      next_part.push_back(t.part);
      owned.push_back(std::move(t.triangles));
    }
    cand = std::move(next);
    cand_part = std::move(next_part);
  }

  FitResult out;
  runtime::SphereSet& set = out.spheres;
  FitReport& rep = out.report;
  rep.spheres_dropped = dropped_before_tighten + tighten_report.dropped;
  rep.spheres_split = tighten_report.splits;
  rep.triangles_handed_over = tighten_report.triangles_handed_over;
  rep.spheres_merged = tighten_report.merges;
  rep.standoff_before = static_cast<float>(tighten_report.standoff_before);
  rep.standoff_after = static_cast<float>(tighten_report.standoff_after);
  set.source_file = ch.source_file;
  set.source_vertex_count = static_cast<uint32_t>(ch.vertex_count());
  set.source_triangle_count = static_cast<uint32_t>(ch.triangle_count());
  set.params_json = settings.ToJson();
  set.joint_names = ch.skeleton.joint_names;
  set.joint_parents = ch.skeleton.parents;
  set.joint_rest_world = rest_world;
  for (const auto& p : parts.parts) {
    runtime::SpherePart sp;
    sp.name = p.name;
    for (int32_t j : p.joints) {
      if (j >= 0) sp.joints.push_back(static_cast<uint32_t>(j));
    }
    set.parts.push_back(std::move(sp));
  }
  rep.body_height = BodyHeight(ch.positions_rest);
  const float height = rep.body_height > 0.0f ? rep.body_height : 1.0f;

  // M_b(rest) = G_joint(b)(rest) · IBM_b: where each bind entry carries a bind-space vertex at rest.
  std::vector<Eigen::Matrix4d> bind_rest(ch.skin.binds.size());
  for (size_t b = 0; b < ch.skin.binds.size(); ++b) {
    bind_rest[b] = (rest_world[ch.skin.binds[b].joint] * ch.skin.binds[b].inverse_bind).cast<double>();
  }
  const bool have_skin = ch.skin.influence_offsets.size() == ch.vertex_count() + 1;
  // The mesh itself (sphere-set version 2), for triangle-level tests and per-vertex skinning at run
  // time: the file's skin as imported, and the triangles in file order.
  if (have_skin && ch.triangle_count() > 0) {
    set.mesh = ch.skin;
    set.triangle_vertices.reserve(3 * ch.triangle_count());
    for (const Eigen::Vector3i& t : ch.triangles) {
      for (int c = 0; c < 3; ++c) set.triangle_vertices.push_back(static_cast<uint32_t>(t[c]));
    }
  }

  set.vertex_offsets = {0};
  set.triangle_offsets = {0};
  set.influence_offsets = {0};
  double growth_sum = 0.0;
  std::vector<double> joint_weight(joints, 0.0);
  std::vector<int> joint_tris(joints, 0);
  for (size_t s = 0; s < cand.size(); ++s) {
    if (owned[s].empty()) {
      ++rep.spheres_dropped;
      continue;
    }
    const Eigen::Vector3f c = cand[s].ball.center;
    std::vector<uint32_t> vlist = unique.Indices(owned[s]);
    std::sort(vlist.begin(), vlist.end());
    double max_sq = 0.0;
    for (uint32_t v : vlist) max_sq = std::max(max_sq, (ch.positions_rest[v].cast<double>() - c.cast<double>()).squaredNorm());
    const float radius = HoldingRadius(max_sq);
    const float fit_r = cand[s].ball.radius;
    if (radius > fit_r * (1.0f + 1e-5f)) {
      ++rep.spheres_grown;
      const float g = (radius - fit_r) / height;
      rep.growth_max = std::max(rep.growth_max, g);
      growth_sum += g;
    } else if (radius < fit_r * (1.0f - 1e-5f)) {
      ++rep.spheres_shrunk;
    }
    // Dominant joint: the joint owning most of its triangles (ties: lowest index).
    for (uint32_t t : owned[s]) ++joint_tris[parts.triangle_joint[t]];
    int dom = 0;
    for (size_t j = 0; j < joints; ++j) {
      if (joint_tris[j] > joint_tris[dom]) dom = static_cast<int>(j);
    }
    for (uint32_t t : owned[s]) joint_tris[parts.triangle_joint[t]] = 0;

    // 6: fast-refit data. Joints influencing the source vertices (mean weights) and the radius
    // holding every rest copy M_b(rest)·p_bind of every source vertex for each of its entries.
    double fast_sq = max_sq;
    if (have_skin) {
      for (uint32_t v : vlist) {
        const Eigen::Vector4d pb(ch.skin.positions_bind[v].x(), ch.skin.positions_bind[v].y(), ch.skin.positions_bind[v].z(), 1.0);
        for (uint32_t k = ch.skin.influence_offsets[v]; k < ch.skin.influence_offsets[v + 1]; ++k) {
          const uint16_t b = ch.skin.influence_binds[k];
          joint_weight[ch.skin.binds[b].joint] += ch.skin.influence_weights[k];
          const Eigen::Vector3d copy = (bind_rest[b] * pb).head<3>();
          fast_sq = std::max(fast_sq, (copy - c.cast<double>()).squaredNorm());
        }
      }
    }
    double wsum = 0.0;
    for (size_t j = 0; j < joints; ++j) wsum += joint_weight[j];
    if (wsum <= 0.0) {
      joint_weight[dom] = 1.0;
      wsum = 1.0;
    }
    for (size_t j = 0; j < joints; ++j) {
      if (joint_weight[j] > 0.0) {
        set.influence_joints.push_back(static_cast<uint16_t>(j));
        set.influence_weights.push_back(static_cast<float>(joint_weight[j] / wsum));
        joint_weight[j] = 0.0;
      }
    }
    set.influence_offsets.push_back(static_cast<uint32_t>(set.influence_joints.size()));

    set.centers_rest.push_back(c);
    set.radii_rest.push_back(radius);
    set.radii_fast.push_back(std::max(radius, HoldingRadius(fast_sq)));
    set.sphere_part.push_back(cand_part[s]);
    set.sphere_joint.push_back(static_cast<uint16_t>(dom));
    set.sphere_level.push_back(cand[s].level);
    set.vertices.insert(set.vertices.end(), vlist.begin(), vlist.end());
    set.vertex_offsets.push_back(static_cast<uint32_t>(set.vertices.size()));
    set.triangles.insert(set.triangles.end(), owned[s].begin(), owned[s].end());
    set.triangle_offsets.push_back(static_cast<uint32_t>(set.triangles.size()));
  }
  rep.growth_mean = rep.spheres_grown ? static_cast<float>(growth_sum / rep.spheres_grown) : 0.0f;

  // 5: excluded pairs.
  const auto hops = JointHops(ch.skeleton.parents);
  for (uint32_t i = 0; i < set.size(); ++i) {
    for (uint32_t j = i + 1; j < set.size(); ++j) {
      const int a = set.sphere_joint[i], b = set.sphere_joint[j];
      std::optional<runtime::ExclusionReason> reason;
      if (a == b) {
        reason = runtime::ExclusionReason::kSameJoint;
      } else if (hops[a][b] <= settings.adjacent_hops) {
        reason = runtime::ExclusionReason::kAdjacentJoints;
      } else if (settings.exclude_bind_overlaps &&
                 (set.centers_rest[i] - set.centers_rest[j]).norm() < set.radii_rest[i] + set.radii_rest[j]) {
        reason = runtime::ExclusionReason::kBindOverlap;
      }
      if (reason) set.excluded_pairs.push_back({i, j, *reason});
    }
  }

  // Report.
  double f_sum = 0.0;
  int f_n = 0;
  for (auto& f : fitted) {
    f.report.spheres = 0;
    rep.f_max = std::max(rep.f_max, f.report.f_max);
    f_sum += static_cast<double>(f.report.f_mean) * f.report.rays_hit;
    f_n += f.report.rays_hit;
    rep.parts.push_back(f.report);
  }
  for (size_t s = 0; s < set.size(); ++s) ++rep.parts[set.sphere_part[s]].spheres;
  rep.f_mean = f_n ? static_cast<float>(f_sum / f_n) : 0.0f;

  if (auto err = set.Validate()) return MakeError(ErrorCode::kInvalidData, name + ": fitted set is inconsistent: " + err->message);
  int first_bad = -1;
  const int uncovered = CountUncoveredTriangles(ch, set, &first_bad);
  if (uncovered) {
    return MakeError(ErrorCode::kCheckFailed, name + ": bind-pose check failed: " + std::to_string(uncovered) +
                                                  " triangles outside their sphere (first: " + std::to_string(first_bad) + ")");
  }
  rep.triangles_covered = static_cast<int>(ch.triangle_count());
  rep.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace skinspheres::lib
