// Helpers shared by the tests: where the shared characters are, temporary files, thread counts.
// Everything but BuiltinCharacter() builds without the offline fitter (the runtime-only tree of a
// cross build); BuiltinCharacter() exists where the tests link lib/ (SKINSPHERES_TEST_WITH_LIB).
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "skinspheres/skinning/parallel_for.h"
#if SKINSPHERES_TEST_WITH_LIB
#include "skinspheres/lib/character/raw_character.h"
#endif

namespace skinspheres::test {

// The shared characters folder (../shared/assets from the project root), or empty when absent.
std::filesystem::path AssetDir();
// Full path of a shared character, or empty when it is not there.
std::filesystem::path Asset(const std::string& file_name);
// The four shared characters' file names.
const std::vector<std::string>& SharedCharacters();
#if SKINSPHERES_TEST_WITH_LIB
// The built-in character (lib::MakeBuiltinCharacter()), made once per test process.
const lib::RawCharacter& BuiltinCharacter();
#endif
// A fresh, empty folder under the build tree for this test's files (one per running test).
std::filesystem::path TempDir(const std::string& name);
// A stand-in for an engine's job system: splits [0, count) into ranges of `grain` items and runs
// them on `threads` std::threads, last range first, so no code can depend on TBB or on the order.
ParallelFor EngineStyleFor(int threads);
// Runs `body` with the default ParallelFor (DefaultParallelFor) limited to `threads` threads: in a
// TBB arena of that size with TBB; as it is without TBB (the default is then the serial loop).
void WithDefaultThreads(int threads, const std::function<void()>& body);
// Whether the default ParallelFor runs on TBB in this build.
bool DefaultIsTbb();

// A pipe nobody writes to, named by a path a reader can be handed: a FIFO in `dir` (POSIX), or a
// named pipe \\.\pipe\... (Windows; its server end is held open while this lives). ok() false
// (and the caller fails) when it could not be made.
class TestPipe {
 public:
  TestPipe(const std::filesystem::path& dir, const std::string& name);
  ~TestPipe();
  TestPipe(const TestPipe&) = delete;
  TestPipe& operator=(const TestPipe&) = delete;
  bool ok() const { return ok_; }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
  void* handle_ = nullptr;
  bool ok_ = false;
};
// A device that is not a file: /dev/zero (it never ends), or NUL on Windows.
std::filesystem::path DeviceNotAFile();
// A file `bytes` long, sparse where the file system allows (std::filesystem::resize_file).
bool MakeLongFile(const std::filesystem::path& path, uint64_t bytes, const std::string& head);

}  // namespace skinspheres::test

// Skips the current test with a message when a shared character is missing.
#define SKINSPHERES_REQUIRE_ASSET(path_var, file_name)                          \
  const std::filesystem::path path_var = ::skinspheres::test::Asset(file_name); \
  if (path_var.empty()) GTEST_SKIP() << "shared asset " << (file_name) << " not found under " SKINSPHERES_ASSET_DIR
