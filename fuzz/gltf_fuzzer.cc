// Fuzz target: the glTF 2.0 / GLB reader (lib/src/io/gltf_document.cc, importer_gltf*.cc) on any
// bytes, then sampling every clip of what it accepted. Properties: an error is one line naming
// the file; an accepted character is consistent (skeleton parents first, influences normalised
// and in range, triangles in range, rest positions finite, key times strictly increasing).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "fuzz_check.h"
#include "skinspheres/lib/io/importer.h"
#include "skinspheres/skinning/local_to_model_job.h"
#include "skinspheres/skinning/sampling_job.h"

namespace {

using namespace skinspheres;

template <typename Value>
void CheckTrack(const skinning::Track<Value>& track) {
  const size_t per_key = track.interpolation == skinning::Interpolation::kCubicSpline ? 3 : 1;
  SKINSPHERES_FUZZ_CHECK(track.values.size() == track.times_s.size() * per_key, "track sizes");
  for (size_t k = 1; k < track.times_s.size(); ++k) {
    SKINSPHERES_FUZZ_CHECK(track.times_s[k] > track.times_s[k - 1], "key times");
  }
}

// The skin: bind entries on joints, every vertex with normalised influences and a finite rest position.
void CheckSkin(const lib::RawCharacter& c) {
  const auto& skin = c.skin;
  SKINSPHERES_FUZZ_CHECK(skin.influence_offsets.size() == skin.vertex_count() + 1, "influence offsets");
  SKINSPHERES_FUZZ_CHECK(c.positions_rest.size() == skin.vertex_count(), "rest positions");
  for (const auto& b : skin.binds) {
    SKINSPHERES_FUZZ_CHECK(b.joint >= 0 && static_cast<size_t>(b.joint) < c.skeleton.size(), "bind joint");
  }
  for (size_t v = 0; v < skin.vertex_count(); ++v) {
    double sum = 0.0;
    SKINSPHERES_FUZZ_CHECK(skin.influence_offsets[v] < skin.influence_offsets[v + 1], "a vertex without influence");
    for (uint32_t k = skin.influence_offsets[v]; k < skin.influence_offsets[v + 1]; ++k) {
      SKINSPHERES_FUZZ_CHECK(skin.influence_binds[k] < skin.binds.size(), "influence bind");
      SKINSPHERES_FUZZ_CHECK(skin.influence_weights[k] > 0.0f, "influence weight");
      sum += skin.influence_weights[k];
    }
    SKINSPHERES_FUZZ_CHECK(std::abs(sum - 1.0) < 1e-4, "weights sum to " + std::to_string(sum));
    SKINSPHERES_FUZZ_CHECK(c.positions_rest[v].allFinite(), "rest position");
  }
}

// Every clip: a finite duration, tracks on joints with ordered keys, valid for the skeleton.
void CheckClips(const lib::RawCharacter& c) {
  for (const auto& clip : c.clips) {
    SKINSPHERES_FUZZ_CHECK(std::isfinite(clip.duration_s) && clip.duration_s >= 0.0f, "clip duration");
    for (const auto& track : clip.tracks) {
      SKINSPHERES_FUZZ_CHECK(track.joint >= 0 && static_cast<size_t>(track.joint) < c.skeleton.size(), "track joint");
      CheckTrack(track.translation);
      CheckTrack(track.rotation);
      CheckTrack(track.scale);
    }
    std::string why;
    SKINSPHERES_FUZZ_CHECK(skinning::ValidateClip(clip, c.skeleton, &why), why);
  }
}

void CheckCharacter(const lib::RawCharacter& c) {
  SKINSPHERES_FUZZ_CHECK(c.skeleton.Validate() && c.skeleton.size() >= 1, "skeleton");
  CheckSkin(c);
  SKINSPHERES_FUZZ_CHECK(!c.triangles.empty(), "no triangles");
  for (const auto& t : c.triangles) {
    SKINSPHERES_FUZZ_CHECK(t.minCoeff() >= 0 && static_cast<size_t>(t.maxCoeff()) < c.vertex_count(), "triangle index");
  }
  CheckClips(c);
}

// What `play` does first with each clip: sample it at its start, middle and end and pose the
// skeleton. Must not crash, whatever the keys (huge values may overflow to infinity: allowed).
void SampleClips(const lib::RawCharacter& c) {
  std::vector<skinning::Transform> locals(c.skeleton.size());
  std::vector<Mat4f> world(c.skeleton.size());
  for (const auto& clip : c.clips) {
    for (float t : {0.0f, 0.5f * clip.duration_s, clip.duration_s}) {
      skinning::SamplingJob sampling{&clip, &c.skeleton, t, locals};
      skinning::LocalToModelJob l2m;
      l2m.skeleton = &c.skeleton;
      l2m.input = locals;
      l2m.output = world;
      SKINSPHERES_FUZZ_CHECK(sampling.Run() && l2m.Run(), "sampling an accepted clip failed");
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  // A folder that does not exist: external buffer uris are looked for there and never found.
  const std::string name = "/nonexistent-fuzz-dir/input.glb";
  auto r = lib::ImportGltfBytes(std::span<const uint8_t>(data, size), name);
  if (!r.ok()) {
    fuzz::CheckError(r.error(), name);
    return 0;
  }
  CheckCharacter(*r);
  SampleClips(*r);
  return 0;
}
