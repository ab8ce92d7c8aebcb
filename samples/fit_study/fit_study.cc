// fit_study: how far below the fitter's tightness figures other coverings get, on the same
// character and the same measuring tool (lib/metrics/fit_metrics.h). It backs the "where the tightness
// gap comes from" section of docs/FIT_REPORT.md; nothing in the product depends on it.
//
//   fit_study [FILE ...]      (no file: the built-in character)
//
// Rows, each measured by MeasureFit on the character's own rest mesh:
//   no tightening  FitSpheres without the tightening pass (the paper's spheres after ownership);
//   default        FitSpheres with default settings (what `skinspheres fit` writes);
//   max effort     the tightening pass splitting while anything pays (split gain 1, no target
//                  standoff), up to 300 spheres (the sphere budget of docs/FIT_REPORT.md);
//   subdivided     the mesh cut (longest-edge bisection) until no edge exceeds 1% of the body
//                  height, then fitted with max effort; its spheres are measured against the
//                  ORIGINAL mesh. It breaks the one-sphere-per-triangle rule (a source triangle
//                  may end up held only by several spheres: the "not in one sphere" column), so it
//                  is not a product option: it tells whether triangle size is what holds the fit back;
//   tri balls      one minimum ball per triangle (as many spheres as triangles): the coverings
//                  whose every sphere just holds its one triangle;
//   patches K      K surface patches (area-weighted k-means on triangle centroids, 10 Lloyd
//                  rounds from farthest-point seeds), one minimum ball per patch.
// Deterministic; one thread for the metrics, the fitter uses TBB as usual.
#include <algorithm>
#include <cstdio>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "skinspheres/lib/body_parts/body_parts.h"
#include "skinspheres/lib/character/builtin_character.h"
#include "skinspheres/lib/fit/sphere_fitter.h"
#include "skinspheres/lib/geometry/enclosing_sphere.h"
#include "skinspheres/lib/geometry/mesh_helpers.h"
#include "skinspheres/lib/io/importer.h"
#include "skinspheres/lib/metrics/fit_metrics.h"

