#include "test_support.h"

#include <system_error>

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

std::filesystem::path TempDir(const std::string& name) {
  auto dir = std::filesystem::path(SKINSPHERES_BINARY_DIR) / "test_tmp" / name;
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace skinspheres::test
