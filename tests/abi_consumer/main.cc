// Runs one frame of every public job (the narrow phase too, and the binary asset, the joint mapping and the C API)
// through the installed package and prints what the library computed, plus the size of every public struct as this
// program sees it. Built once with the library's own flags and again with wider ones (-mavx2 -mfma, -march=native): the
// outputs must be identical, and nothing may crash. Before the public math types were made layout-stable
// (skinning/math_types.h) the -mavx2 build crashed in LocalToModelJob::Run.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "skinspheres/lib/body_parts/body_parts.h"
#include "skinspheres/lib/character/builtin_character.h"
#include "skinspheres/lib/fit/sphere_fitter.h"
#include "skinspheres/runtime/api/character.h"
#include "skinspheres/runtime/api/joint_mapping.h"
#include "skinspheres/runtime/broad_phase/broad_phase.h"
#include "skinspheres/runtime/crowd/crowd.h"
#include "skinspheres/runtime/format/sphere_set_binary.h"
#include "skinspheres/runtime/format/sphere_set_io.h"
#include "skinspheres/runtime/narrow_phase/narrow_phase.h"
#include "skinspheres/runtime/refit/refit_job.h"
#include "skinspheres/skinning/local_to_model_job.h"
#include "skinspheres/skinning/prepared_influences.h"
#include "skinspheres/skinning/sampling_job.h"
#include "skinspheres/skinning/skinning_job.h"
#include "skinspheres/skinning/skinning_matrices_job.h"
#include "skinspheres/skinspheres.h"

using namespace skinspheres;

namespace {

int failures = 0;
void Check(bool ok, const char* what) {
  std::printf("%s: %s\n", what, ok ? "ok" : "FAILED");
  if (!ok) ++failures;
}

std::span<const float> Floats(const std::vector<Eigen::Vector3f>& v) { return {v.data()->data(), 3 * v.size()}; }
std::span<float> Floats(std::vector<Eigen::Vector3f>& v) { return {v.data()->data(), 3 * v.size()}; }

void PrintContacts(const char* what, std::span<const runtime::SpherePair> contacts) {
  std::printf("%s: %zu contacts", what, contacts.size());
  for (const runtime::SpherePair& c : contacts) std::printf(" %u-%u:%.5f", c.sphere_i, c.sphere_j, c.depth);
  std::printf("\n");
}

}  // namespace

