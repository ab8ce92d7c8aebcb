// soak: many frames through the engine API (runtime/character.h), checking what must hold however
// long a game runs:
//  - after warm-up, the per-frame calls allocate nothing (operator new is counted around them) and
//    the process's resident memory (RSS, /proc/self/statm) stays flat;
//  - every `--check-every` frames, each instance's spheres (bit for bit) and contacts equal those of
//    a fresh instance given the same pose (frame-to-frame state such as the broad phase's sort
//    order and sweep axis never changes a result);
//  - every update succeeds.
// Scenarios: each refit mode in kModes, for one character and for a crowd (CrowdUpdateAndFindSpherePairs,
// parallel). Poses: the built-in character's clips, sampled at 30 fps into a ring of poses once
// (the soak measures the engine, not the sampling); crowd member k runs `k * 37` poses ahead.
//
// Modes: the broad phase alone (fast, exact), and the narrow phase behind it (FindContacts; for the
// crowd CrowdUpdateAndFindContacts): "narrow-a" refits exactly and passes the skinned positions
// (mode a), "narrow-b" refits fast and skins lazily from the joint matrices (mode b). For the
// narrow modes the fresh-instance check also compares the triangle contacts (FrameContacts ==).
//
//   soak [--frames N] [--crowd K] [--check-every M] [--rss checked|unchecked]
//        (defaults 100000, 8, 997, checked)
// CTest runs it with 3000 frames (tests/CMakeLists.txt); docs/LIMITS.md quotes a 100,000-frame run.
// `--rss unchecked` is for sanitizer builds only (CMake passes it there): ASan's quarantine and
// TSan's shadow memory grow the RSS while the program allocates nothing, so the RSS columns are
// printed but not judged, and the output says so; the plain build (scripts/test) judges them.
// Exit 0 and "soak: ok" when everything held, else 1 and what failed.
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <new>
#include <string>
#include <vector>

#include "skinspheres/lib/body_parts/body_parts.h"
#include "skinspheres/lib/character/builtin_character.h"
#include "skinspheres/lib/fit/sphere_fitter.h"
#include "skinspheres/runtime/api/character.h"
#include "skinspheres/runtime/crowd/crowd.h"
#include "skinspheres/skinning/local_to_model_job.h"
#include "skinspheres/skinning/sampling_job.h"
#include "skinspheres/skinning/skinning_job.h"

