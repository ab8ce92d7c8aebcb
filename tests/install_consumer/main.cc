// A program that embeds skinspheres through find_package(skinspheres) after cmake --install,
// linking skinspheres::runtime only (no Assimp): loads a sphere set and creates the asset.
#include <cstdio>

#include "skinspheres/runtime/api/character.h"
#include "skinspheres/runtime/format/sphere_set_io.h"
int main(int argc, char** argv) {
  auto set = skinspheres::runtime::LoadSphereSet(argc > 1 ? argv[1] : "missing.json");
  if (!set.ok()) {
    std::printf("%s\n", set.error().message.c_str());
    return 2;
  }
  auto asset = skinspheres::runtime::CharacterAsset::Create(std::move(set).value());
  std::printf("spheres: %zu\n", asset.ok() ? (*asset)->size() : 0);
  return 0;
}
