// Self-collision broad phase benchmarks (broad_phase.h).
//
// Sphere sets: a synthetic humanoid of 150 or 300 spheres (torso of three columns, head, two arms,
// two legs: chains of overlapping spheres), animated over a 64-frame loop (arms swing and adduct
// into the torso, legs swing with bending knees, torso twists), so frames are temporally coherent
// and contacts exist. Exclusions: consecutive spheres on a chain and every pair overlapping at rest
// (what the fitter's kBindOverlap produces). Each iteration is one new frame.
//
//   BM_SkinSpheres      SelfCollisionJob (sort and sweep, coherent insertion sort)
//   BM_AllPairs         SelfCollisionAllPairs (the scalar oracle)
//   BM_BulletDbvt       btDbvtBroadphase: setAabb per sphere + calculateOverlappingPairs, exclusions in
//                       an overlap filter callback, then the sphere test and sorted contacts
//   BM_FclDynamicTree   fcl::DynamicAABBTreeCollisionManager: setTranslation + computeAABB per sphere,
//                       update(), collide() with a callback doing exclusions and the sphere test
//   BM_Crowd            RunSelfCollisionJobs on 1..1000 characters at 1 and 2 threads
// Every method is checked against the oracle on all 64 frames before timing (SkipWithError if not).
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "skinspheres/runtime/broad_phase.h"

#include "peer_broad_phases.h"

