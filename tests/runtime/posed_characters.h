// Test helpers for the runtime tests: a fitted character from the test fixtures
// (support/character_fixture.h: the set fitted with default settings and the character, made once
// per build by make_fixtures, cached per process), posed (clip frames, random poses with optional
// non-uniform scale) with the independent test oracle of support/clip_eval_for_tests.h (naive
// sampler, FK, LBS). No offline fitter: these tests build in the runtime-only tree too.
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "skinspheres/runtime/format/file_io.h"
#include "skinspheres/runtime/format/sphere_set_io.h"
#include "skinspheres/skinning/math_types.h"
#include "support/character_fixture.h"
#include "support/clip_eval_for_tests.h"
#include "test_support.h"

namespace skinspheres::test {

struct FittedCharacter {
  Character character;
  runtime::SphereSet set;
};

// nullptr (with a gtest failure) when the fixture is missing or unreadable. name: "builtin", or a
// shared character's file name ("Xbot.glb"; call SKINSPHERES_REQUIRE_ASSET first, so that a test
// skips where the shared characters are absent).
inline std::shared_ptr<const FittedCharacter> LoadFitted(const std::string& name) {
  static std::map<std::string, std::shared_ptr<const FittedCharacter>> cache;
  auto it = cache.find(name);
  if (it != cache.end()) return it->second;
  const std::filesystem::path base = FixtureDir() / name;
  auto set = runtime::LoadSphereSet(base.string() + ".ssb");
  if (!set.ok()) {
    ADD_FAILURE() << "fixture " << name << ": " << set.error().message << " (make_fixtures writes it)";
    return nullptr;
  }
  auto bytes = runtime::ReadRegularFile(base.string() + ".character", uint64_t{1} << 31, "character fixture");
  if (!bytes.ok()) {
    ADD_FAILURE() << "fixture " << name << ": " << bytes.error().message;
    return nullptr;
  }
  std::string error;
  auto character = ReadCharacter(*bytes, &error);
  if (!character) {
    ADD_FAILURE() << "fixture " << name << ".character: " << error;
    return nullptr;
  }
  auto fitted = std::make_shared<FittedCharacter>();
  fitted->character = std::move(*character);
  fitted->set = std::move(set).value();
  cache[name] = fitted;
  return fitted;
}

// Rest locals with every joint rotated by a random angle in [0, max_deg] about a random axis and,
// when scale_probability > 0, that fraction of joints scaled non-uniformly by factors in [0.6, 1.5].
inline std::vector<skinning::Transform> RandomLocal(const Character& c, std::mt19937& rng, float max_deg,
                                                    float scale_probability) {
  std::uniform_real_distribution<float> u(-1.0f, 1.0f), unit(0.0f, 1.0f), sc(0.6f, 1.5f);
  std::vector<skinning::Transform> local = c.skeleton.rest_local;
  for (auto& t : local) {
    Eigen::Vector3f axis(u(rng), u(rng), u(rng));
    if (axis.norm() < 1e-3f) axis = Eigen::Vector3f::UnitX();
    const float angle = unit(rng) * max_deg * 3.14159265f / 180.0f;
    t.rotation = (t.rotation * skinspheres::Quatf(Eigen::AngleAxisf(angle, axis.normalized()))).normalized();
    if (unit(rng) < scale_probability) t.scale = t.scale.cwiseProduct(Eigen::Vector3f(sc(rng), sc(rng), sc(rng)));
  }
  return local;
}

// A pose: G_j(t) per joint and every vertex skinned by the naive LBS.
struct Pose {
  std::string label;
  std::vector<skinspheres::Mat4f> world;
  std::vector<Eigen::Vector3f> positions;
};

inline Pose MakePose(const Character& c, const std::vector<skinning::Transform>& local, std::string label) {
  Pose p;
  p.label = std::move(label);
  p.world = WorldOf(c, local);
  p.positions = Skin(c, p.world);
  return p;
}

// Every clip at 30 fps, keeping at most max_frames_per_clip evenly spaced frames.
inline std::vector<Pose> ClipPoses(const Character& c, int max_frames_per_clip) {
  std::vector<Pose> poses;
  for (const auto& clip : c.clips) {
    const int frames = std::max(1, static_cast<int>(clip.duration_s * 30.0f) + 1);
    const int stride = std::max(1, (frames + max_frames_per_clip - 1) / max_frames_per_clip);
    for (int f = 0; f < frames; f += stride) {
      const float t = std::min(clip.duration_s, f / 30.0f);
      poses.push_back(MakePose(c, SampleLocal(c, clip, t), clip.name + "@" + std::to_string(t)));
    }
  }
  return poses;
}

}  // namespace skinspheres::test