namespace {

using skinspheres::lib::BodyParts;
using skinspheres::lib::RawCharacter;

struct Covering {
  std::vector<Eigen::Vector3f> centers;
  std::vector<float> radii;
};

void PrintRow(const RawCharacter& ch, const std::string& name, const Covering& cov, int samples_per_sphere) {
  skinspheres::lib::FitMetricsInput in;
  in.positions = ch.positions_rest;
  in.triangles = ch.triangles;
  in.centers = cov.centers;
  in.radii = cov.radii;
  skinspheres::lib::FitMetricsSettings settings;
  settings.samples_per_sphere = samples_per_sphere;
  auto m = skinspheres::lib::MeasureFit(in, settings);
  if (!m.ok()) {
    std::printf("| %-28s | measuring failed: %s |\n", name.c_str(), m.error().message.c_str());
    return;
  }
  std::printf("| %-28s | %7zu | %6.3f | %6.2f %% | %6.2f %% | %9zu |\n", name.c_str(), cov.centers.size(),
              m->volume_ratio, 100.0 * m->boundary_distance_mean_rel, 100.0 * m->boundary_distance_max_rel,
              m->uncovered_triangles);
}

Covering FromFit(const skinspheres::runtime::SphereSet& set) { return {set.centers_rest, set.radii_rest}; }

// Longest-edge bisection until every edge is at most max_edge. New vertices blend their edge's two
// endpoints (position, bind position, influences); each new triangle keeps its source triangle's
// part and dominant joint.
std::pair<RawCharacter, BodyParts> Subdivide(const RawCharacter& ch, const BodyParts& parts, float max_edge) {
  RawCharacter out = ch;
  auto& skin = out.skin;
  std::map<std::pair<int, int>, int> midpoints;
  auto midpoint = [&](int a, int b) {
    const auto key = std::minmax(a, b);
    if (auto it = midpoints.find(key); it != midpoints.end()) return it->second;
    const int v = static_cast<int>(out.positions_rest.size());
    out.positions_rest.push_back(0.5f * (out.positions_rest[a] + out.positions_rest[b]));
    skin.positions_bind.push_back(0.5f * (skin.positions_bind[a] + skin.positions_bind[b]));
    std::map<uint16_t, float> blend;
    for (int end : {a, b}) {
      for (uint32_t k = skin.influence_offsets[end]; k < skin.influence_offsets[end + 1]; ++k) {
        blend[skin.influence_binds[k]] += 0.5f * skin.influence_weights[k];
      }
    }
    for (const auto& [bind, w] : blend) {
      skin.influence_binds.push_back(bind);
      skin.influence_weights.push_back(w);
    }
    skin.influence_offsets.push_back(static_cast<uint32_t>(skin.influence_binds.size()));
    midpoints.emplace(key, v);
    return v;
  };
  std::vector<Eigen::Vector3i> triangles;
  std::vector<uint32_t> source;
  std::vector<std::pair<Eigen::Vector3i, uint32_t>> stack;
  for (size_t t = ch.triangles.size(); t-- > 0;) stack.push_back({ch.triangles[t], static_cast<uint32_t>(t)});
  while (!stack.empty()) {
    const auto [tri, t] = stack.back();
    stack.pop_back();
    int e = 0;
    float longest = -1.0f;
    for (int k = 0; k < 3; ++k) {
      const float len = (out.positions_rest[tri[k]] - out.positions_rest[tri[(k + 1) % 3]]).norm();
      if (len > longest) longest = len, e = k;
    }
    if (longest <= max_edge) {
      triangles.push_back(tri);
      source.push_back(t);
      continue;
    }
    const int a = tri[e], b = tri[(e + 1) % 3], c = tri[(e + 2) % 3], m = midpoint(a, b);
    stack.push_back({Eigen::Vector3i(m, b, c), t});
    stack.push_back({Eigen::Vector3i(a, m, c), t});
  }
  out.triangles = triangles;
  out.meshes = {skinspheres::lib::MeshRange{"subdivided", 0, static_cast<uint32_t>(out.positions_rest.size()), 0,
                                            static_cast<uint32_t>(triangles.size()), true, -1}};
  BodyParts sub = parts;
  sub.triangle_part.resize(triangles.size());
  sub.triangle_joint.resize(triangles.size());
  for (auto& p : sub.parts) p.triangles.clear();
  for (size_t t = 0; t < triangles.size(); ++t) {
    sub.triangle_part[t] = parts.triangle_part[source[t]];
    sub.triangle_joint[t] = parts.triangle_joint[source[t]];
    sub.parts[sub.triangle_part[t]].triangles.push_back(static_cast<uint32_t>(t));
  }
  return {std::move(out), std::move(sub)};
}

Covering TriangleBalls(const RawCharacter& ch) {
  Covering cov;
  for (const auto& tri : ch.triangles) {
    const Eigen::Vector3f p[3] = {ch.positions_rest[tri[0]], ch.positions_rest[tri[1]], ch.positions_rest[tri[2]]};
    const auto ball = skinspheres::lib::MinimumBall(p);
    cov.centers.push_back(ball.center);
    cov.radii.push_back(ball.radius);
  }
  return cov;
}

Covering Patches(const RawCharacter& ch, int k_patches) {
  const size_t n = ch.triangles.size();
  std::vector<Eigen::Vector3f> centroid(n);
  std::vector<float> area(n);
  for (size_t t = 0; t < n; ++t) {
    const auto& tri = ch.triangles[t];
    const Eigen::Vector3f &a = ch.positions_rest[tri[0]], &b = ch.positions_rest[tri[1]],
                          &c = ch.positions_rest[tri[2]];
    centroid[t] = (a + b + c) / 3.0f;
    area[t] = 0.5f * (b - a).cross(c - a).norm() + 1e-12f;
  }
  const size_t k_count = std::min(n, static_cast<size_t>(k_patches));
  std::vector<Eigen::Vector3f> seeds{centroid[0]};
  std::vector<float> d2(n, std::numeric_limits<float>::infinity());
  while (seeds.size() < k_count) {
    size_t far = 0;
    for (size_t t = 0; t < n; ++t) {
      d2[t] = std::min(d2[t], (centroid[t] - seeds.back()).squaredNorm());
      if (d2[t] > d2[far]) far = t;
    }
    seeds.push_back(centroid[far]);
  }
  std::vector<size_t> owner(n, 0);
  for (int round = 0; round < 10; ++round) {
    for (size_t t = 0; t < n; ++t) {
      float best = std::numeric_limits<float>::infinity();
      for (size_t k = 0; k < seeds.size(); ++k) {
        const float d = (centroid[t] - seeds[k]).squaredNorm();
        if (d < best) best = d, owner[t] = k;
      }
    }
    std::vector<Eigen::Vector3f> sum(seeds.size(), Eigen::Vector3f::Zero());
    std::vector<float> weight(seeds.size(), 0.0f);
    for (size_t t = 0; t < n; ++t) {
      sum[owner[t]] += area[t] * centroid[t];
      weight[owner[t]] += area[t];
    }
    for (size_t k = 0; k < seeds.size(); ++k) {
      if (weight[k] > 0.0f) seeds[k] = sum[k] / weight[k];
    }
  }
  std::vector<std::vector<Eigen::Vector3f>> points(seeds.size());
  for (size_t t = 0; t < n; ++t) {
    for (int v = 0; v < 3; ++v) points[owner[t]].push_back(ch.positions_rest[ch.triangles[t][v]]);
  }
  Covering cov;
  for (const auto& pts : points) {
    if (pts.empty()) continue;
    const auto ball = skinspheres::lib::MinimumBall(pts);
    cov.centers.push_back(ball.center);
    cov.radii.push_back(ball.radius);
  }
  return cov;
}

int Study(const std::string& file) {
  RawCharacter ch;
  if (file.empty()) {
    ch = skinspheres::lib::MakeBuiltinCharacter();
  } else {
    auto imported = skinspheres::lib::ImportCharacter(file);
    if (!imported.ok()) return std::fprintf(stderr, "fit_study: %s\n", imported.error().message.c_str()), 2;
    ch = std::move(imported).value();
  }
  auto parts = skinspheres::lib::SplitBodyParts(ch);
  if (!parts.ok()) return std::fprintf(stderr, "fit_study: %s\n", parts.error().message.c_str()), 2;
  std::printf("\n%s: %zu triangles, body height %.4g\n\n", file.empty() ? "built-in character" : file.c_str(),
              ch.triangle_count(), skinspheres::lib::BodyHeight(ch.positions_rest));
  std::printf(
      "| covering                     | spheres | union/body | boundary mean | boundary max | not in one sphere |\n");
  std::printf("|---|---|---|---|---|---|\n");
  skinspheres::lib::FitSettings settings;
  settings.tighten = false;
  auto fit = skinspheres::lib::FitSpheres(ch, *parts, settings);
  if (!fit.ok()) return std::fprintf(stderr, "fit_study: %s\n", fit.error().message.c_str()), 2;
  PrintRow(ch, "no tightening", FromFit(fit->spheres), 256);
  settings = {};
  fit = skinspheres::lib::FitSpheres(ch, *parts, settings);
  if (!fit.ok()) return std::fprintf(stderr, "fit_study: %s\n", fit.error().message.c_str()), 2;
  PrintRow(ch, "default", FromFit(fit->spheres), 256);
  settings.split_gain = 1.0f;
  settings.target_standoff = 0.0f;
  settings.max_spheres = 300;
  fit = skinspheres::lib::FitSpheres(ch, *parts, settings);
  if (!fit.ok()) return std::fprintf(stderr, "fit_study: %s\n", fit.error().message.c_str()), 2;
  PrintRow(ch, "max effort (300)", FromFit(fit->spheres), 256);
  {
    const auto [sub, sub_parts] = Subdivide(ch, *parts, 0.01f * skinspheres::lib::BodyHeight(ch.positions_rest));
    auto sub_fit = skinspheres::lib::FitSpheres(sub, sub_parts, settings);
    if (!sub_fit.ok()) return std::fprintf(stderr, "fit_study: %s\n", sub_fit.error().message.c_str()), 2;
    PrintRow(ch, "subdivided 1%, max effort", FromFit(sub_fit->spheres), 256);
  }
  PrintRow(ch, "tri balls", TriangleBalls(ch), 64);
  PrintRow(ch, "patches 100", Patches(ch, 100), 256);
  PrintRow(ch, "patches 300", Patches(ch, 300), 256);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  int status = 0;
  if (argc < 2) return Study("");
  for (int k = 1; k < argc; ++k) status = std::max(status, Study(argv[k]));
  return status;
}
