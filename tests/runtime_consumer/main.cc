// Loads a sphere set (binary or JSON), maps the set's joints, runs one frame in the rest pose and
// prints what it found: what a runtime-only engine does, through find_package(... COMPONENTS runtime).
#include <cstdio>
#include <vector>

#include "skinspheres/runtime/api/character.h"
#include "skinspheres/runtime/format/sphere_set_io.h"
#include "skinspheres/version.h"

using namespace skinspheres;

int main(int argc, char** argv) {
  std::printf("skinspheres headers %s, library %s, default parallel loop: %s\n", SKINSPHERES_VERSION_STRING,
              LibraryVersionString(), DefaultParallelForUsesTbb() ? "tbb" : "serial");
  if (LibraryVersion() != SKINSPHERES_VERSION) return std::printf("headers and library differ\n"), 1;
  auto set = runtime::LoadSphereSet(argc > 1 ? argv[1] : "missing.ssb");
  if (!set.ok()) return std::printf("%s\n", set.error().message.c_str()), 2;
  auto asset = runtime::CharacterAsset::Create(std::move(set).value());
  if (!asset.ok()) return std::printf("%s\n", asset.error().message.c_str()), 2;
  const runtime::SphereSet& s = (*asset)->sphere_set();
  auto mapping = runtime::MapJoints(s, s.joint_names);
  if (!mapping.ok()) return std::printf("%s\n", mapping.error().message.c_str()), 2;
  auto instance = runtime::CharacterInstance::Create(*asset, *mapping);
  if (!instance.ok()) return std::printf("%s\n", instance.error().message.c_str()), 2;
  // A pose both consumers can make without animation data: the rest pose with every joint's
  // translation halved (the body folds onto itself, so spheres touch).
  std::vector<Mat4f> squashed = s.joint_rest_world;
  for (Mat4f& m : squashed) m.topRightCorner<3, 1>() *= 0.5f;
  const runtime::FrameStatus st = instance->UpdateFast(squashed);
  if (!st.ok()) return std::printf("update: %s\n", st.message), 1;
  std::printf("spheres: %zu, squashed-pose contacts: %zu\n", (*asset)->size(), instance->FindSpherePairs().size());
  return 0;
}
