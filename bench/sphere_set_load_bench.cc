// Loading a fitted Xbot sphere set: JSON (the interchange format) against the binary asset
// (sphere_set_binary.h), from a file and from memory, in one run. The set is fitted in the set-up
// from ../shared/assets/Xbot.glb and written to a temporary folder (never committed).
//
//   LoadJsonFile / LoadBinaryFile / LoadFastOnlyFile   LoadSphereSet(path): read + decode + Validate
//   ReadJson / ReadBinary / ReadFastOnly                the same from bytes already in memory
//   OpenBinaryView                                      SphereSetBinaryView::Open on a buffer (what a
//                                                       memory-mapped file costs: checksum + checks)
#include <benchmark/benchmark.h>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "skinspheres/lib/body_parts/body_parts.h"
#include "skinspheres/lib/fit/sphere_fitter.h"
#include "skinspheres/lib/io/importer.h"
#include "skinspheres/runtime/format/sphere_set_binary.h"
#include "skinspheres/runtime/format/sphere_set_io.h"

namespace skinspheres {
namespace {

struct Files {
  std::filesystem::path json, binary, fast_only;
  std::string json_text;
  std::vector<std::byte> binary_bytes, fast_only_bytes;
  size_t spheres = 0;
};

// Fitted once per process; null (with a message) when Xbot is not there.
const Files* XbotFiles() {
  static const std::unique_ptr<Files> files = []() -> std::unique_ptr<Files> {
    const std::filesystem::path source = std::filesystem::path(SKINSPHERES_ASSET_DIR) / "Xbot.glb";
    auto ch = lib::ImportCharacter(source.string());
    if (!ch.ok()) return std::fprintf(stderr, "%s\n", ch.error().message.c_str()), nullptr;
    auto parts = lib::SplitBodyParts(*ch);
    if (!parts.ok()) return std::fprintf(stderr, "%s\n", parts.error().message.c_str()), nullptr;
    auto fit = lib::FitSpheres(*ch, *parts, lib::FitSettings{});
    if (!fit.ok()) return std::fprintf(stderr, "%s\n", fit.error().message.c_str()), nullptr;
    auto f = std::make_unique<Files>();
    const auto dir = std::filesystem::temp_directory_path() / "skinspheres_load_bench";
    std::filesystem::create_directories(dir);
    f->json = dir / "xbot.json";
    f->binary = dir / "xbot.ssb";
    f->fast_only = dir / "xbot_fast.ssb";
    if (runtime::SaveSphereSet(fit->spheres, f->json) || runtime::SaveSphereSet(fit->spheres, f->binary) ||
        runtime::SaveSphereSet(fit->spheres, f->fast_only, runtime::SphereSetFileFormat::kBinaryFastOnly)) {
      return std::fprintf(stderr, "cannot write the sets under %s\n", dir.c_str()), nullptr;
    }
    f->json_text = runtime::WriteSphereSetJson(fit->spheres);
    f->binary_bytes = runtime::WriteSphereSetBinary(fit->spheres);
    f->fast_only_bytes = runtime::WriteSphereSetBinary(fit->spheres, runtime::SphereSetBinaryContent::kFastOnly);
    f->spheres = fit->spheres.size();
    std::fprintf(stderr, "Xbot: %zu spheres, %zu vertices; JSON %zu bytes, binary %zu, fast-only %zu\n", f->spheres,
                 static_cast<size_t>(fit->spheres.source_vertex_count), f->json_text.size(), f->binary_bytes.size(),
                 f->fast_only_bytes.size());
    return f;
  }();
  return files.get();
}

template <typename Load>
void Run(benchmark::State& state, size_t bytes, Load&& load) {
  const Files* f = XbotFiles();
  if (f == nullptr) {
    state.SkipWithError("Xbot.glb not found under " SKINSPHERES_ASSET_DIR);
    return;
  }
  for (auto _ : state) {
    auto set = load(*f);
    if (!set.ok()) {
      state.SkipWithError(set.error().message.c_str());
      return;
    }
    benchmark::DoNotOptimize(set);
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * bytes));
  state.counters["spheres"] = static_cast<double>(f->spheres);
}

size_t JsonBytes() { return XbotFiles() ? XbotFiles()->json_text.size() : 0; }
size_t BinaryBytes() { return XbotFiles() ? XbotFiles()->binary_bytes.size() : 0; }
size_t FastOnlyBytes() { return XbotFiles() ? XbotFiles()->fast_only_bytes.size() : 0; }

void BM_LoadJsonFile(benchmark::State& state) {
  Run(state, JsonBytes(), [](const Files& f) { return runtime::LoadSphereSet(f.json); });
}
void BM_LoadBinaryFile(benchmark::State& state) {
  Run(state, BinaryBytes(), [](const Files& f) { return runtime::LoadSphereSet(f.binary); });
}
void BM_LoadFastOnlyFile(benchmark::State& state) {
  Run(state, FastOnlyBytes(), [](const Files& f) { return runtime::LoadSphereSet(f.fast_only); });
}
void BM_ReadJson(benchmark::State& state) {
  Run(state, JsonBytes(), [](const Files& f) { return runtime::ReadSphereSetJson(f.json_text, "xbot.json"); });
}
void BM_ReadBinary(benchmark::State& state) {
  Run(state, BinaryBytes(), [](const Files& f) { return runtime::ReadSphereSetBinary(f.binary_bytes, "xbot.ssb"); });
}
void BM_ReadFastOnly(benchmark::State& state) {
  Run(state, FastOnlyBytes(),
      [](const Files& f) { return runtime::ReadSphereSetBinary(f.fast_only_bytes, "xbot_fast.ssb"); });
}
void BM_OpenBinaryView(benchmark::State& state) {
  Run(state, BinaryBytes(),
      [](const Files& f) { return runtime::SphereSetBinaryView::Open(f.binary_bytes, "xbot.ssb"); });
}

BENCHMARK(BM_LoadJsonFile)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_LoadBinaryFile)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_LoadFastOnlyFile)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ReadJson)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ReadBinary)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ReadFastOnly)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_OpenBinaryView)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace skinspheres

BENCHMARK_MAIN();
