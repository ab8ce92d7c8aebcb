#include "test_support.h"

#include <gtest/gtest.h>

#if defined(_WIN32)
#ifndef WIN32_LEAN_AND_MEAN
#define WIN32_LEAN_AND_MEAN
#endif
#include <windows.h>
#else
#include <sys/stat.h>
#include <unistd.h>
#endif

#include <algorithm>
#include <atomic>
#include <fstream>
#include <system_error>
#include <thread>

#if SKINSPHERES_TEST_EXPECT_TBB
#include <tbb/task_arena.h>
#endif

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
  static const std::vector<std::string> names = {"CesiumMan.glb", "RobotExpressive.glb", "Soldier.glb", "Xbot.glb"};
  return names;
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

void WithDefaultThreads(int threads, const std::function<void()>& body) {
#if SKINSPHERES_TEST_EXPECT_TBB
  tbb::task_arena(threads).execute(body);
#else
  (void)threads;
  body();
#endif
}

bool DefaultIsTbb() { return SKINSPHERES_TEST_EXPECT_TBB != 0; }

#if defined(_WIN32)
TestPipe::TestPipe(const std::filesystem::path&, const std::string& name) {
  path_ = L"\\\\.\\pipe\\skinspheres_test_" + std::to_wstring(GetCurrentProcessId()) + L"_" +
          std::filesystem::path(name).wstring();
  HANDLE h =
      CreateNamedPipeW(path_.c_str(), PIPE_ACCESS_OUTBOUND, PIPE_TYPE_BYTE | PIPE_NOWAIT, 1, 4096, 4096, 0, nullptr);
  ok_ = h != INVALID_HANDLE_VALUE;
  handle_ = ok_ ? h : nullptr;
}
TestPipe::~TestPipe() {
  if (handle_ != nullptr) CloseHandle(static_cast<HANDLE>(handle_));
}
std::filesystem::path DeviceNotAFile() { return "NUL"; }
#else
TestPipe::TestPipe(const std::filesystem::path& dir, const std::string& name) : path_(dir / name) {
  ok_ = ::mkfifo(path_.c_str(), 0600) == 0;
}
TestPipe::~TestPipe() = default;
std::filesystem::path DeviceNotAFile() { return "/dev/zero"; }
#endif

bool MakeLongFile(const std::filesystem::path& path, uint64_t bytes, const std::string& head) {
  {
    std::ofstream out(path, std::ios::binary);
    out << head;
    if (!out) return false;
  }
  std::error_code ec;
  std::filesystem::resize_file(path, bytes, ec);
  return !ec;
}

}  // namespace skinspheres::test