int main(int argc, char** argv) {
  // To stderr, so the compared output stays the same: proof that the flags reached the compiler.
#if defined(__AVX512F__)
  std::fprintf(stderr, "consumer instruction set: avx512f\n");
#elif defined(__AVX2__)
  std::fprintf(stderr, "consumer instruction set: avx2\n");
#else
  std::fprintf(stderr, "consumer instruction set: baseline\n");
#endif
  // Layouts as this program sees them (compared across builds by the test script).
  std::printf(
      "sizeof Transform %zu BindEntry %zu LocalToModelJob %zu SkinningMatricesJob %zu SamplingJob %zu "
      "SkinningJob %zu RefitJob %zu BroadPhaseJob %zu SpherePair %zu SphereSet %zu CharacterFrameInput %zu "
      "FrameStatus %zu JointTrack %zu JointMapping %zu SphereSetBinaryView %zu skinspheres_sphere_pair %zu "
      "skinspheres_frame_input %zu NarrowPhaseJob %zu NarrowPhaseSettings %zu PartContact %zu "
      "TriangleContact %zu skinspheres_part_contact %zu skinspheres_triangle_contact %zu\n",
      sizeof(skinning::Transform), sizeof(skinning::BindEntry), sizeof(skinning::LocalToModelJob),
      sizeof(skinning::SkinningMatricesJob), sizeof(skinning::SamplingJob), sizeof(skinning::SkinningJob),
      sizeof(runtime::RefitJob), sizeof(runtime::BroadPhaseJob), sizeof(runtime::SpherePair),
      sizeof(runtime::SphereSet), sizeof(runtime::CharacterFrameInput), sizeof(runtime::FrameStatus),
      sizeof(skinning::JointTrack), sizeof(runtime::JointMapping), sizeof(runtime::SphereSetBinaryView),
      sizeof(skinspheres_sphere_pair), sizeof(skinspheres_frame_input), sizeof(runtime::NarrowPhaseJob),
      sizeof(runtime::NarrowPhaseSettings), sizeof(runtime::PartContact), sizeof(runtime::TriangleContact),
      sizeof(skinspheres_part_contact), sizeof(skinspheres_triangle_contact));

  // Offline API: the built-in character, its parts and its fit, saved and loaded back.
  const lib::RawCharacter ch = lib::MakeBuiltinCharacter();
  auto parts = lib::SplitBodyParts(ch);
  if (!parts.ok()) return std::printf("%s\n", parts.error().message.c_str()), 1;
  auto fit = lib::FitSpheres(ch, *parts, lib::FitSettings{});
  if (!fit.ok()) return std::printf("%s\n", fit.error().message.c_str()), 1;
  const std::filesystem::path path = argc > 1 ? argv[1] : "abi_consumer.spheres.json";
  if (auto err = runtime::SaveSphereSet(fit->spheres, path)) return std::printf("%s\n", err->message.c_str()), 1;
  auto loaded = runtime::LoadSphereSet(path);
  if (!loaded.ok()) return std::printf("%s\n", loaded.error().message.c_str()), 1;
  auto asset = runtime::CharacterAsset::Create(std::move(loaded).value());
  if (!asset.ok()) return std::printf("%s\n", asset.error().message.c_str()), 1;
  const runtime::SphereSet& set = (*asset)->sphere_set();
  std::printf("spheres %zu joints %zu excluded %zu\n", set.size(), set.joint_count(), set.excluded_pairs.size());
  Check(!(*asset)->Matches(ch.skeleton.joint_names, ch.vertex_count()).has_value(), "asset matches the character");

  // Pose: the "touch" clip with both hands on the chest, the character placed in the world.
  const skinning::AnimationClip& clip = ch.clips.back();
  const size_t joints = ch.skeleton.size();
  std::vector<skinning::Transform> locals(joints);
  Check(skinning::SamplingJob{&clip, &ch.skeleton, 1.2f, locals}.Run(), "SamplingJob");
  std::vector<Mat4f> world(joints);
  skinning::LocalToModelJob l2m;
  l2m.skeleton = &ch.skeleton;
  l2m.root(0, 3) = 2.0f;  // a non-identity root exercises the struct's Mat4f member
  l2m.input = locals;
  l2m.output = world;
  Check(l2m.Run(), "LocalToModelJob");
  std::vector<Mat4f> skin_matrices(ch.skin.binds.size());
  skinning::SkinningMatricesJob matrices_job;
  matrices_job.binds = ch.skin.binds;
  matrices_job.joint_model = world;
  matrices_job.output = skin_matrices;
  Check(matrices_job.Run(), "SkinningMatricesJob");

  // Skinning: prepared (SIMD) in parallel, CSR, and the reference loop.
  const size_t n = ch.vertex_count();
  std::vector<Eigen::Vector3f> fast(n), csr(n), reference(n);
  skinning::PreparedInfluences prepared;
  Check(prepared.Build(n, ch.skin.influence_offsets, ch.skin.influence_binds, ch.skin.influence_weights),
        "PreparedInfluences");
  skinning::SkinningJob skin;
  skin.joint_matrices = skin_matrices;
  skin.vertex_count = n;
  skin.in_positions = Floats(ch.skin.positions_bind);
  skin.out_positions = Floats(fast);
  skin.prepared = &prepared;
  Check(skin.RunParallel(), "SkinningJob prepared, RunParallel");
  skinning::SkinningJob skin_csr = skin;
  skin_csr.prepared = nullptr;
  skin_csr.influence_offsets = ch.skin.influence_offsets;
  skin_csr.influence_binds = ch.skin.influence_binds;
  skin_csr.influence_weights = ch.skin.influence_weights;
  skin_csr.out_positions = Floats(csr);
  Check(skin_csr.Run(), "SkinningJob CSR");
  skin_csr.out_positions = Floats(reference);
  Check(skinning::SkinReference(skin_csr), "SkinReference");
  float worst = 0.0f;
  for (size_t v = 0; v < n; ++v)
    worst = std::max({worst, (fast[v] - reference[v]).norm(), (csr[v] - reference[v]).norm()});
  Check(worst < 1e-4f, "skinning paths agree with the reference");

  // Refit, both modes, serial and parallel.
  std::vector<Vec4f> exact(set.size()), exact_parallel(set.size()), fast_spheres(set.size());
  runtime::RefitJob refit;
  refit.mode = runtime::RefitMode::kExact;
  refit.set = &set;
  refit.rest = &(*asset)->rest();
  refit.joint_world = world;
  refit.positions = reference;
  refit.out = exact;
  Check(refit.Run(), "RefitJob exact");
  refit.out = exact_parallel;
  Check(refit.RunParallel(), "RefitJob::RunParallel exact");
  Check(std::equal(exact.begin(), exact.end(), exact_parallel.begin()), "RefitJob::RunParallel is bit-identical");
  refit.mode = runtime::RefitMode::kFast;
  refit.positions = {};
  refit.out = fast_spheres;
  Check(refit.Run(), "RefitJob fast");

  // Broad phase: the job, the crowd runners and the oracle.
  runtime::BroadPhaseContext context_a(set.size()), context_b(set.size());
  std::vector<runtime::SpherePair> out_a, out_b, oracle;
  runtime::BroadPhaseJob jobs[2];
  jobs[0] = {exact, &(*asset)->filter(), &context_a, &out_a};
  jobs[1] = {fast_spheres, &(*asset)->filter(), &context_b, &out_b};
  Check(jobs[0].Run(), "BroadPhaseJob");
  Check(runtime::RunParallel(jobs), "RunParallel");
  Check(runtime::RunRange(jobs, 0, 2), "RunRange");
  Check(runtime::FindSpherePairsBruteForce(exact, (*asset)->filter(), &oracle), "FindSpherePairsBruteForce");
  Check(oracle == out_a, "sweep == all pairs");
  PrintContacts("exact spheres", out_a);
  PrintContacts("fast spheres", out_b);

  // Engine API: instances, both modes, and the crowd call.
  auto one = runtime::CharacterInstance::Create(*asset);
  auto two = runtime::CharacterInstance::Create(*asset);
  if (!one.ok() || !two.ok()) return std::printf("instance: failed\n"), 1;
  Check(one->UpdateExact(reference, world).ok(), "CharacterInstance::UpdateExact");
  Check(std::vector<runtime::SpherePair>(one->FindSpherePairs().begin(), one->FindSpherePairs().end()) == out_a,
        "FindSpherePairs == BroadPhaseJob (exact)");
  Check(one->UpdateFast(world).ok(), "CharacterInstance::UpdateFast");
  const auto queried = one->FindSpherePairs();
  Check(std::vector<runtime::SpherePair>(queried.begin(), queried.end()) == out_b,
        "FindSpherePairs == BroadPhaseJob (fast)");
  runtime::CharacterInstance* crowd[2] = {&*one, &*two};
  const runtime::CharacterFrameInput inputs[2] = {{world, {}}, {world, {}}};
  Check(runtime::CrowdUpdateAndFindSpherePairs(crowd, inputs, runtime::RefitMode::kFast).ok(),
        "CrowdUpdateAndFindSpherePairs");
  Check(std::equal(one->sphere_pairs().begin(), one->sphere_pairs().end(), out_b.begin(), out_b.end()) &&
            std::equal(two->sphere_pairs().begin(), two->sphere_pairs().end(), out_b.begin(), out_b.end()),
        "crowd == single instance");

  // The binary asset: the same set as the JSON, through a file and through a checked view.
  std::filesystem::path binary_path = path;
  binary_path.replace_extension(".ssb");
  if (auto err = runtime::SaveSphereSet(set, binary_path)) return std::printf("%s\n", err->message.c_str()), 1;
  auto binary = runtime::LoadSphereSet(binary_path);
  Check(binary.ok() && runtime::WriteSphereSetJson(*binary) == runtime::WriteSphereSetJson(set),
        "binary set == JSON set");
  auto bytes = runtime::ReadSphereSetFile(binary_path);
  Check(bytes.ok() && runtime::SphereSetBinaryView::Open(*bytes, "abi.ssb").ok(), "SphereSetBinaryView::Open");

  // Joint mapping: matrices in an engine's order (the set's reversed) give the same contacts.
  std::vector<std::string> engine_names(set.joint_names.rbegin(), set.joint_names.rend());
  std::vector<Mat4f> engine_world(world.rbegin(), world.rend());
  auto mapping = runtime::MapJoints(set, engine_names);
  Check(mapping.ok(), "MapJoints");
  auto mapped = runtime::CharacterInstance::Create(*asset, *mapping);
  Check(mapped.ok() && mapped->UpdateFast(engine_world).ok(), "CharacterInstance with a JointMapping");
  Check(mapped.ok() &&
            std::equal(mapped->FindSpherePairs().begin(), mapped->FindSpherePairs().end(), out_b.begin(), out_b.end()),
        "engine joint order == set joint order");

  // The C API on the same file and the same engine order.
  skinspheres_asset* c_asset = nullptr;
  skinspheres_instance* c_instance = nullptr;
  std::vector<const char*> c_names;
  for (const std::string& n : engine_names) c_names.push_back(n.c_str());
  size_t c_count = 0;
  Check(skinspheres_asset_load_file(binary_path.c_str(), &c_asset) == SKINSPHERES_OK &&
            skinspheres_instance_create(c_asset, c_names.data(), c_names.size(), &c_instance) == SKINSPHERES_OK &&
            skinspheres_instance_update_fast(c_instance, engine_world.data()->data(), engine_world.size()) ==
                SKINSPHERES_OK &&
            skinspheres_instance_find_sphere_pairs(c_instance, &c_count) == SKINSPHERES_OK,
        "C API: load, instance, update, query");
  std::vector<skinspheres_sphere_pair> c_contacts(c_count);
  size_t written = 0;
  Check(skinspheres_instance_get_sphere_pairs(c_instance, c_contacts.data(), c_contacts.size(), &written) ==
                SKINSPHERES_OK &&
            written == out_b.size() &&
            std::memcmp(c_contacts.data(), out_b.data(), written * sizeof(skinspheres_sphere_pair)) == 0,
        "C API contacts == C++ contacts");

  // The narrow phase: the job on the prepared skinning's positions, the brute-force oracle, the
  // mapped instance skinning only what it tests (the same positions, so the same contacts), and the
  // C API on the same frame.
  const runtime::NarrowPhaseData* narrow_data = (*asset)->narrow_phase();
  Check(narrow_data != nullptr, "NarrowPhaseData (the set has its mesh)");
  if (narrow_data != nullptr) {
    runtime::NarrowPhaseContext narrow_context;
    narrow_context.Resize(*narrow_data, /*lazy_skinning=*/true);
    runtime::FrameContacts narrow_out, narrow_oracle;
    runtime::NarrowPhaseJob narrow_job;
    narrow_job.set = &set;
    narrow_job.data = narrow_data;
    narrow_job.spheres = fast_spheres;
    narrow_job.pairs = out_b;
    narrow_job.positions = fast;
    narrow_job.context = &narrow_context;
    narrow_job.out = &narrow_out;
    Check(narrow_job.Run(), "NarrowPhaseJob");
    Check(runtime::FindContactsBruteForce(set, *narrow_data, (*asset)->filter(), fast, &narrow_oracle) &&
              narrow_oracle.triangle_pairs == narrow_out.triangle_pairs,
          "NarrowPhaseJob == brute force");
    std::printf("triangle contacts: %zu part pairs, %zu triangle pairs", narrow_out.parts.size(),
                narrow_out.triangle_pairs.size());
    for (const runtime::PartContact& pc : narrow_out.parts) {
      std::printf(" %u-%u:%u:%.5f", pc.part_a, pc.part_b, pc.triangle_pair_count, pc.depth);
    }
    std::printf("\n");
    Check(mapped.ok() && mapped->FindContacts().ok() && mapped->contacts() == narrow_out,
          "FindContacts (engine joint order, skinning what it tests) == NarrowPhaseJob");
    size_t c_parts = 0, c_triangles = 0;
    Check(skinspheres_instance_find_contacts(c_instance, nullptr, 0, &c_parts, &c_triangles) == SKINSPHERES_OK &&
              c_parts == narrow_out.parts.size() && c_triangles == narrow_out.triangle_pairs.size(),
          "C API: find_contacts");
    std::vector<skinspheres_triangle_contact> c_pairs(c_triangles);
    bool same = skinspheres_instance_get_triangle_contacts(c_instance, SKINSPHERES_ALL_PART_PAIRS, c_pairs.data(),
                                                           c_pairs.size(), &written) == SKINSPHERES_OK &&
                written == narrow_out.triangle_pairs.size();
    for (size_t k = 0; same && k < written; ++k) {
      const runtime::TriangleContact& t = narrow_out.triangle_pairs[k];
      same = c_pairs[k].triangle_a == t.triangle_a && c_pairs[k].triangle_b == t.triangle_b &&
             c_pairs[k].distance == t.distance && std::memcmp(c_pairs[k].on_a, t.on_a, sizeof t.on_a) == 0 &&
             std::memcmp(c_pairs[k].on_b, t.on_b, sizeof t.on_b) == 0;
    }
    Check(same, "C API triangle contacts == C++ triangle contacts");
  }
  skinspheres_instance_destroy(c_instance);
  skinspheres_asset_release(c_asset);
  std::printf("%s\n", failures ? "FAILED" : "all jobs ran");
  return failures ? 1 : 0;
}
