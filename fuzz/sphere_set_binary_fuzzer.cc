// Fuzz target: the binary sphere-set reader (runtime/src/sphere_set_binary.cc) on any bytes, then
// the engine API on what it accepted. A mutation almost never keeps the file's checksum right, so
// the right checksum is written into the input (bytes 8..15) before reading, so that mutations reach
// the structure and value checks behind it; inputs whose length is a multiple of 7 are read as they
// are (the checksum check itself). Properties: an error is one line naming the input; an accepted
// set passes SphereSet::Validate; writing it again gives bytes that read back and write to the same
// bytes; a whole (not fast-only) set converts to JSON, which reads back and writes the same text
// (what `skinspheres convert` does); an asset and instance made from it update and query.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "fuzz_check.h"
#include "sphere_set_check.h"
#include "skinspheres/runtime/sphere_set_binary.h"
#include "skinspheres/runtime/sphere_set_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace skinspheres;
  const std::string name = "input.ssb";
  std::vector<std::byte> bytes(size);  // operator new: 16-byte aligned, as a mapped file is
  if (size != 0) std::memcpy(bytes.data(), data, size);
  if (size >= 16 && size % 7 != 0) {
    const uint64_t sum = runtime::Xxh64(std::span<const std::byte>(bytes).subspan(16));
    std::memcpy(bytes.data() + 8, &sum, sizeof sum);
  }
  auto read = runtime::ReadSphereSetBinary(bytes, name);
  if (!read.ok()) {
    fuzz::CheckError(read.error(), name);
    return 0;
  }
  runtime::SphereSet& set = *read;
  SKINSPHERES_FUZZ_CHECK(!set.Validate().has_value(), set.Validate()->message);
  const auto content = set.fast_only ? runtime::SphereSetBinaryContent::kFastOnly : runtime::SphereSetBinaryContent::kFull;
  const std::vector<std::byte> written = runtime::WriteSphereSetBinary(set, content);
  auto again = runtime::ReadSphereSetBinary(written, name);
  SKINSPHERES_FUZZ_CHECK(again.ok(), again.ok() ? "" : again.error().message);
  SKINSPHERES_FUZZ_CHECK(runtime::WriteSphereSetBinary(*again, content) == written, "write, read, write differs");
  if (!set.fast_only) {
    const std::string text = runtime::WriteSphereSetJson(set);
    auto from_json = runtime::ReadSphereSetJson(text, name);
    SKINSPHERES_FUZZ_CHECK(from_json.ok(), from_json.ok() ? "" : from_json.error().message);
    SKINSPHERES_FUZZ_CHECK(runtime::WriteSphereSetJson(*from_json) == text, "binary -> JSON -> read -> JSON differs");
  }
  fuzz::CheckEngineApi(std::move(set));
  return 0;
}
