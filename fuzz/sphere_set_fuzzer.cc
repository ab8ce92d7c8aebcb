// Fuzz target: the sphere-set reader (runtime/src/format/sphere_set_io.cc) on any bytes, then the
// engine API on what it accepted. Properties: an error is one line naming the input; an
// accepted set passes SphereSet::Validate, writes and reads back to the same text, and an
// asset and instance made from it update (fast and exact, at the rest pose) and query without
// crashing.
#include <cstddef>
#include <cstdint>
#include <string_view>
#include <utility>

#include "fuzz_check.h"
#include "fuzz_engine.h"
#include "skinspheres/runtime/format/sphere_set_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace skinspheres;
  const std::string name = "input.spheres.json";
  auto read = runtime::ReadSphereSetJson(std::string_view(reinterpret_cast<const char*>(data), size), name);
  if (!read.ok()) {
    fuzz::CheckError(read.error(), name);
    return 0;
  }
  runtime::SphereSet& set = *read;
  SKINSPHERES_FUZZ_CHECK(!set.Validate().has_value(), set.Validate()->message);
  const std::string text = runtime::WriteSphereSetJson(set);
  auto again = runtime::ReadSphereSetJson(text, name);
  SKINSPHERES_FUZZ_CHECK(again.ok(), again.ok() ? "" : again.error().message);
  SKINSPHERES_FUZZ_CHECK(runtime::WriteSphereSetJson(*again) == text, "write, read, write differs");

  fuzz::CheckFastRefit(set, fuzz::PoseSeed(data, size));
  fuzz::DriveEngine(std::move(set));
  return 0;
}
