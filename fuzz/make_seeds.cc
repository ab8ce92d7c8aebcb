// Writes the seed corpus of the fuzz targets into fuzz/corpus/<target>/ (the folder given as the
// only argument, normally fuzz/corpus): small valid inputs from the tests' tiny glTF writer,
// so the fuzzers start from files that go deep into the readers. Deterministic: the same files
// every run. Usage: build/fuzz/fuzz_make_seeds fuzz/corpus
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <random>
#include <span>

#include "skinspheres/lib/body_parts/body_parts.h"
#include "skinspheres/lib/fit/sphere_fitter.h"
#include "skinspheres/lib/io/importer.h"
#include "skinspheres/runtime/format/sphere_set_binary.h"
#include "skinspheres/runtime/format/sphere_set_io.h"
#include "tiny_gltf.h"

namespace {

using namespace skinspheres;
using lib::json;

void Save(const std::filesystem::path& file, const std::string& bytes) {
  std::filesystem::create_directories(file.parent_path());
  std::ofstream(file, std::ios::binary) << bytes;
  std::printf("%s (%zu bytes)\n", file.c_str(), bytes.size());
}

std::optional<runtime::SphereSet> FitSet(const std::string& gltf, bool tighten, float piece_edge = 0.0f) {
  const auto c = lib::ImportGltfBytes(
      std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(gltf.data()), gltf.size()), "seed.gltf");
  if (!c.ok()) return std::nullopt;
  const auto parts = lib::SplitBodyParts(*c);
  if (!parts.ok()) return std::nullopt;
  lib::FitSettings settings;
  settings.rays = 8;
  settings.tighten = tighten;
  settings.piece_edge = piece_edge;
  const auto fit = lib::FitSpheres(*c, *parts, settings);
  if (!fit.ok()) return std::nullopt;
  return fit->spheres;
}

std::string Bytes(const std::vector<std::byte>& b) {
  return std::string(reinterpret_cast<const char*>(b.data()), b.size());
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: fuzz_make_seeds <corpus folder>\n");
    return 2;
  }
  const std::filesystem::path out(argv[1]);
  lib::TinyOptions anim;
  anim.animations = true;
  lib::TinyOptions strip;
  strip.skinned = false;
  strip.mode = 5;
  lib::TinyOptions sparse;
  sparse.edit = [](lib::TinyGltf& t) {
    const float moved[3] = {2, 0.5f, 0};
    t.MakeSparse(0, {1}, 5121, moved, sizeof moved);
  };
  const std::pair<const char*, lib::TinyOptions> cases[] = {
      {"tiny", {}}, {"anim", anim}, {"strip", strip}, {"sparse", sparse}};
  for (const auto& [name, options] : cases) {
    const json j = lib::MakeTiny(options);
    Save(out / "gltf" / (std::string(name) + ".gltf"), j.dump());
    Save(out / "gltf" / (std::string(name) + ".glb"), lib::ToGlb(j));
  }
  const auto tight = FitSet(lib::MakeTiny(anim).dump(), true);
  const auto loose = FitSet(lib::MakeTiny({}).dump(), false);
  // Each vertex weighted half on each joint, the child's rest raised by 1 from its bind pose
  // (identity inverse bind matrices): the rest copies lie apart, so the fit stores the bind pose as
  // the fast reference (fast_reference_inverse, fast_reference; binary sections 29-30), and its
  // reach groups (reach_groups; sections 31-33).
  lib::TinyOptions blend;
  blend.weights = {0.5f, 0.5f, 0, 0, 0.25f, 0.75f, 0, 0, 0.75f, 0.25f, 0, 0, 1, 0, 0, 0};
  const auto blended = FitSet(lib::MakeTiny(blend).dump(), true);
  if (!tight || !loose || !blended) {
    std::fprintf(stderr, "fuzz_make_seeds: the tiny character did not fit\n");
    return 1;
  }
  Save(out / "sphere_set" / "tiny.spheres.json", runtime::WriteSphereSetJson(*tight));
  Save(out / "sphere_set" / "tiny_untightened.spheres.json", runtime::WriteSphereSetJson(*loose));
  if (blended->fast_reference_inverse.empty() || blended->reach_group_offsets.empty()) {
    std::fprintf(stderr, "fuzz_make_seeds: the blended tiny character has no fast reference or no reach groups\n");
    return 1;
  }
  Save(out / "sphere_set" / "tiny_bind_reference.spheres.json", runtime::WriteSphereSetJson(*blended));
  // The binary asset: whole (mesh included) and fast-only.
  using runtime::SphereSetBinaryContent;
  Save(out / "sphere_set_binary" / "tiny.ssb", Bytes(runtime::WriteSphereSetBinary(*tight)));
  Save(out / "sphere_set_binary" / "tiny_fast_only.ssb",
       Bytes(runtime::WriteSphereSetBinary(*tight, SphereSetBinaryContent::kFastOnly)));
  Save(out / "sphere_set_binary" / "tiny_untightened.ssb", Bytes(runtime::WriteSphereSetBinary(*loose)));
  Save(out / "sphere_set_binary" / "tiny_bind_reference.ssb", Bytes(runtime::WriteSphereSetBinary(*blended)));
  Save(out / "sphere_set_binary" / "tiny_bind_reference_fast_only.ssb",
       Bytes(runtime::WriteSphereSetBinary(*blended, SphereSetBinaryContent::kFastOnly)));
  // Triangle pieces (docs/TRIANGLE_PIECES.md): the tiny character's triangles cut (JSON version 3,
  // binary sections 34-36).
  const auto cut = FitSet(lib::MakeTiny(anim).dump(), true, 0.6f);
  if (!cut || !cut->has_pieces()) {
    std::fprintf(stderr, "fuzz_make_seeds: the tiny character's fit with pieces has none\n");
    return 1;
  }
  Save(out / "sphere_set" / "tiny_pieces.spheres.json", runtime::WriteSphereSetJson(*cut));
  Save(out / "sphere_set_binary" / "tiny_pieces.ssb", Bytes(runtime::WriteSphereSetBinary(*cut)));
  // The fit target decodes any bytes into a character: seeds of a few sizes, from a fixed seed.
  std::mt19937 rng(20240601);
  for (size_t size : {64, 160, 320, 640}) {
    std::string bytes(size, '\0');
    for (char& b : bytes) b = static_cast<char>(rng());
    Save(out / "fit" / ("random_" + std::to_string(size) + ".bin"), bytes);
  }
  return 0;
}
