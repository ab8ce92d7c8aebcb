#include "test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <system_error>
#include <thread>

#include "skinspheres/lib/character/builtin_character.h"

namespace skinspheres::test {

std::filesystem::path AssetDir() {
  std::filesystem::path dir(SKINSPHERES_ASSET_DIR);
  std::error_code ec;
  return std::filesystem::is_directory(dir, ec) ? dir : std::filesystem::path();
}

std::filesystem::path Asset(const std::string& file_name) {
  const auto dir = AssetDir();
  if (dir.empty()) return {};
  std::error_code ec;
  auto path = dir / file_name;
  return std::filesystem::is_regular_file(path, ec) ? path : std::filesystem::path();
}

const std::vector<std::string>& SharedCharacters() {
  static const std::vector<std::string> names = {"CesiumMan.glb", "RobotExpressive.glb",
                                                 "Soldier.glb", "Xbot.glb"};
  return names;
}

const lib::RawCharacter& BuiltinCharacter() {
  static const lib::RawCharacter c = lib::MakeBuiltinCharacter();
  return c;
}

std::filesystem::path TempDir(const std::string& name) {
  // One folder per test: CTest runs the tests of one executable in parallel processes, and two
  // tests sharing a helper's folder name must not delete each other's files.
  std::string test = "no_test";
  if (const auto* info = ::testing::UnitTest::GetInstance()->current_test_info()) {
    test = std::string(info->test_suite_name()) + "." + info->name();
    for (char& c : test) {
      if (c == '/') c = '_';
    }
  }
  auto dir = std::filesystem::path(SKINSPHERES_BINARY_DIR) / "test_tmp" / test / name;
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
  std::filesystem::create_directories(dir);
  return dir;
}

ParallelFor EngineStyleFor(int threads) {
  return [threads](size_t count, size_t grain, RangeBody body) {
    grain = std::max<size_t>(grain, 1);
    const size_t ranges = (count + grain - 1) / grain;
    std::atomic<size_t> next{0};
    auto worker = [&] {
      for (size_t k = next++; k < ranges; k = next++) {
        const size_t r = ranges - 1 - k;  // last range first
        body(r * grain, std::min(count, (r + 1) * grain));
      }
    };
    std::vector<std::thread> pool;
    for (int t = 1; t < threads; ++t) pool.emplace_back(worker);
    worker();
    for (auto& t : pool) t.join();
  };
}

}  // namespace skinspheres::test
