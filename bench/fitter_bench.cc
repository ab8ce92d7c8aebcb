// End-to-end fitter benchmark: import, body-part split and fit timed apart (the fit's budget is
// Xbot.glb, 49k triangles, under 200 ms on one core after import). For every shared character
// (SKINSPHERES_ASSET_DIR/{Xbot,Soldier,CesiumMan,RobotExpressive}.glb; the rows SkipWithError
// when a file is absent) and for the built-in character (lib::MakeBuiltinCharacter), three stages
// are timed apart, each on inputs prepared once outside the timed loop:
//   Import/<name>      ImportCharacter (default options, clips read); built-in: MakeBuiltinCharacter
//   Split/<name>       SplitBodyParts on the imported character
//   Fit/<name>/threads FitSpheres with default FitSettings, TBB limited by
//                      tbb::global_control(max_allowed_parallelism, threads): 1 = the one-core
//                      figure, 2 = both cores of the build machine.
// Import and split run under max_allowed_parallelism 1 too. Every row uses real (wall) time;
// "CPU" is the calling thread's CPU time only (with 2 threads it misses the worker's share).
// Counters: triangles, vertices, spheres (fit), parts (split).
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "skinspheres/lib/body_parts/body_parts.h"
#include "skinspheres/lib/character/builtin_character.h"
#include "skinspheres/lib/fit/sphere_fitter.h"
#include "skinspheres/lib/io/importer.h"

namespace {

namespace lib = skinspheres::lib;

constexpr const char* kBuiltin = "Builtin";
const char* const kAssets[] = {"Xbot", "Soldier", "CesiumMan", "RobotExpressive"};

std::filesystem::path AssetPath(const std::string& name) {
  return std::filesystem::path(SKINSPHERES_ASSET_DIR) / (name + ".glb");
}

// Imported character and its parts, prepared once per name (outside every timed loop).
struct Prepared {
  std::string error;  // "" when usable
  lib::RawCharacter character;
  lib::BodyParts parts;
};

const Prepared& Prepare(const std::string& name) {
  static std::map<std::string, std::unique_ptr<Prepared>> cache;
  auto& slot = cache[name];
  if (slot) return *slot;
  slot = std::make_unique<Prepared>();
  if (name == kBuiltin) {
    slot->character = lib::MakeBuiltinCharacter();
  } else {
    const auto file = AssetPath(name);
    if (!std::filesystem::exists(file)) {
      slot->error = file.string() + " is absent";
      return *slot;
    }
    auto ch = lib::ImportCharacter(file);
    if (!ch.ok()) {
      slot->error = ch.error().message;
      return *slot;
    }
    slot->character = std::move(*ch);
  }
  auto parts = lib::SplitBodyParts(slot->character);
  if (!parts.ok()) {
    slot->error = parts.error().message;
    return *slot;
  }
  slot->parts = std::move(*parts);
  return *slot;
}

void SetMeshCounters(benchmark::State& state, const lib::RawCharacter& ch) {
  state.counters["triangles"] = static_cast<double>(ch.triangle_count());
  state.counters["vertices"] = static_cast<double>(ch.vertex_count());
}

void BM_Import(benchmark::State& state, const std::string& name) {
  tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
  const auto file = AssetPath(name);
  if (name != kBuiltin && !std::filesystem::exists(file)) {
    state.SkipWithError((file.string() + " is absent").c_str());
    return;
  }
  size_t triangles = 0, vertices = 0;
  for (auto _ : state) {
    if (name == kBuiltin) {
      lib::RawCharacter ch = lib::MakeBuiltinCharacter();
      triangles = ch.triangle_count();
      vertices = ch.vertex_count();
      benchmark::DoNotOptimize(ch);
    } else {
      auto ch = lib::ImportCharacter(file);
      if (!ch.ok()) {
        state.SkipWithError(ch.error().message.c_str());
        return;
      }
      triangles = ch->triangle_count();
      vertices = ch->vertex_count();
      benchmark::DoNotOptimize(ch);
    }
  }
  state.counters["triangles"] = static_cast<double>(triangles);
  state.counters["vertices"] = static_cast<double>(vertices);
}

void BM_Split(benchmark::State& state, const std::string& name) {
  tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
  const Prepared& p = Prepare(name);
  if (!p.error.empty()) {
    state.SkipWithError(p.error.c_str());
    return;
  }
  size_t part_count = 0;
  for (auto _ : state) {
    auto parts = lib::SplitBodyParts(p.character);
    if (!parts.ok()) {
      state.SkipWithError(parts.error().message.c_str());
      return;
    }
    part_count = parts->parts.size();
    benchmark::DoNotOptimize(parts);
  }
  SetMeshCounters(state, p.character);
  state.counters["parts"] = static_cast<double>(part_count);
}

void BM_Fit(benchmark::State& state, const std::string& name) {
  const int threads = static_cast<int>(state.range(0));
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(threads));
  const Prepared& p = Prepare(name);
  if (!p.error.empty()) {
    state.SkipWithError(p.error.c_str());
    return;
  }
  const lib::FitSettings settings;  // defaults
  size_t spheres = 0;
  for (auto _ : state) {
    auto fit = lib::FitSpheres(p.character, p.parts, settings);
    if (!fit.ok()) {
      state.SkipWithError(fit.error().message.c_str());
      return;
    }
    spheres = fit->spheres.size();
    benchmark::DoNotOptimize(fit);
  }
  SetMeshCounters(state, p.character);
  state.counters["spheres"] = static_cast<double>(spheres);
}

void RegisterAll() {
  std::vector<std::string> names(std::begin(kAssets), std::end(kAssets));
  names.push_back(kBuiltin);
  for (const auto& n : names) {
    benchmark::RegisterBenchmark(("Import/" + n).c_str(), BM_Import, n)->Unit(benchmark::kMillisecond)->UseRealTime();
  }
  for (const auto& n : names) {
    benchmark::RegisterBenchmark(("Split/" + n).c_str(), BM_Split, n)->Unit(benchmark::kMillisecond)->UseRealTime();
  }
  for (const auto& n : names) {
    benchmark::RegisterBenchmark(("Fit/" + n).c_str(), BM_Fit, n)
        ->ArgName("threads")
        ->Arg(1)
        ->Arg(2)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
  }
}

}  // namespace

int main(int argc, char** argv) {
  RegisterAll();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
