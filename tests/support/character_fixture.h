// Test fixtures: a fitted character as files, so that the runtime, skinning and C API tests need no
// offline fitter and run on every platform (a cross build replays under qemu or wine the files the
// build machine made).
//
// make_fixtures (tests/fixtures/make_fixtures.cc, built with the offline fitter) writes, per
// character ("builtin" and every shared character present), into the fixture folder:
//   <name>.ssb        the sphere set fitted with the default settings (binary, full);
//   <name>.character  the character itself (test::Character below): skeleton, clips, skin, rest
//                     positions and triangles, what the tests pose it with (support/clip_eval_for_tests.h).
// CTest makes them once per build (fixture "character_fixtures"); a cross build is pointed at the
// build machine's folder (SKINSPHERES_FIXTURE_DIR).
//
// The .character format, little-endian: "SKSCHR01", then each field in the order of the struct,
// strings as u32 length + bytes, arrays as u32 count + elements, floats as IEEE binary32. Test
// data only: the reader checks every count against the bytes left and fails on anything else.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "skinspheres/skinning/animation_clip.h"
#include "skinspheres/skinning/skeleton.h"
#include "skinspheres/skinning/skinned_mesh.h"

namespace skinspheres::test {

// What the tests read of a character: lib::RawCharacter's fields, without lib.
struct Character {
  std::string source_file;
  skinning::Skeleton skeleton;
  std::vector<skinning::AnimationClip> clips;
  skinning::SkinnedMesh skin;
  std::vector<Eigen::Vector3f> positions_rest;
  std::vector<Eigen::Vector3i> triangles;

  size_t vertex_count() const { return positions_rest.size(); }
  size_t triangle_count() const { return triangles.size(); }
};

// The bytes of a .character file.
std::string WriteCharacter(const Character& c);
// nullopt (with *error set) when the bytes are not a whole, consistent .character file.
std::optional<Character> ReadCharacter(const std::string& bytes, std::string* error);

// The folder the fixtures are in (SKINSPHERES_FIXTURE_DIR, set by CMake).
std::filesystem::path FixtureDir();

}  // namespace skinspheres::test
