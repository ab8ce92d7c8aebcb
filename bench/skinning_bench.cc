// Linear blend skinning throughput, one thread: the naive loop (per vertex, per influence,
// Matrix4f · Vector4f, accumulate weighted) against SkinningJob (CSR and prepared influences,
// each SIMD level), on a synthetic Xbot-sized mesh (50k vertices, 70 bind entries):
// 4 influences per vertex, or mixed counts (1..8), full mesh or a 10% subset.
// items_per_second = skinned vertices per second.
#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <random>
#include <vector>

#include "skinspheres/skinning/prepared_influences.h"
#include "skinspheres/skinning/skinning_job.h"

namespace {

using skinspheres::skinning::PreparedInfluences;
using skinspheres::skinning::SimdLevel;
using skinspheres::skinning::SkinningJob;

constexpr size_t kVertices = 50000;
constexpr size_t kBinds = 70;

struct Mesh {
  std::vector<float> positions;  // xyz
  std::vector<uint32_t> offsets;
  std::vector<uint16_t> binds;
  std::vector<float> weights;
  std::vector<uint32_t> subset;
  std::vector<skinspheres::Mat4f> matrices;
  std::vector<float> out;
  PreparedInfluences prepared_full, prepared_subset;
};

Mesh MakeMesh(bool mixed) {
  std::mt19937 rng(mixed ? 7 : 4);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  Mesh m;
  m.positions.resize(3 * kVertices);
  for (float& p : m.positions) p = u(rng);
  m.offsets.push_back(0);
  std::discrete_distribution<int> counts({20, 25, 20, 20, 5, 4, 3, 3});
  for (size_t v = 0; v < kVertices; ++v) {
    const int n = mixed ? counts(rng) + 1 : 4;
    float sum = 0;
    const uint16_t base = static_cast<uint16_t>(rng() % (kBinds - 8));  // nearby joints, like a real rig
    for (int k = 0; k < n; ++k) {
      m.binds.push_back(static_cast<uint16_t>(base + k));
      const float w = 0.1f + 0.9f * (u(rng) + 1.0f) * 0.5f;
      m.weights.push_back(w);
      sum += w;
    }
    for (int k = 0; k < n; ++k) m.weights[m.weights.size() - 1 - k] /= sum;
    m.offsets.push_back(static_cast<uint32_t>(m.binds.size()));
  }
  for (size_t v = 0; v < kVertices; ++v)
    if (rng() % 10 == 0) m.subset.push_back(static_cast<uint32_t>(v));
  for (size_t b = 0; b < kBinds; ++b) {
    Eigen::Affine3f a = Eigen::Translation3f(u(rng), u(rng), u(rng)) *
                        Eigen::AngleAxisf(u(rng) * 3.0f, Eigen::Vector3f(u(rng), u(rng), u(rng) + 2.0f).normalized());
    m.matrices.push_back(a.matrix());
  }
  m.out.assign(m.positions.size(), 0.0f);
  m.prepared_full.Build(kVertices, m.offsets, m.binds, m.weights);
  m.prepared_subset.Build(kVertices, m.offsets, m.binds, m.weights, m.subset);
  return m;
}

Mesh& GetMesh(bool mixed) {
  static Mesh four = MakeMesh(false);
  static Mesh mix = MakeMesh(true);
  return mixed ? mix : four;
}

// args: mixed (0/1), subset (0/1)
void BM_Naive(benchmark::State& state) {
  Mesh& m = GetMesh(state.range(0) != 0);
  const bool sub = state.range(1) != 0;
  const size_t items = sub ? m.subset.size() : kVertices;
  for (auto _ : state) {
    for (size_t i = 0; i < items; ++i) {
      const size_t v = sub ? m.subset[i] : i;
      const skinspheres::Vec4f p(m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2], 1.0f);
      skinspheres::Vec4f acc = skinspheres::Vec4f::Zero();
      for (uint32_t k = m.offsets[v]; k < m.offsets[v + 1]; ++k) {
        acc += m.weights[k] * (m.matrices[m.binds[k]] * p);
      }
      m.out[3 * v] = acc.x();
      m.out[3 * v + 1] = acc.y();
      m.out[3 * v + 2] = acc.z();
    }
    benchmark::DoNotOptimize(m.out.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * items));
}

// args: mixed, subset, prepared (0/1), simd level
void BM_Job(benchmark::State& state) {
  Mesh& m = GetMesh(state.range(0) != 0);
  const bool sub = state.range(1) != 0;
  const bool prep = state.range(2) != 0;
  const auto level = static_cast<SimdLevel>(state.range(3));
  if (!skinspheres::skinning::SimdLevelSupported(level)) {
    state.SkipWithError("SIMD level not supported on this CPU");
    return;
  }
  SkinningJob job;
  job.joint_matrices = m.matrices;
  job.vertex_count = kVertices;
  job.in_positions = m.positions;
  job.out_positions = m.out;
  job.simd = level;
  if (prep) {
    job.prepared = sub ? &m.prepared_subset : &m.prepared_full;
  } else {
    job.influence_offsets = m.offsets;
    job.influence_binds = m.binds;
    job.influence_weights = m.weights;
    if (sub) job.subset = m.subset;
  }
  if (!job.Validate()) {
    state.SkipWithError("invalid job");
    return;
  }
  for (auto _ : state) {
    // Run() validates the range it reads: part of the price.
    benchmark::DoNotOptimize(job.Run());
    benchmark::ClobberMemory();
  }
  state.SetLabel(skinspheres::skinning::ToString(level));
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * job.WorkSize()));
}

void JobArgs(benchmark::internal::Benchmark* b) {
  b->ArgNames({"mixed", "subset", "prepared", "simd"});
  for (int mixed : {0, 1})
    for (int sub : {0, 1})
      for (int prep : {0, 1})
        for (SimdLevel l : {SimdLevel::kPortable, SimdLevel::kSse2, SimdLevel::kAvx2})
          b->Args({mixed, sub, prep, static_cast<int>(l)});
}

BENCHMARK(BM_Naive)->ArgNames({"mixed", "subset"})->Args({0, 0})->Args({0, 1})->Args({1, 0})->Args({1, 1});
BENCHMARK(BM_Job)->Apply(JobArgs);

}  // namespace

BENCHMARK_MAIN();
