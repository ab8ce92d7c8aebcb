// Fuzz target: the binary sphere-set reader (runtime/src/format/sphere_set_binary_reader.cc) on any bytes, from
// memory (the checked view on an aligned buffer, and the copying reader at an odd address) and
// from a file, then the engine API on what it accepted.
//
// Nearly every mutation breaks the XXH64 checksum, which would stop the fuzzer at that one check,
// so an input is read twice: as it is (magic, version, checksum and size checks), and with its
// checksum recomputed (bytes 8..15 = Xxh64 of bytes 16..), which lets mutations reach the
// structure checks and the values.
//
// Properties: an error is one line naming the source, and every route gives the same answer; an
// accepted set passes Validate, its encoding reads back and encodes to the same bytes, a full set
// goes to JSON and back to the same bytes, and the engine runs on it.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "fuzz_check.h"
#include "fuzz_engine.h"
#include "skinspheres/runtime/format/sphere_set_binary.h"
#include "skinspheres/runtime/format/sphere_set_io.h"

namespace {

using namespace skinspheres;

// A file for the file route, one per process, removed at exit.
struct ScratchFile {
  std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("skinspheres_fuzz_binary_" + std::to_string(::getpid()) + ".ssb");
  ~ScratchFile() {
    std::error_code ec;
    std::filesystem::remove(path, ec);
  }
};

const std::string kName = "input.ssb";

std::string Message(const Result<runtime::SphereSet>& r) { return r.ok() ? "accepted" : r.error().message; }

// Reads `bytes` by every route; the routes must agree. Returns what the aligned memory route read.
Result<runtime::SphereSet> ReadEveryWay(std::span<const std::byte> bytes) {
  const std::vector<std::byte> aligned(bytes.begin(), bytes.end());  // operator new: 16-byte aligned
  auto view = runtime::SphereSetBinaryView::Open(aligned, kName);
  auto read = runtime::ReadSphereSetBinary(aligned, kName);

  std::vector<std::byte> shifted(bytes.size() + 1);
  if (!bytes.empty()) std::memcpy(shifted.data() + 1, bytes.data(), bytes.size());
  auto read_odd = runtime::ReadSphereSetBinary(std::span<const std::byte>(shifted).subspan(1), kName);

  static const ScratchFile scratch;
  {
    std::ofstream out(scratch.path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    SKINSPHERES_FUZZ_CHECK(out.good(), "cannot write " + scratch.path.string());
  }
  auto loaded = runtime::LoadSphereSetBinary(scratch.path);

  if (!view.ok()) {
    fuzz::CheckError(view.error(), kName);
    SKINSPHERES_FUZZ_CHECK(!read.ok(), "the view refused what the reader accepted: " + view.error().message);
  }
  if (!read.ok()) {
    fuzz::CheckError(read.error(), kName);
    SKINSPHERES_FUZZ_CHECK(!read_odd.ok() && read_odd.error().message == read.error().message,
                           read.error().message + " / at an odd address: " + Message(read_odd));
    SKINSPHERES_FUZZ_CHECK(!loaded.ok(), read.error().message + " / from the file: accepted");
    fuzz::CheckError(loaded.error(), scratch.path.string());
    SKINSPHERES_FUZZ_CHECK(loaded.error().code == read.error().code,
                           read.error().message + " / " + loaded.error().message);
    return read;
  }
  SKINSPHERES_FUZZ_CHECK(read_odd.ok() && loaded.ok(),
                         "accepted in memory; odd address: " + Message(read_odd) + "; file: " + Message(loaded));
  const std::vector<std::byte> encoded = runtime::WriteSphereSetBinary(*read);
  SKINSPHERES_FUZZ_CHECK(runtime::WriteSphereSetBinary(*read_odd) == encoded, "odd address read another set");
  SKINSPHERES_FUZZ_CHECK(runtime::WriteSphereSetBinary(*loaded) == encoded, "the file route read another set");
  return read;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::vector<std::byte> bytes(size);
  if (size > 0) std::memcpy(bytes.data(), data, size);
  auto read = ReadEveryWay(bytes);
  if (!read.ok() && size >= 16) {
    const uint64_t sum = runtime::Xxh64(std::span<const std::byte>(bytes).subspan(16));
    std::memcpy(bytes.data() + 8, &sum, sizeof sum);  // little-endian host (the format requires one)
    read = ReadEveryWay(bytes);
  }
  if (!read.ok()) return 0;

  runtime::SphereSet& set = *read;
  SKINSPHERES_FUZZ_CHECK(!set.Validate().has_value(), set.Validate()->message);
  const auto content =
      set.fast_only ? runtime::SphereSetBinaryContent::kFastOnly : runtime::SphereSetBinaryContent::kFull;
  const std::vector<std::byte> encoded = runtime::WriteSphereSetBinary(set, content);
  auto again = runtime::ReadSphereSetBinary(encoded, kName);
  SKINSPHERES_FUZZ_CHECK(again.ok(), Message(again));
  SKINSPHERES_FUZZ_CHECK(runtime::WriteSphereSetBinary(*again, content) == encoded, "write, read, write differs");
  if (!set.fast_only) {
    auto from_json = runtime::ReadSphereSetJson(runtime::WriteSphereSetJson(set), "input.spheres.json");
    SKINSPHERES_FUZZ_CHECK(from_json.ok(), Message(from_json));
    SKINSPHERES_FUZZ_CHECK(runtime::WriteSphereSetBinary(*from_json) == encoded, "binary -> JSON -> binary differs");
  }
  fuzz::CheckFastRefit(set, fuzz::PoseSeed(data, size));
  fuzz::DriveEngine(std::move(set));
  return 0;
}
