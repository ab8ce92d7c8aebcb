// Benchmarks of the fitter's geometric kernels: BVH build and disk-ray casting on a ~50k-triangle
// closed ellipsoid (Xbot-sized), and the enclosing-sphere methods M1, M2, M1-A on 40 points.
#include <benchmark/benchmark.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "shapes/uv_sphere.h"
#include "skinspheres/lib/geometry/enclosing_sphere.h"
#include "skinspheres/lib/geometry/triangle_bvh.h"

namespace {

using V = Eigen::Vector3f;
using skinspheres::lib::TriangleBvh;

using Mesh = skinspheres::test::TriangleMesh;

const Mesh& BigMesh() {
  // A closed UV ellipsoid (semi-axes 0.2, 0.15, 0.9: torso-like), 2·160·159 = 50,880 triangles.
  static const Mesh m = skinspheres::test::UvEllipsoid(V::Zero(), V(0.2f, 0.15f, 0.9f), 160, 160);
  return m;
}

void BM_BvhBuild(benchmark::State& state) {
  const Mesh& m = BigMesh();
  for (auto _ : state) {
    auto bvh = TriangleBvh::Build(m.positions, m.triangles);
    benchmark::DoNotOptimize(bvh);
  }
  state.counters["triangles"] = static_cast<double>(m.triangles.size());
}
BENCHMARK(BM_BvhBuild)->Unit(benchmark::kMillisecond);

// Disk rays (paper §4.1: Nr = 80, α = 4.5°) from the axis at 300 levels along γ = z.
void BM_DiskRays(benchmark::State& state) {
  const Mesh& m = BigMesh();
  const TriangleBvh bvh = *TriangleBvh::Build(m.positions, m.triangles);
  constexpr int kRays = 80, kLevels = 300;
  int64_t hits = 0;
  for (auto _ : state) {
    for (int h = 0; h < kLevels; ++h) {
      const V c(0.01f, -0.005f, -0.85f + 1.7f * h / kLevels);
      for (int i = 0; i < kRays; ++i) {
        const float a = 2.0f * static_cast<float>(std::numbers::pi) * i / kRays;
        const auto hit = bvh.FirstHit(c, V(std::cos(a), std::sin(a), 0.0f));
        hits += hit.has_value();
      }
    }
  }
  benchmark::DoNotOptimize(hits);
  state.SetItemsProcessed(state.iterations() * kRays * kLevels);
}
BENCHMARK(BM_DiskRays)->Unit(benchmark::kMillisecond);

void BM_BruteForceRays(benchmark::State& state) {
  const Mesh& m = BigMesh();
  int64_t hits = 0, rays = 0;
  for (auto _ : state) {
    const float a = 0.1f * static_cast<float>(rays);
    hits += skinspheres::lib::BruteForceFirstHit(m.positions, m.triangles, {}, V(0, 0, 0.1f),
                                                 V(std::cos(a), std::sin(a), 0.0f))
                .has_value();
    ++rays;
  }
  benchmark::DoNotOptimize(hits);
  state.SetItemsProcessed(rays);
}
BENCHMARK(BM_BruteForceRays)->Unit(benchmark::kMillisecond);

std::vector<V> ArcPoints(int n) {
  std::vector<V> pts;
  for (int i = 0; i < n; ++i) {
    const float th = -1.5f + 3.0f * i / static_cast<float>(n - 1);
    pts.emplace_back(0.2f * std::cos(th), 0.1f * std::sin(th), 0.001f * static_cast<float>(i % 3));
  }
  return pts;
}

void BM_CentroidBall(benchmark::State& state) {
  const auto pts = ArcPoints(40);
  for (auto _ : state) benchmark::DoNotOptimize(skinspheres::lib::CentroidBall(pts));
}
BENCHMARK(BM_CentroidBall);

void BM_MinimumBall(benchmark::State& state) {
  const auto pts = ArcPoints(static_cast<int>(state.range(0)));
  for (auto _ : state) benchmark::DoNotOptimize(skinspheres::lib::MinimumBall(pts));
}
BENCHMARK(BM_MinimumBall)->Arg(20)->Arg(40)->Arg(80);

void BM_AdjustM1(benchmark::State& state) {
  const auto pts = ArcPoints(40);
  const auto m1 = skinspheres::lib::CentroidBall(pts);
  for (auto _ : state) {
    benchmark::DoNotOptimize(skinspheres::lib::AdjustM1(m1, pts, V(0, 0, 0), V(1, 0, 0), V(0, 1, 0)));
  }
}
BENCHMARK(BM_AdjustM1);

}  // namespace

BENCHMARK_MAIN();