// ---- Allocation counting: operator new while `g_counting` is set. ----
namespace {
bool g_counting = false;
size_t g_allocations = 0;
void* Allocate(size_t n) {
  if (g_counting) ++g_allocations;
  if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}
}  // namespace
void* operator new(size_t n) { return Allocate(n); }
void* operator new[](size_t n) { return Allocate(n); }
void* operator new(size_t n, const std::nothrow_t&) noexcept {
  if (g_counting) ++g_allocations;
  return std::malloc(n == 0 ? 1 : n);
}
void* operator new[](size_t n, const std::nothrow_t& t) noexcept { return operator new(n, t); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, size_t) noexcept { std::free(p); }
void operator delete[](void* p, size_t) noexcept { std::free(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { std::free(p); }

namespace {

using namespace skinspheres;

struct Mode {
  const char* name;
  runtime::RefitMode refit;
  bool narrow;  // FindContacts after FindSpherePairs (mode a in exact refits, mode b in fast ones)
};
constexpr Mode kModes[] = {{"fast", runtime::RefitMode::kFast, false},
                           {"exact", runtime::RefitMode::kExact, false},
                           {"narrow-a", runtime::RefitMode::kExact, true},
                           {"narrow-b", runtime::RefitMode::kFast, true}};

struct Pose {
  std::vector<Mat4f> joint_world;
  std::vector<Eigen::Vector3f> skinned;
};

size_t ResidentBytes() {
  std::ifstream statm("/proc/self/statm");
  size_t pages_total = 0, pages_resident = 0;
  statm >> pages_total >> pages_resident;
  return pages_resident * static_cast<size_t>(sysconf(_SC_PAGESIZE));
}

std::vector<Pose> MakePoses(const lib::RawCharacter& ch, size_t per_clip) {
  std::vector<Pose> poses;
  std::vector<skinning::Transform> locals(ch.skeleton.size());
  std::vector<Mat4f> bind(ch.skin.binds.size());
  for (const auto& clip : ch.clips) {
    for (size_t f = 0; f < per_clip; ++f) {
      Pose p;
      p.joint_world.resize(ch.skeleton.size());
      p.skinned.resize(ch.vertex_count());
      skinning::SamplingJob{&clip, &ch.skeleton, skinning::LoopTime(f / 30.0f, clip.duration_s), locals}.Run();
      skinning::LocalToModelJob l2m;
      l2m.skeleton = &ch.skeleton;
      l2m.input = locals;
      l2m.output = p.joint_world;
      l2m.Run();
      for (size_t b = 0; b < bind.size(); ++b) {
        bind[b] = p.joint_world[ch.skin.binds[b].joint] * ch.skin.binds[b].inverse_bind;
      }
      skinning::SkinningJob skin;
      skin.joint_matrices = bind;
      skin.vertex_count = ch.vertex_count();
      skin.in_positions = {reinterpret_cast<const float*>(ch.skin.positions_bind.data()), 3 * ch.vertex_count()};
      skin.out_positions = {reinterpret_cast<float*>(p.skinned.data()), 3 * ch.vertex_count()};
      skin.influence_offsets = ch.skin.influence_offsets;
      skin.influence_binds = ch.skin.influence_binds;
      skin.influence_weights = ch.skin.influence_weights;
      skinning::SkinReference(skin);
      poses.push_back(std::move(p));
    }
  }
  return poses;
}

// The narrow phase for one instance as the crowd runs it: mode (a) with the positions in exact
// refits, mode (b) in fast ones.
bool FindContacts(runtime::CharacterInstance& instance, const runtime::CharacterFrameInput& in,
                  runtime::RefitMode mode) {
  return instance
      .FindContacts(mode == runtime::RefitMode::kExact ? in.skinned_positions : std::span<const Eigen::Vector3f>{})
      .ok();
}

// The same pose through a fresh instance: spheres bit for bit, sphere pairs equal and, in the
// narrow modes, the triangle contacts equal.
bool SameAsFresh(runtime::CharacterInstance& instance, const runtime::CharacterFrameInput& in, const Mode& mode) {
  auto fresh = runtime::CharacterInstance::Create(instance.shared_asset());
  if (!fresh.ok() || !fresh->Update(mode.refit, in.joint_world, in.skinned_positions).ok()) return false;
  const auto contacts = fresh->FindSpherePairs();
  if (mode.narrow && !FindContacts(*fresh, in, mode.refit)) return false;
  const auto a = instance.spheres(), b = fresh->spheres();
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size_bytes()) == 0 &&
         std::equal(contacts.begin(), contacts.end(), instance.sphere_pairs().begin(), instance.sphere_pairs().end()) &&
         (!mode.narrow || fresh->contacts() == instance.contacts());
}

struct Outcome {
  size_t allocations_after_warmup = 0;
  size_t rss_warm = 0, rss_end = 0;
  size_t checks = 0, mismatches = 0, failed_updates = 0, contacts = 0, triangle_contacts = 0;
};

Outcome Run(const std::shared_ptr<const runtime::CharacterAsset>& asset, const std::vector<Pose>& poses,
            const Mode& mode, size_t crowd, size_t frames, size_t check_every) {
  Outcome out;
  std::vector<runtime::CharacterInstance> instances;
  for (size_t k = 0; k < crowd; ++k) {
    instances.push_back(std::move(runtime::CharacterInstance::Create(asset).value()));
    // The lists never grow: every sphere pair, and as many triangle pairs (far more than any pose
    // of the built-in character reaches; the narrow phase reports each triangle pair once).
    instances.back().ReserveContacts(asset->size() * (asset->size() - 1) / 2);
  }
  std::vector<runtime::CharacterInstance*> pointers;
  for (auto& i : instances) pointers.push_back(&i);
  std::vector<runtime::CharacterFrameInput> inputs(crowd);
  const size_t warmup = std::max<size_t>(200, frames / 10);
  for (size_t f = 0; f < frames; ++f) {
    for (size_t k = 0; k < crowd; ++k) {
      const Pose& p = poses[(f + 37 * k) % poses.size()];
      inputs[k] = {p.joint_world, p.skinned};
    }
    g_counting = f >= warmup;
    if (crowd == 1) {
      if (!instances[0].Update(mode.refit, inputs[0].joint_world, inputs[0].skinned_positions).ok())
        ++out.failed_updates;
      out.contacts += instances[0].FindSpherePairs().size();
      if (mode.narrow && !FindContacts(instances[0], inputs[0], mode.refit)) ++out.failed_updates;
    } else {
      const auto status = mode.narrow ? runtime::CrowdUpdateAndFindContacts(pointers, inputs, mode.refit)
                                      : runtime::CrowdUpdateAndFindSpherePairs(pointers, inputs, mode.refit);
      if (!status.ok()) ++out.failed_updates;
      for (const auto& i : instances) out.contacts += i.sphere_pairs().size();
    }
    if (mode.narrow)
      for (const auto& i : instances) out.triangle_contacts += i.contacts().triangle_pairs.size();
    g_counting = false;
    if (f + 1 == warmup) {
      g_allocations = 0;
      out.rss_warm = ResidentBytes();
    }
    if (f % check_every == check_every - 1 || f + 1 == frames) {
      for (size_t k = 0; k < crowd; ++k) {
        ++out.checks;
        if (!SameAsFresh(instances[k], inputs[k], mode)) ++out.mismatches;
      }
    }
  }
  out.allocations_after_warmup = g_allocations;
  out.rss_end = ResidentBytes();
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  size_t frames = 100000, crowd = 8, check_every = 997;
  bool check_rss = true;
  const char* usage =
      "soak: usage: soak [--frames N>=1] [--crowd K>=2] [--check-every M>=1] [--rss checked|unchecked]\n";
  if (argc % 2 == 0) {
    std::fprintf(stderr, "%s", usage);
    return 2;
  }
  for (int a = 1; a + 1 < argc; a += 2) {
    const std::string flag = argv[a], text = argv[a + 1];
    char* end = nullptr;
    const size_t value = std::strtoull(text.c_str(), &end, 10);
    const bool number = !text.empty() && *end == '\0';
    if (flag == "--rss" && (text == "checked" || text == "unchecked"))
      check_rss = text == "checked";
    else if (flag == "--frames" && number)
      frames = value;
    else if (flag == "--crowd" && number)
      crowd = value;
    else if (flag == "--check-every" && number)
      check_every = value;
    else {
      std::fprintf(stderr, "%s", usage);
      return 2;
    }
  }
  if (frames < 1 || crowd < 2 || check_every < 1) {
    std::fprintf(stderr, "%s", usage);
    return 2;
  }
  const lib::RawCharacter ch = lib::MakeBuiltinCharacter();
  auto parts = lib::SplitBodyParts(ch);
  auto fit = parts.ok() ? lib::FitSpheres(ch, *parts, lib::FitSettings{}) : Result<lib::FitResult>(parts.error());
  if (!fit.ok()) {
    std::fprintf(stderr, "soak: %s\n", fit.error().message.c_str());
    return 1;
  }
  auto asset = runtime::CharacterAsset::Create(fit->spheres);
  if (!asset.ok()) {
    std::fprintf(stderr, "soak: %s\n", asset.error().message.c_str());
    return 1;
  }
  const std::vector<Pose> poses = MakePoses(ch, 150);
  std::printf("soak: built-in character, %zu spheres, %zu vertices, %zu poses; %zu frames per scenario, crowd of %zu\n",
              (*asset)->size(), ch.vertex_count(), poses.size(), frames, crowd);
  if (!check_rss) std::printf("soak: RSS printed, not judged (--rss unchecked: a sanitizer build)\n");
  std::printf("%-8s %-6s %12s %10s %10s %9s %8s %10s %12s %12s\n", "mode", "who", "allocations", "RSS warm", "RSS end",
              "checks", "differ", "failed", "contacts", "triangles");
  bool ok = true;
  for (const Mode& mode : kModes) {
    for (size_t who : {size_t{1}, crowd}) {
      const Outcome o = Run(*asset, poses, mode, who, frames, check_every);
      // RSS: pages first touched after warm-up would show as growth; allow 1 MiB of allocator noise.
      const bool flat = !check_rss || o.rss_end <= o.rss_warm + (1u << 20);
      // A narrow mode that found no triangle contact in the whole run has tested nothing.
      const bool exercised = !mode.narrow || o.triangle_contacts > 0;
      const bool good = o.allocations_after_warmup == 0 && flat && o.mismatches == 0 && o.failed_updates == 0 &&
                        o.checks > 0 && exercised;
      std::printf("%-8s %-6s %12zu %9.1fM %9.1fM %9zu %8zu %10zu %12zu %12zu %s\n", mode.name,
                  who == 1 ? "one" : "crowd", o.allocations_after_warmup, o.rss_warm / 1048576.0, o.rss_end / 1048576.0,
                  o.checks, o.mismatches, o.failed_updates, o.contacts, o.triangle_contacts, good ? "" : "FAILED");
      ok = ok && good;
    }
  }
  std::printf(ok ? "soak: ok\n" : "soak: FAILED\n");
  return ok ? 0 : 1;
}
