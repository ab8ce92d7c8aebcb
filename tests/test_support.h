// Helpers shared by the tests: where the shared characters are, temporary files.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "skinspheres/lib/character/raw_character.h"
#include "skinspheres/skinning/parallel_for.h"

namespace skinspheres::test {

// The shared characters folder (../shared/assets from the project root), or empty when absent.
std::filesystem::path AssetDir();
// Full path of a shared character, or empty when it is not there.
std::filesystem::path Asset(const std::string& file_name);
// The four shared characters' file names.
const std::vector<std::string>& SharedCharacters();
// The built-in character (lib::MakeBuiltinCharacter()), made once per test process.
const lib::RawCharacter& BuiltinCharacter();
// A fresh, empty folder under the build tree for this test's files (one per running test).
std::filesystem::path TempDir(const std::string& name);
// A stand-in for an engine's job system: splits [0, count) into ranges of `grain` items and runs
// them on `threads` std::threads, last range first, so no code can depend on TBB or on the order.
ParallelFor EngineStyleFor(int threads);

}  // namespace skinspheres::test

// Skips the current test with a message when a shared character is missing.
#define SKINSPHERES_REQUIRE_ASSET(path_var, file_name)                                   \
  const std::filesystem::path path_var = ::skinspheres::test::Asset(file_name);          \
  if (path_var.empty()) GTEST_SKIP() << "shared asset " << (file_name)                   \
                                     << " not found under " SKINSPHERES_ASSET_DIR
