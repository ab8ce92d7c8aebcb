// What a character reports does not depend on how it was fitted (runtime narrow_phase/contact_rules.h):
// the same triangle pairs and part-pair depths, frame by frame, from the default fit, from a fit with --max-spheres at
// the character's part count, and from a fit with triangle pieces, in exact and in fast mode, and each equal to the
// sphere-free oracle. On the built-in character and every shared character present, with their own clips and, where the
// rigs match by name (Soldier and Xbot), each other's clips retargeted as `play --clips` retargets them. The same
// loading, fitting and retargeting as the tool.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include "clip_files.h"
#include "commands.h"
#include "skinspheres/lib/fit/sphere_fitter.h"
#include "skinspheres/runtime/api/character.h"
#include "skinspheres/runtime/narrow_phase/narrow_phase.h"
#include "skinspheres/skinning/local_to_model_job.h"
#include "skinspheres/skinning/sampling_job.h"
#include "skinspheres/skinning/skinning_job.h"
#include "skinspheres/skinning/skinning_matrices_job.h"
#include "test_support.h"

namespace skinspheres::tool {
namespace {

// At most this many frames of each clip, evenly spread over it at 30 fps (the test's time).
constexpr int kFramesPerClip = 8;

// What a report says, without what follows from the fit (the sphere pairs that own the contacts):
// per part pair its parts, counts and depth (its flood walks the mesh's triangles, not the spheres),
// and every triangle pair with its kind.
using Report = std::vector<std::tuple<uint16_t, uint16_t, uint32_t, uint32_t, float, uint32_t, uint32_t, int>>;
Report ReportOf(const runtime::FrameContacts& c) {
  Report r;
  for (const runtime::PartContact& p : c.parts) {
    for (uint32_t k = p.first_triangle_pair; k < p.first_triangle_pair + p.triangle_pair_count; ++k) {
      const runtime::TriangleContact& t = c.triangle_pairs[k];
      r.emplace_back(p.part_a, p.part_b, p.triangle_pair_count, p.intersecting_count, p.depth, t.triangle_a,
                     t.triangle_b, int(t.kind));
    }
  }
  return r;
}

struct Fit {
  std::string label;
  std::shared_ptr<const runtime::CharacterAsset> asset;
};

// The three fits, each as an asset.
std::vector<Fit> ThreeFits(const LoadedCharacter& loaded) {
  size_t parts = 0;
  for (const auto& p : loaded.parts.parts) parts += !p.triangles.empty();
  std::vector<std::pair<std::string, lib::FitSettings>> settings(3);
  settings[0].first = "default";
  settings[1].first = "--max-spheres " + std::to_string(parts);
  settings[1].second.max_spheres = int(parts);
  settings[2].first = "--piece-edge 0.02";
  settings[2].second.piece_edge = 0.02f;
  std::vector<Fit> fits;
  for (const auto& [label, s] : settings) {
    auto fit = lib::FitSpheres(loaded.character, loaded.parts, s);
    EXPECT_TRUE(fit.ok()) << label << ": " << fit.error().message;
    if (!fit.ok()) continue;
    if (label == "--piece-edge 0.02") {
      EXPECT_TRUE(fit->spheres.has_pieces()) << "nothing was cut";
    }
    auto asset = runtime::CharacterAsset::Create(std::move(fit->spheres));
    EXPECT_TRUE(asset.ok()) << label << ": " << asset.error().message;
    if (asset.ok()) fits.push_back({label, *asset});
  }
  return fits;
}

void ExpectTheSameFromEveryFit(const std::string& name, const std::string& path,
                               const std::vector<std::string>& others) {
  auto loaded = LoadCharacter(path, "");
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  const size_t own = loaded->character.clips.size();
  if (!others.empty()) {
    ClipFileOptions options;
    options.files = others;
    std::vector<std::string> notes;
    ASSERT_EQ(AddClipFiles(*loaded, options, 30.0f, &notes), std::nullopt);
  }
  const std::vector<Fit> fits = ThreeFits(*loaded);
  ASSERT_EQ(fits.size(), 3u);
  const lib::RawCharacter& ch = loaded->character;
  std::vector<runtime::CharacterInstance> instances;
  for (const Fit& f : fits) {
    auto instance = runtime::CharacterInstance::Create(f.asset);
    ASSERT_TRUE(instance.ok());
    instances.push_back(std::move(*instance));
  }
  std::vector<skinning::Transform> local(ch.skeleton.size());
  std::vector<Mat4f> world(ch.skeleton.size()), bind(ch.skin.binds.size());
  std::vector<Eigen::Vector3f> positions(ch.vertex_count(), Eigen::Vector3f::Zero());
  runtime::FrameContacts oracle;
  size_t frames = 0, pairs = 0, compared = 0;
  for (const skinning::AnimationClip& clip : ch.clips) {
    const int count = std::max(1, int(clip.duration_s * 30.0f) + 1);
    const int stride = std::max(1, (count + kFramesPerClip - 1) / kFramesPerClip);
    for (int f = 0; f < count; f += stride) {
      const float t = std::min(clip.duration_s, float(f) / 30.0f);
      skinning::LocalToModelJob l2m;
      l2m.skeleton = &ch.skeleton;
      l2m.input = local;
      l2m.output = world;
      ASSERT_TRUE((skinning::SamplingJob{&clip, &ch.skeleton, t, local}.Run()));
      ASSERT_TRUE(l2m.Run());
      ASSERT_TRUE((skinning::SkinningMatricesJob{ch.skin.binds, world, bind}.Run()));
      skinning::SkinningJob skin;
      skin.joint_matrices = bind;
      skin.vertex_count = ch.vertex_count();
      skin.in_positions = {reinterpret_cast<const float*>(ch.skin.positions_bind.data()), 3 * ch.vertex_count()};
      skin.out_positions = {reinterpret_cast<float*>(positions.data()), 3 * positions.size()};
      skin.influence_offsets = ch.skin.influence_offsets;
      skin.influence_binds = ch.skin.influence_binds;
      skin.influence_weights = ch.skin.influence_weights;
      ASSERT_TRUE(skin.Run());
      const std::string at = name + " " + clip.name + " @" + std::to_string(t);
      const runtime::CharacterAsset& first = *fits[0].asset;
      ASSERT_TRUE(runtime::FindContactsBruteForce(first.sphere_set(), *first.narrow_phase(), first.filter(), positions,
                                                  &oracle));
      const Report expected = ReportOf(oracle);
      ++frames;
      pairs += oracle.triangle_pairs.size();
      for (size_t k = 0; k < fits.size(); ++k) {
        for (const bool fast : {false, true}) {
          runtime::CharacterInstance& in = instances[k];
          ASSERT_TRUE((fast ? in.UpdateFast(world) : in.UpdateExact(positions, world)).ok());
          // Exact mode reads the positions given; fast mode skins its own (to the same bits).
          const auto st = fast ? in.FindContacts() : in.FindContacts(positions);
          ASSERT_TRUE(st.ok()) << st.message;
          EXPECT_EQ(ReportOf(in.contacts()), expected) << at << ": " << fits[k].label << (fast ? " fast" : " exact");
          ++compared;
        }
      }
    }
  }
  std::printf("[fit independence] %s: %zu clips (%zu its own), %zu frames, %zu triangle pairs, %zu reports compared\n",
              name.c_str(), ch.clips.size(), own, frames, pairs, compared);
  EXPECT_GT(pairs, 0u) << name << ": no contact at all, the comparison means nothing";
}

TEST(FitIndependence, BuiltinCharacter) { ExpectTheSameFromEveryFit("builtin", "", {}); }

class FitIndependenceShared : public ::testing::TestWithParam<std::string> {};

TEST_P(FitIndependenceShared, SameTrianglePairsFromEveryFitInBothModes) {
  SKINSPHERES_REQUIRE_ASSET(path, GetParam());
  // The rigs that match by name take each other's clips.
  std::vector<std::string> others;
  for (const std::string& other : {std::string("Soldier.glb"), std::string("Xbot.glb")}) {
    if (GetParam() != other && (GetParam() == "Soldier.glb" || GetParam() == "Xbot.glb") &&
        !test::Asset(other).empty()) {
      others.push_back(test::Asset(other).string());
    }
  }
  ExpectTheSameFromEveryFit(GetParam(), path.string(), others);
}

INSTANTIATE_TEST_SUITE_P(SharedCharacters, FitIndependenceShared, ::testing::ValuesIn(test::SharedCharacters()),
                         [](const auto& param_info) { return param_info.param.substr(0, param_info.param.find('.')); });

}  // namespace
}  // namespace skinspheres::tool