namespace {

using skinspheres::runtime::BroadPhaseContext;
using skinspheres::runtime::Contact;
using skinspheres::runtime::ExcludedPair;
using skinspheres::runtime::ExclusionReason;
using skinspheres::runtime::PairFilter;
using skinspheres::runtime::SelfCollisionJob;

constexpr int kFrames = 64;

struct Humanoid {
  std::vector<std::vector<skinspheres::Vec4f>> frames;  // kFrames x n
  PairFilter filter;
};

// One chain: spheres evenly spaced from `from` to `to`; limbs have a joint at their middle.
struct Chain {
  Eigen::Vector3f from, to;
  int count;
  float radius;
  uint16_t part;  // 0 torso, 1 head, 2 arm_l, 3 arm_r, 4 leg_l, 5 leg_r
};

Humanoid MakeHumanoid(int n) {
  const int m = n / 150;  // 1 or 2
  const float rs = 1.0f / std::sqrt(float(m));
  std::vector<Chain> chains;
  for (float x : {-0.1f, 0.0f, 0.1f}) chains.push_back({{x, 0.95f, 0}, {x, 1.5f, 0}, 14 * m, 0.09f * rs, 0});
  chains.push_back({{0, 1.56f, 0}, {0, 1.8f, 0}, 8 * m, 0.1f * rs, 1});
  for (float s : {-1.0f, 1.0f}) {
    chains.push_back({{0.2f * s, 1.45f, 0}, {0.24f * s, 0.8f, 0}, 22 * m, 0.045f * rs, uint16_t(s < 0 ? 2 : 3)});
    chains.push_back({{0.1f * s, 0.9f, 0}, {0.1f * s, 0.05f, 0}, 28 * m, 0.07f * rs, uint16_t(s < 0 ? 4 : 5)});
  }
  std::vector<skinspheres::Vec4f> rest;
  std::vector<uint16_t> parts;
  std::vector<int> chain_of, index_in_chain;
  for (size_t c = 0; c < chains.size(); ++c) {
    for (int k = 0; k < chains[c].count; ++k) {
      const float t = (float(k) + 0.5f) / float(chains[c].count);
      const Eigen::Vector3f p = chains[c].from + t * (chains[c].to - chains[c].from);
      rest.push_back({p.x(), p.y(), p.z(), chains[c].radius});
      parts.push_back(chains[c].part);
      chain_of.push_back(int(c));
      index_in_chain.push_back(k);
    }
  }
  std::vector<ExcludedPair> excluded;
  for (uint32_t i = 0; i < rest.size(); ++i) {
    for (uint32_t j = i + 1; j < rest.size(); ++j) {
      const bool consecutive = chain_of[i] == chain_of[j] && index_in_chain[j] == index_in_chain[i] + 1;
      const bool overlap_at_rest = (rest[i].head<3>() - rest[j].head<3>()).norm() < rest[i].w() + rest[j].w();
      if (consecutive || overlap_at_rest) excluded.push_back({i, j, ExclusionReason::kBindOverlap});
    }
  }
  Humanoid h;
  h.filter = std::move(PairFilter::Create(rest.size(), parts, excluded)).value();
  h.frames.resize(kFrames);
  for (int f = 0; f < kFrames; ++f) {
    const float theta = 2.0f * float(M_PI) * float(f) / float(kFrames);
    const float s = std::sin(theta);
    const Eigen::AngleAxisf twist(0.1f * s, Eigen::Vector3f::UnitY());
    std::vector<skinspheres::Vec4f>& out = h.frames[f];
    out.resize(rest.size());
    for (size_t i = 0; i < rest.size(); ++i) {
      const Chain& ch = chains[chain_of[i]];
      Eigen::Vector3f p = rest[i].head<3>();
      const bool lower = index_in_chain[i] >= ch.count / 2;
      const Eigen::Vector3f mid = 0.5f * (ch.from + ch.to);
      const float side = ch.from.x() < 0 ? -1.0f : 1.0f;
      if (ch.part == 2 || ch.part == 3) {  // arm: elbow bend, then shoulder swing and adduction
        if (lower) p = mid + Eigen::AngleAxisf(-0.7f * (1.0f + s), Eigen::Vector3f::UnitX()) * (p - mid);
        const Eigen::Matrix3f shoulder =
            (Eigen::AngleAxisf(-side * (0.05f + 0.08f * s), Eigen::Vector3f::UnitZ()) *
             Eigen::AngleAxisf(0.6f * s * side, Eigen::Vector3f::UnitX()))
                .toRotationMatrix();
        p = ch.from + shoulder * (p - ch.from);
        p = twist * p;
      } else if (ch.part >= 4) {  // leg: knee bend, hip swing, slight adduction
        const float phase = side * s;
        if (lower) p = mid + Eigen::AngleAxisf(0.5f * (1.0f - phase), Eigen::Vector3f::UnitX()) * (p - mid);
        const Eigen::Matrix3f hip = (Eigen::AngleAxisf(-side * 0.04f, Eigen::Vector3f::UnitZ()) *
                                     Eigen::AngleAxisf(-0.45f * phase, Eigen::Vector3f::UnitX()))
                                        .toRotationMatrix();
        p = ch.from + hip * (p - ch.from);
      } else {  // torso and head twist about the pelvis
        p = twist * p;
      }
      out[i] = {p.x(), p.y(), p.z(), rest[i].w()};
    }
  }
  return h;
}

const Humanoid& GetHumanoid(int n) {
  static std::map<int, Humanoid> cache;
  auto it = cache.find(n);
  if (it == cache.end()) it = cache.emplace(n, MakeHumanoid(n)).first;
  return it->second;
}

std::vector<Contact> Oracle(const Humanoid& h, int frame) {
  std::vector<Contact> out;
  skinspheres::runtime::SelfCollisionAllPairs(h.frames[frame], h.filter, &out);
  return out;
}

void AddCounters(benchmark::State& state, const Humanoid& h, size_t contacts_total, size_t frames) {
  state.counters["spheres"] = double(h.frames[0].size());
  state.counters["contacts"] = frames ? double(contacts_total) / double(frames) : 0.0;
}

// --------------------------------------------------------------------------------- skinspheres

void BM_SkinSpheres(benchmark::State& state) {
  const Humanoid& h = GetHumanoid(int(state.range(0)));
  const size_t n = h.frames[0].size();
  BroadPhaseContext ctx(n);
  std::vector<Contact> out;
  out.reserve(4 * n);
  for (int f = 0; f < kFrames; ++f) {
    if (!SelfCollisionJob{h.frames[f], &h.filter, &ctx, &out}.Run() || out != Oracle(h, f)) {
      state.SkipWithError("skinspheres differs from all-pairs");
      return;
    }
  }
  size_t frame = 0, contacts = 0, candidates = 0;
  for (auto _ : state) {
    SelfCollisionJob{h.frames[frame % kFrames], &h.filter, &ctx, &out}.Run();
    contacts += out.size();
    candidates += ctx.last_candidate_count();
    benchmark::DoNotOptimize(out.data());
    ++frame;
  }
  AddCounters(state, h, contacts, frame);
  state.counters["candidates"] = frame ? double(candidates) / double(frame) : 0.0;
  state.counters["axis"] = ctx.sweep_axis();
}
BENCHMARK(BM_SkinSpheres)->Arg(150)->Arg(300);

void BM_AllPairs(benchmark::State& state) {
  const Humanoid& h = GetHumanoid(int(state.range(0)));
  std::vector<Contact> out;
  out.reserve(4 * h.frames[0].size());
  size_t frame = 0, contacts = 0;
  for (auto _ : state) {
    skinspheres::runtime::SelfCollisionAllPairs(h.frames[frame % kFrames], h.filter, &out);
    contacts += out.size();
    benchmark::DoNotOptimize(out.data());
    ++frame;
  }
  AddCounters(state, h, contacts, frame);
}
BENCHMARK(BM_AllPairs)->Arg(150)->Arg(300);

#if SKINSPHERES_HAVE_PEERS
// ----------------------------------------------------------------------- Bullet and FCL (peers)
using skinspheres::bench::BulletWorld;
using skinspheres::bench::FclWorld;

// One peer over the synthetic humanoid: checked against all-pairs on every frame, then timed.
template <class World>
void PeerBenchmark(benchmark::State& state, const char* name) {
  const Humanoid& h = GetHumanoid(int(state.range(0)));
  World world(h.frames[0], h.filter);
  std::vector<Contact> out;
  out.reserve(4 * h.frames[0].size());
  for (int f = 0; f < kFrames; ++f) {
    world.Frame(h.frames[f], &out);
    if (out != Oracle(h, f)) {
      state.SkipWithError((std::string(name) + " differs from all-pairs").c_str());
      return;
    }
  }
  size_t frame = 0, contacts = 0;
  for (auto _ : state) {
    world.Frame(h.frames[frame % kFrames], &out);
    contacts += out.size();
    ++frame;
  }
  AddCounters(state, h, contacts, frame);
}
void BM_BulletDbvt(benchmark::State& state) { PeerBenchmark<BulletWorld>(state, "Bullet"); }
void BM_FclDynamicTree(benchmark::State& state) { PeerBenchmark<FclWorld>(state, "FCL"); }
BENCHMARK(BM_BulletDbvt)->Arg(150)->Arg(300);
BENCHMARK(BM_FclDynamicTree)->Arg(150)->Arg(300);
#endif  // SKINSPHERES_HAVE_PEERS

// -------------------------------------------------------------------------------------- crowd

// range(0) characters of 150 spheres, range(1) threads. Character c plays the loop 7c frames ahead.
void BM_Crowd(benchmark::State& state) {
  const Humanoid& h = GetHumanoid(150);
  const size_t characters = size_t(state.range(0));
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(state.range(1)));
  std::vector<BroadPhaseContext> contexts(characters);
  std::vector<std::vector<Contact>> outs(characters);
  std::vector<SelfCollisionJob> jobs(characters);
  for (size_t c = 0; c < characters; ++c) {
    contexts[c].Resize(h.frames[0].size());
    outs[c].reserve(4 * h.frames[0].size());
    jobs[c] = {h.frames[0], &h.filter, &contexts[c], &outs[c]};
  }
  size_t frame = 0;
  for (auto _ : state) {
    for (size_t c = 0; c < characters; ++c) jobs[c].spheres = h.frames[(frame + 7 * c) % kFrames];
    if (!skinspheres::runtime::RunSelfCollisionJobs(jobs)) {
      state.SkipWithError("crowd job failed");
      return;
    }
    ++frame;
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(characters));  // characters per second
}
BENCHMARK(BM_Crowd)
    ->ArgsProduct({{1, 10, 100, 1000}, {1, 2}})
    ->ArgNames({"characters", "threads"})
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
