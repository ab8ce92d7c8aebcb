// The binary sphere-set asset (sphere_set_binary.h): XXH64 against the reference library's values,
// lossless both ways with the JSON (compared as JSON text, which holds every field), the fast-only
// variant (same fast spheres, exact mode refused), memory-mapping, and fuzz-style refusals: every
// prefix, every byte flipped (with and without a fixed-up checksum), absurd counts and offsets,
// none of which may crash or allocate more than the input justifies.

#include <fcntl.h>
#include <gtest/gtest.h>

#include "skinspheres/runtime/format/sphere_set_binary.h"
#if defined(_WIN32)
#ifndef WIN32_LEAN_AND_MEAN
#define WIN32_LEAN_AND_MEAN
#endif
#include <windows.h>
#else
#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>
#endif

#include <algorithm>
#include <cstring>
#include <functional>
#include <nlohmann/json.hpp>
#include <random>
#include <string>

#include "allocation_counter.h"
#include "runtime/format/binary_edit.h"
#include "runtime/format/contact_rules_sets.h"
#include "runtime/posed_characters.h"
#include "runtime/sample_sphere_set.h"
#include "skinspheres/runtime/api/character.h"
#include "skinspheres/runtime/format/file_io.h"
#include "skinspheres/runtime/format/sphere_set_io.h"
#include "skinspheres/runtime/refit/refit_job.h"
#include "test_support.h"

namespace skinspheres::runtime {
namespace {

using namespace test_binary;  // binary_edit.h: Bytes, Get32, Put32, FixChecksum, EntryOf

std::span<const std::byte> AsBytes(std::string_view s) {
  return {reinterpret_cast<const std::byte*>(s.data()), s.size()};
}

// A set with everything non-trivial: the built-in character's fit (mesh, parts, exclusions, a
// params object), or the small hand-made one when a test wants every byte position.
const SphereSet& Builtin() {
  static const SphereSet set = [] {
    auto fc = test::LoadFitted("builtin");
    return fc ? fc->set : SphereSet{};
  }();
  return set;
}

SphereSet Small() {
  SphereSet set = TwoSpheresWithMesh();
  set.source_file = "small.glb";
  set.params_json = R"({"rays":80})";
  set.parts.push_back({"head", {0}});
  set.sphere_part[1] = 1;
  return set;
}

// The file as a writer of layout `version` (1 to 5) wrote it: the sections that version lacks left
// out (28-40 for version 1, 29-40 for version 2, 34-40 for version 3, 37-40 for version 4, 39-40 for
// version 5), the others laid out again as the writer lays them out (table, then each section on the
// next 16-byte boundary, zero padding), the version, the checksum. A file before layout 6 states its
// contact rules on sphere pairs: it reads as WithRulesOnSpherePairs of the set written.
Bytes Downgrade(const Bytes& v2, uint32_t version) {
  struct Entry {
    uint32_t id, element_size;
    uint64_t offset, count;
  };
  std::vector<Entry> entries;
  for (uint32_t k = 0; k < Get32(v2, 32); ++k) {
    const size_t at = kSphereSetBinaryHeaderSize + k * kSphereSetBinarySectionEntrySize;
    const Entry e{Get32(v2, at), Get32(v2, at + 4), Get64(v2, at + 8), Get64(v2, at + 16)};
    const uint32_t first_dropped = static_cast<uint32_t>(version == 1   ? SphereSetSection::kInfluenceReach
                                                         : version == 2 ? SphereSetSection::kFastReferenceInverse
                                                         : version == 3 ? SphereSetSection::kPiecePoints
                                                         : version == 4 ? SphereSetSection::kReachGroupBlend
                                                                        : SphereSetSection::kContactRules);
    if (e.id < first_dropped) entries.push_back(e);
  }
  const auto align = [](size_t n) { return (n + 15) / 16 * 16; };
  size_t at = align(kSphereSetBinaryHeaderSize + entries.size() * kSphereSetBinarySectionEntrySize);
  Bytes out(kSphereSetBinaryHeaderSize + entries.size() * kSphereSetBinarySectionEntrySize, std::byte{0});
  std::copy_n(v2.begin(), kSphereSetBinaryHeaderSize, out.begin());
  for (size_t k = 0; k < entries.size(); ++k) {
    const Entry& e = entries[k];
    const size_t entry = kSphereSetBinaryHeaderSize + k * kSphereSetBinarySectionEntrySize;
    Put32(out, entry, e.id);
    Put32(out, entry + 4, e.element_size);
    Put64(out, entry + 8, at);
    Put64(out, entry + 16, e.count);
    out.resize(at + e.count * e.element_size, std::byte{0});
    std::copy_n(v2.begin() + static_cast<ptrdiff_t>(e.offset), e.count * e.element_size,
                out.begin() + static_cast<ptrdiff_t>(at));
    at = align(at + e.count * e.element_size);
  }
  out.resize(at, std::byte{0});
  Put32(out, 16, version);
  Put32(out, 32, static_cast<uint32_t>(entries.size()));
  Put64(out, 24, out.size());
  FixChecksum(out);
  return out;
}

// Reads, watching the largest allocation; checks a refusal names the source in one line.
Result<SphereSet> Read(const Bytes& b, size_t* largest = nullptr) {
  test::AllocationCounter counter;
  auto read = ReadSphereSetBinary(b, "in.ssb");
  if (largest) *largest = counter.largest();
  if (!read.ok()) {
    EXPECT_EQ(read.error().message.rfind("in.ssb: ", 0), 0u) << read.error().message;
    EXPECT_EQ(read.error().message.find('\n'), std::string::npos) << read.error().message;
  }
  return read;
}

TEST(Xxh64Test, MatchesTheReferenceImplementation) {
  // Values from libxxhash 0.8.1's XXH64 (the reference implementation), seed 0 unless given.
  auto h = [](std::string_view s, uint64_t seed = 0) { return Xxh64(AsBytes(s), seed); };
  EXPECT_EQ(h(""), 0xef46db3751d8e999ull);
  EXPECT_EQ(h("a"), 0xd24ec4f1a98c6e5bull);
  EXPECT_EQ(h("abc"), 0x44bc2cf5ad770999ull);
  EXPECT_EQ(h("0123456789abcdef0123456789abcdef!"), 0x8afff4daac4e677eull);  // 33 bytes: stripes + tail
  std::string long_input;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 256; ++c) long_input.push_back(static_cast<char>(c));
  }
  long_input += "xyz";
  EXPECT_EQ(h(long_input), 0xe921a1b45bd779f8ull);  // 771 bytes
  EXPECT_EQ(h("abc", 12345), 0x01700e64f6f23509ull);
}

// Every set both ways, whatever its contact rules: on triangles (the fitted set and hand-made ones,
// at hops 0, 1 and 2, with and without a rest gap) and on sphere pairs (as read from files before
// them, JSON versions 1 to 3).
TEST(SphereSetBinaryTest, LosslessBothWaysWithTheJson) {
  ASSERT_GT(Builtin().size(), 10u);
  ASSERT_EQ(Builtin().contact_rules, ContactRules::kTriangles);
  const std::vector<SphereSet> sets = {Builtin(),
                                       Small(),
                                       TwoSpheres(),
                                       WithRulesOnTriangles(TwoJointsWithMesh(), 0, 0.05f),
                                       WithRulesOnTriangles(TwoJointsWithPieces(), 2, 0.0123f),
                                       WithRulesOnSpherePairs(Builtin()),
                                       WithRulesOnSpherePairs(Small()),
                                       WithRulesOnSpherePairs(TwoSpheres()),
                                       WithRulesOnSpherePairs(TwoJointsWithPieces())};
  for (const SphereSet& set_ref : sets) {
    const SphereSet* set = &set_ref;
    const std::string json = WriteSphereSetJson(*set);
    auto from_json = ReadSphereSetJson(json, "a.json");
    ASSERT_TRUE(from_json.ok()) << from_json.error().message;
    const Bytes binary = WriteSphereSetBinary(*from_json);
    EXPECT_EQ(binary.size() % 16, 0u);
    EXPECT_EQ(Get64(binary, 24), binary.size());
    auto from_binary = Read(binary);
    ASSERT_TRUE(from_binary.ok()) << from_binary.error().message;
    EXPECT_FALSE(from_binary->fast_only);
    EXPECT_EQ(from_binary->has_mesh(), set->has_mesh());
    EXPECT_EQ(from_binary->loaded_from, "in.ssb");
    ExpectSameRules(*from_binary, *set);
    // JSON -> binary -> JSON: the same text; binary -> JSON -> binary: the same bytes.
    EXPECT_EQ(WriteSphereSetJson(*from_binary), json);
    EXPECT_EQ(WriteSphereSetBinary(*from_binary), binary);
  }
}

TEST(SphereSetBinaryTest, FilesAreReadByContentWhateverTheirName) {
  const auto dir = test::TempDir("sphere_set_binary_files");
  const SphereSet& set = Builtin();
  ASSERT_FALSE(SaveSphereSet(set, dir / "x.ssb").has_value());
  ASSERT_FALSE(SaveSphereSet(set, dir / "x.json").has_value());
  ASSERT_FALSE(SaveSphereSet(set, dir / "binary.json", SphereSetFileFormat::kBinary).has_value());
  EXPECT_EQ(SphereSetFormatForPath(dir / "x.ssb"), SphereSetFileFormat::kBinary);
  EXPECT_EQ(SphereSetFormatForPath(dir / "x.json"), SphereSetFileFormat::kJson);
  EXPECT_FALSE(SphereSetFormatForPath(dir / "x.txt").has_value());
  auto json_bytes = ReadSphereSetFile(dir / "x.json");
  ASSERT_TRUE(json_bytes.ok());
  EXPECT_FALSE(IsSphereSetBinary(*json_bytes));
  for (const char* name : {"x.ssb", "x.json", "binary.json"}) {
    auto loaded = LoadSphereSet(dir / name);
    ASSERT_TRUE(loaded.ok()) << loaded.error().message;
    EXPECT_EQ(loaded->loaded_from, (dir / name).string());
    EXPECT_EQ(WriteSphereSetJson(*loaded), WriteSphereSetJson(set)) << name;
  }
  auto missing = LoadSphereSetBinary(dir / "none.ssb");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, ErrorCode::kFileNotFound);
  EXPECT_NE(missing.error().message.find("none.ssb: file not found"), std::string::npos);
  auto directory = LoadSphereSet(dir);
  ASSERT_FALSE(directory.ok());
  EXPECT_NE(directory.error().message.find(dir.string()), std::string::npos);
}

// The binary reader opens files as the JSON one does (file_io.h): only a regular file, never a
// FIFO or pipe (which would block), a device (/dev/zero never ends; NUL) or a directory; a file
// over kMaxSphereSetBytes is refused from its size, before anything is allocated; writes are
// checked through the close (/dev/full fails at the flush).
TEST(SphereSetBinaryTest, OnlyRegularFilesWithinTheSizeLimitAreReadAndEveryWriteIsChecked) {
  const auto dir = test::TempDir("sphere_set_binary_hostile");
  const test::TestPipe pipe(dir, "fifo.ssb");
  ASSERT_TRUE(pipe.ok());
  const auto fifo = pipe.path();
  const auto huge = dir / "huge.ssb";  // the magic, then a sparse file one byte over the limit
  ASSERT_TRUE(test::MakeLongFile(huge, kMaxSphereSetBytes + 1,
                                 std::string(reinterpret_cast<const char*>(kSphereSetBinaryMagic), 8)));
  struct Case {
    std::filesystem::path path;
    ErrorCode code;
    std::string needle;
  };
  const Case cases[] = {
      {fifo, ErrorCode::kFileUnreadable, "pipe"},
      {test::DeviceNotAFile(), ErrorCode::kFileUnreadable, "is a device"},
      {dir, ErrorCode::kFileUnreadable, "is a directory"},
      {huge, ErrorCode::kFormatRejected, "a sphere set may be at most 536870912 bytes"},
  };
  using Loader = std::function<Result<SphereSet>(const std::filesystem::path&)>;
  const Loader loaders[] = {[](const auto& p) { return LoadSphereSetBinary(p); },
                            [](const auto& p) { return LoadSphereSet(p); }};
  for (const Case& c : cases) {
    for (const Loader& load : loaders) {
      test::AllocationCounter counter;
      // A blocking open of the FIFO would hang here (no writer ever comes): the test would time out.
      auto read = load(c.path);
      EXPECT_LT(counter.largest(), size_t{1} << 20) << c.path;  // nothing near the file's size
      ASSERT_FALSE(read.ok()) << c.path;
      EXPECT_EQ(read.error().code, c.code) << read.error().message;
      EXPECT_EQ(read.error().message.rfind(PathText(c.path) + ": ", 0), 0u) << read.error().message;
      EXPECT_NE(read.error().message.find(c.needle), std::string::npos) << read.error().message;
      EXPECT_EQ(read.error().message.find('\n'), std::string::npos) << read.error().message;
    }
  }
#if !defined(_WIN32)
  for (const SphereSetFileFormat format : {SphereSetFileFormat::kBinary, SphereSetFileFormat::kBinaryFastOnly}) {
    const auto err = SaveSphereSet(Small(), "/dev/full", format);
    ASSERT_TRUE(err.has_value());
    EXPECT_EQ(err->message.rfind("/dev/full: write failed (", 0), 0u) << err->message;
  }
#endif
  const auto onto_dir = SaveSphereSetBinary(Small(), dir);
  ASSERT_TRUE(onto_dir.has_value());
  EXPECT_EQ(onto_dir->message.rfind(PathText(dir) + ": ", 0), 0u) << onto_dir->message;
  const auto err = SaveSphereSetBinary(Small(), dir / "no_such_dir" / "x.ssb");
  ASSERT_TRUE(err.has_value());
  EXPECT_NE(err->message.find("cannot open for writing"), std::string::npos) << err->message;
}

TEST(SphereSetBinaryTest, FastOnlyGivesTheSameFastSpheresAndRefusesExactMode) {
  const SphereSet& full = Builtin();
  const Bytes fast_bytes = WriteSphereSetBinary(full, SphereSetBinaryContent::kFastOnly);
  const Bytes full_bytes = WriteSphereSetBinary(full);
  EXPECT_LT(fast_bytes.size(), full_bytes.size() / 2);
  auto fast = Read(fast_bytes);
  ASSERT_TRUE(fast.ok()) << fast.error().message;
  EXPECT_TRUE(fast->fast_only);
  EXPECT_FALSE(fast->has_mesh());
  EXPECT_TRUE(fast->vertices.empty() && fast->triangles.empty());
  // Writing a fast-only set again keeps it fast-only, byte for byte, even when asked for kFull.
  EXPECT_EQ(WriteSphereSetBinary(*fast, SphereSetBinaryContent::kFull), fast_bytes);
  EXPECT_FALSE(Read(WriteSphereSetBinary(*fast))->vertices.size());

  auto full_asset = CharacterAsset::Create(full);
  auto fast_asset = CharacterAsset::Create(*fast);
  ASSERT_TRUE(full_asset.ok() && fast_asset.ok());
  auto a = CharacterInstance::Create(*full_asset);
  auto b = CharacterInstance::Create(*fast_asset);
  ASSERT_TRUE(a.ok() && b.ok());
  auto fc = test::LoadFitted("builtin");
  ASSERT_TRUE(fc);
  size_t frames_with_contacts = 0;
  for (const test::Pose& pose : test::ClipPoses(fc->character, 12)) {
    ASSERT_TRUE(a->UpdateFast(pose.world).ok());
    ASSERT_TRUE(b->UpdateFast(pose.world).ok());
    ASSERT_TRUE(std::equal(a->spheres().begin(), a->spheres().end(), b->spheres().begin(), b->spheres().end()));
    const std::vector<SpherePair> ca(a->FindSpherePairs().begin(), a->FindSpherePairs().end());
    const auto cb = b->FindSpherePairs();
    EXPECT_TRUE(std::equal(ca.begin(), ca.end(), cb.begin(), cb.end())) << pose.label;
    frames_with_contacts += !ca.empty();
  }
  EXPECT_GT(frames_with_contacts, 0u);

  const std::vector<Eigen::Vector3f> positions(full.source_vertex_count, Eigen::Vector3f::Zero());
  const FrameStatus st = b->UpdateExact(positions, {});
  EXPECT_EQ(st.code, ErrorCode::kInvalidArgument);
  EXPECT_NE(std::string(st.message).find("fast-only"), std::string::npos) << st.message;
  EXPECT_TRUE(b->FindSpherePairs().empty());
  RefitJob job;
  job.mode = RefitMode::kExact;
  job.set = &*fast;
  job.positions = positions;
  std::vector<Vec4f> out(fast->size());
  job.out = out;
  EXPECT_FALSE(job.Validate());

  const auto dir = test::TempDir("sphere_set_binary_fast");
  auto err = SaveSphereSet(*fast, dir / "fast.json");
  ASSERT_TRUE(err.has_value());
  EXPECT_NE(err->message.find("fast-only"), std::string::npos) << err->message;
  EXPECT_NE(err->message.find("in.ssb"), std::string::npos) << err->message;
}

TEST(SphereSetBinaryTest, AMemoryMappedFileIsReadInPlace) {
  const auto dir = test::TempDir("sphere_set_binary_mmap");
  const SphereSet& set = Builtin();
  ASSERT_FALSE(SaveSphereSetBinary(set, dir / "m.ssb").has_value());
#if defined(_WIN32)
  const HANDLE file = CreateFileW((dir / "m.ssb").c_str(), GENERIC_READ, FILE_SHARE_READ, nullptr, OPEN_EXISTING,
                                  FILE_ATTRIBUTE_NORMAL, nullptr);
  ASSERT_NE(file, INVALID_HANDLE_VALUE);
  LARGE_INTEGER file_size{};
  ASSERT_TRUE(GetFileSizeEx(file, &file_size));
  const size_t size = static_cast<size_t>(file_size.QuadPart);
  const HANDLE mapping = CreateFileMappingW(file, nullptr, PAGE_READONLY, 0, 0, nullptr);
  CloseHandle(file);
  ASSERT_NE(mapping, nullptr);
  void* map = MapViewOfFile(mapping, FILE_MAP_READ, 0, 0, 0);
  CloseHandle(mapping);
  ASSERT_NE(map, nullptr);
#else
  const int fd = ::open((dir / "m.ssb").c_str(), O_RDONLY);
  ASSERT_GE(fd, 0);
  const size_t size = static_cast<size_t>(::lseek(fd, 0, SEEK_END));
  void* map = ::mmap(nullptr, size, PROT_READ, MAP_PRIVATE, fd, 0);
  ::close(fd);
  ASSERT_NE(map, MAP_FAILED);
#endif
  const std::span<const std::byte> bytes(static_cast<const std::byte*>(map), size);
  auto view = SphereSetBinaryView::Open(bytes, "m.ssb");
  ASSERT_TRUE(view.ok()) << view.error().message;
  EXPECT_EQ(view->size(), set.size());
  EXPECT_EQ(view->source_file(), set.source_file);
  EXPECT_EQ(view->joint_name(3), set.joint_names[3]);
  EXPECT_EQ(view->part_name(0), set.parts[0].name);
  // The spans point into the mapping, 16-byte aligned, and hold the set's values.
  EXPECT_GE(reinterpret_cast<const std::byte*>(view->radii_rest().data()), bytes.data());
  EXPECT_LT(reinterpret_cast<const std::byte*>(view->radii_rest().data()), bytes.data() + size);
  EXPECT_EQ(reinterpret_cast<uintptr_t>(view->radii_rest().data()) % 16, 0u);
  EXPECT_TRUE(
      std::equal(set.radii_fast.begin(), set.radii_fast.end(), view->radii_fast().begin(), view->radii_fast().end()));
  EXPECT_TRUE(std::equal(set.influence_joints.begin(), set.influence_joints.end(), view->influence_joints().begin(),
                         view->influence_joints().end()));
  EXPECT_EQ(view->centers_rest()[3 * 5 + 1], set.centers_rest[5].y());
  ASSERT_EQ(view->contact_rules().size(), 2u);
  EXPECT_EQ(view->contact_rules()[0], static_cast<uint32_t>(ContactRules::kTriangles));
  EXPECT_EQ(view->contact_rules()[1], set.contact_hops);
  ASSERT_EQ(view->rest_gap().size(), 1u);
  EXPECT_EQ(Bits(view->rest_gap()[0]), Bits(set.rest_gap));
  auto copied = view->ToSphereSet();
  ASSERT_TRUE(copied.ok()) << copied.error().message;
  EXPECT_EQ(WriteSphereSetJson(*copied), WriteSphereSetJson(set));
  // A buffer off the 16-byte grid: the view refuses it, the reader copies it.
  Bytes shifted(size + 1);
  std::memcpy(shifted.data() + 1, map, size);
  const std::span<const std::byte> odd(shifted.data() + 1, size);
  auto refused = SphereSetBinaryView::Open(odd, "odd");
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ErrorCode::kInvalidArgument);
  EXPECT_TRUE(ReadSphereSetBinary(odd, "odd").ok());
#if defined(_WIN32)
  UnmapViewOfFile(map);
#else
  ::munmap(map, size);
#endif
}

TEST(SphereSetBinaryTest, EveryPrefixIsRefused) {
  for (const SphereSet& set : {Small(), Builtin()}) {
    const Bytes full = WriteSphereSetBinary(set);
    const size_t step = full.size() < 4096 ? 1 : 61;
    for (size_t n = 0; n < full.size(); n += step) {
      const Bytes cut(full.begin(), full.begin() + static_cast<ptrdiff_t>(n));
      auto read = Read(cut);
      ASSERT_FALSE(read.ok()) << "a prefix of " << n << " bytes was accepted";
      if (n >= 64) {
        EXPECT_NE(read.error().message.find("truncated"), std::string::npos) << read.error().message;
      }
    }
    Bytes longer = full;
    longer.push_back(std::byte{0});
    auto read = Read(longer);
    ASSERT_FALSE(read.ok());
    EXPECT_NE(read.error().message.find("1 bytes after the end"), std::string::npos) << read.error().message;
  }
}

TEST(SphereSetBinaryTest, EveryFlippedByteIsCaughtByTheChecksumOrTheHeader) {
  const Bytes good = WriteSphereSetBinary(Small());
  for (size_t at = 0; at < good.size(); ++at) {
    for (uint8_t mask : {0x01, 0x80, 0xFF}) {
      Bytes bad = good;
      bad[at] ^= std::byte{mask};
      auto read = Read(bad);
      ASSERT_FALSE(read.ok()) << "byte " << at << " ^ " << int(mask) << " was accepted";
    }
  }
}

TEST(SphereSetBinaryTest, CorruptionBehindAValidChecksumNeverCrashesNorOverAllocates) {
  // Each byte flipped, then the checksum recomputed, so the structural checks and
  // SphereSet::Validate are what stands between the bytes and the runtime. A flipped float can
  // still be a valid set; everything else must be refused; nothing may crash (the sanitizer builds
  // run this too) or allocate much more than the file holds.
  for (const SphereSet& set : {Small(), Builtin()}) {
    const Bytes good = WriteSphereSetBinary(set);
    const size_t step = good.size() < 4096 ? 1 : 53;
    size_t accepted = 0, refused = 0;
    for (size_t at = 16; at < good.size(); at += step) {
      for (uint8_t mask : {0x01, 0xFF}) {
        Bytes bad = good;
        bad[at] ^= std::byte{mask};
        FixChecksum(bad);
        size_t largest = 0;
        auto read = Read(bad, &largest);
        EXPECT_LE(largest, 2 * good.size() + 4096) << "byte " << at << " ^ " << int(mask);
        if (read.ok()) {
          ++accepted;
          EXPECT_FALSE(read->Validate().has_value());
        } else {
          ++refused;
        }
      }
    }
    EXPECT_GT(refused, 0u);
    std::printf("%zu-byte file: %zu corruptions refused, %zu still a valid set (changed values)\n", good.size(),
                refused, accepted);
  }
}

TEST(SphereSetBinaryTest, AbsurdHeadersAndTablesAreRefusedByName) {
  const Bytes good = WriteSphereSetBinary(Small());
  ASSERT_TRUE(Read(good).ok());
  using S = SphereSetSection;
  struct Case {
    const char* what;
    std::function<void(Bytes&)> edit;
    ErrorCode code;
    const char* message_part;
    bool fix_checksum = true;
  };
  const size_t radii = EntryOf(good, S::kRadiiRest), strings = EntryOf(good, S::kStringOffsets);
  const std::vector<Case> cases = {
      {"magic", [](Bytes& b) { b[1] = std::byte{'X'}; }, ErrorCode::kFormatRejected, "wrong magic number"},
      {"json", [](Bytes& b) { b.assign(5, std::byte{'{'}); }, ErrorCode::kFormatRejected, "shorter than its magic"},
      {"version", [](Bytes& b) { Put32(b, 16, 7); }, ErrorCode::kVersionMismatch,
       "layout version 7 is not supported (this build reads versions 1 to 6)"},
      {"version 5 with contact rule sections", [](Bytes& b) { Put32(b, 16, 5); }, ErrorCode::kInvalidData,
       "section contact_rules is not expected with these flags in layout version 5"},
      {"version 4 with blend sections", [](Bytes& b) { Put32(b, 16, 4); }, ErrorCode::kInvalidData,
       "section reach_group_blend is not expected with these flags in layout version 4"},
      {"version 3 with piece sections", [](Bytes& b) { Put32(b, 16, 3); }, ErrorCode::kInvalidData,
       "section piece_points is not expected with these flags in layout version 3"},
      {"version 1 with a reach section", [](Bytes& b) { Put32(b, 16, 1); }, ErrorCode::kInvalidData,
       "section influence_reach is not expected with these flags in layout version 1"},
      {"version 2 with reference sections", [](Bytes& b) { Put32(b, 16, 2); }, ErrorCode::kInvalidData,
       "section fast_reference_inverse is not expected with these flags in layout version 2"},
      {"checksum", [](Bytes& b) { b[100] ^= std::byte{1}; }, ErrorCode::kInvalidData, "checksum mismatch", false},
      {"file size huge", [](Bytes& b) { Put64(b, 24, ~uint64_t{0}); }, ErrorCode::kInvalidData, "truncated"},
      {"flags", [](Bytes& b) { Put32(b, 20, 3); }, ErrorCode::kInvalidData, "contradictory flags"},
      {"unknown flag", [](Bytes& b) { Put32(b, 20, 2 | 8); }, ErrorCode::kInvalidData, "flags"},
      {"reserved", [](Bytes& b) { Put32(b, 60, 1); }, ErrorCode::kInvalidData, "reserved"},
      {"section count", [](Bytes& b) { Put32(b, 32, 0xFFFFFFFFu); }, ErrorCode::kInvalidData, "section table"},
      {"sphere count", [](Bytes& b) { Put32(b, 36, 0xFFFFFFFFu); }, ErrorCode::kInvalidData, "expected"},
      {"joint count", [](Bytes& b) { Put32(b, 40, 0x7FFFFFFFu); }, ErrorCode::kInvalidData, "string_offsets"},
      {"vertex count", [](Bytes& b) { Put32(b, 48, 0xFFFFFFF0u); }, ErrorCode::kInvalidData, "positions_bind has 12"},
      {"element count", [&](Bytes& b) { Put64(b, radii + 16, uint64_t{1} << 62); }, ErrorCode::kInvalidData,
       "runs past the end"},
      {"offset past the end", [&](Bytes& b) { Put64(b, radii + 8, uint64_t{1} << 63); }, ErrorCode::kInvalidData,
       "runs past the end"},
      {"misaligned", [&](Bytes& b) { Put64(b, radii + 8, Get64(b, radii + 8) + 4); }, ErrorCode::kInvalidData,
       "not 16-byte aligned"},
      {"overlap", [&](Bytes& b) { Put64(b, radii + 8, Get64(b, radii - 24 + 8)); }, ErrorCode::kInvalidData,
       "overlaps"},
      {"into the table", [&](Bytes& b) { Put64(b, strings + 8, 0); }, ErrorCode::kInvalidData, "overlaps"},
      {"element size", [&](Bytes& b) { Put32(b, radii + 4, 8); }, ErrorCode::kInvalidData, "elements of 8 bytes"},
      {"unknown id", [&](Bytes& b) { Put32(b, radii, 99); }, ErrorCode::kInvalidData, "unknown section id 99"},
      {"repeated id", [&](Bytes& b) { Put32(b, radii, Get32(b, radii - 24)); }, ErrorCode::kInvalidData,
       "out of order or repeated"},
      {"fast-only flag with lists",
       [](Bytes& b) {
         Put32(b, 20, 1);
         Put32(b, 56, 0);
       },
       ErrorCode::kInvalidData, "section vertex_offsets is not expected"},
      {"binds without a mesh", [](Bytes& b) { Put32(b, 20, 0); }, ErrorCode::kInvalidData,
       "bind entries without a mesh"},
      {"missing section", [&](Bytes& b) { Put32(b, radii, static_cast<uint32_t>(S::kRadiiFast)); },
       ErrorCode::kInvalidData, "section radii_rest is missing"},
      {"string offsets decrease", [&](Bytes& b) { Put32(b, Get64(b, strings + 8) + 4, 0xFFFFu); },
       ErrorCode::kInvalidData, "string_offsets does not start at 0, decreases"},
      {"influence offsets",
       [&](Bytes& b) {
         const size_t at = EntryOf(b, S::kInfluenceOffsets);
         Put32(b, Get64(b, at + 8) + 4, 7);
       },
       ErrorCode::kInvalidData, "influence_offsets"},
      {"exclusion reason", [&](Bytes& b) { Put32(b, Get64(b, EntryOf(b, S::kExcludedPairs) + 8) + 8, 9); },
       ErrorCode::kInvalidData, "excluded pair 0 has unknown reason 9"},
      {"pair triples", [&](Bytes& b) { Put64(b, EntryOf(b, S::kExcludedPairs) + 16, 2); }, ErrorCode::kInvalidData,
       "triples"},
      {"vertex out of range (Validate)", [&](Bytes& b) { Put32(b, Get64(b, EntryOf(b, S::kVertices) + 8), 99); },
       ErrorCode::kInvalidData, "vertex 99 out of range"},
      {"nan radius (Validate)", [&](Bytes& b) { Put32(b, Get64(b, radii + 8), 0x7FC00000u); }, ErrorCode::kInvalidData,
       "non-finite centre or radius"},
  };
  for (const Case& c : cases) {
    Bytes bad = good;
    c.edit(bad);
    if (c.fix_checksum && bad.size() >= 16) FixChecksum(bad);
    size_t largest = 0;
    auto read = Read(bad, &largest);
    ASSERT_FALSE(read.ok()) << c.what;
    EXPECT_EQ(read.error().code, c.code) << c.what << ": " << read.error().message;
    EXPECT_NE(read.error().message.find(c.message_part), std::string::npos) << c.what << ": " << read.error().message;
    EXPECT_LE(largest, 2 * good.size() + 4096) << c.what;
  }
}

// Layout version 2 adds section 28, influence_reach (sphere_set.h). Version-1 files still read, as
// sets without reach: with a mesh the rest data computes it (the same as the fitter's), without one
// it is 1 (the bound without reach, refit_job_tests.cc checks the bits). The fast-only variant keeps
// the reach, from the mesh when the set has none of its own.
TEST(SphereSetBinaryTest, VersionOneFilesReadWithoutReachAndFastOnlyFilesKeepIt) {
  const SphereSet& fitted = Builtin();
  ASSERT_EQ(fitted.influence_reach.size(), fitted.influence_joints.size());
  const Bytes v2 = WriteSphereSetBinary(fitted);
  EXPECT_EQ(Get32(v2, 16), kSphereSetBinaryVersion);
  const Bytes v1 = Downgrade(v2, 1);
  EXPECT_EQ(Get32(v1, 16), 1u);
  EXPECT_EQ(Get32(v1, 32), Get32(v2, 32) - 13);  // sections 28-40
  auto old = Read(v1);
  ASSERT_TRUE(old.ok()) << old.error().message;
  EXPECT_TRUE(old->influence_reach.empty());
  EXPECT_TRUE(old->has_mesh());
  // What a version-1 file holds: no reach, no reference, no groups, the rules on sphere pairs.
  SphereSet expected = WithRulesOnSpherePairs(fitted);
  expected.influence_reach.clear();
  expected.fast_reference_inverse.clear();
  expected.fast_reference_spheres.clear();
  expected.ClearReachGroups();
  EXPECT_EQ(WriteSphereSetJson(*old), WriteSphereSetJson(expected));
  auto rest = RefitRestData::Create(*old);
  ASSERT_TRUE(rest.ok()) << rest.error().message;
  EXPECT_TRUE(std::ranges::equal(rest->reach(), fitted.influence_reach)) << "the mesh's reach, as the fitter wrote it";
  // Written again: the current version, an empty reach section, and back to the same set.
  const Bytes rewritten = WriteSphereSetBinary(*old);
  EXPECT_EQ(Get32(rewritten, 16), kSphereSetBinaryVersion);
  EXPECT_EQ(Get64(rewritten, EntryOf(rewritten, SphereSetSection::kInfluenceReach) + 16), 0u);
  EXPECT_TRUE(Read(rewritten)->influence_reach.empty());

  // A version-1 fast-only file (no mesh to compute the reach from): reach 1.
  SphereSet no_mesh = expected;
  no_mesh.mesh = {};
  no_mesh.triangle_vertices.clear();
  auto old_fast = Read(Downgrade(WriteSphereSetBinary(no_mesh, SphereSetBinaryContent::kFastOnly), 1));
  ASSERT_TRUE(old_fast.ok()) << old_fast.error().message;
  EXPECT_TRUE(old_fast->fast_only && old_fast->influence_reach.empty());
  rest = RefitRestData::Create(*old_fast);
  ASSERT_TRUE(rest.ok()) << rest.error().message;
  EXPECT_TRUE(std::ranges::all_of(rest->reach(), [](float w) { return w == 1.0f; }));

  // Fast-only files keep the reach: the set's own, or the mesh's when it has none.
  const SphereSet* with_and_without[] = {&fitted, &expected};
  for (const SphereSet* set : with_and_without) {
    auto fast = Read(WriteSphereSetBinary(*set, SphereSetBinaryContent::kFastOnly));
    ASSERT_TRUE(fast.ok()) << fast.error().message;
    EXPECT_EQ(fast->influence_reach, fitted.influence_reach);
  }

  // The reach section holds one entry per influence, or none.
  SphereSet small = Small();
  small.influence_reach = {1.0f, 1.0f};
  Bytes bad = WriteSphereSetBinary(small);
  ASSERT_TRUE(Read(bad).ok());
  Put64(bad, EntryOf(bad, SphereSetSection::kInfluenceReach) + 16, 1);
  FixChecksum(bad);
  auto refused = Read(bad);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("section influence_reach has 1 elements, expected 2 (one per influence) or 0"),
            std::string::npos)
      << refused.error().message;
}

// Layout version 3 adds sections 29-30, the fast refit's stored reference frame (sphere_set.h,
// refit_job.h), and JSON the optional "fast_reference_inverse" per joint and "fast_reference" per
// sphere. Checked on a set whose rest pose is not its bind pose (ChooseFastReference stores the
// bind pose): JSON -> set -> JSON and binary -> set -> JSON give the same text; a fast-only file
// keeps the reference and refits bit for bit as the whole set on random poses (and not as the set
// without it); a version-2 file reads as a set without one; a section of the wrong length, and JSON
// giving it on some joints or spheres only, are refused by name.
TEST(SphereSetBinaryTest, FastReferenceRoundTripsInBothFormatsAndFastOnlyFilesKeepIt) {
  SphereSet set = TwoJointsRestAwayFromBind();
  auto chosen = ChooseFastReference(&set);
  ASSERT_TRUE(chosen.ok() && *chosen);
  const std::string json = WriteSphereSetJson(set);
  EXPECT_NE(json.find("\"fast_reference_inverse\""), std::string::npos);
  auto from_json = ReadSphereSetJson(json, "set.json");
  ASSERT_TRUE(from_json.ok()) << from_json.error().message;
  EXPECT_EQ(from_json->fast_reference_spheres, set.fast_reference_spheres);
  EXPECT_EQ(from_json->fast_reference_inverse, set.fast_reference_inverse);
  EXPECT_EQ(WriteSphereSetJson(*from_json), json);
  const Bytes full = WriteSphereSetBinary(set);
  EXPECT_EQ(Get32(full, 16), kSphereSetBinaryVersion);
  auto from_binary = Read(full);
  ASSERT_TRUE(from_binary.ok()) << from_binary.error().message;
  EXPECT_EQ(WriteSphereSetJson(*from_binary), json);
  auto fast = Read(WriteSphereSetBinary(set, SphereSetBinaryContent::kFastOnly));
  ASSERT_TRUE(fast.ok()) << fast.error().message;
  EXPECT_TRUE(fast->fast_only);
  EXPECT_EQ(fast->fast_reference_spheres, set.fast_reference_spheres);

  // Refits: the fast-only set as the whole one, bit for bit; the set without the reference differs.
  SphereSet without = set;
  without.fast_reference_inverse.clear();
  without.fast_reference_spheres.clear();
  auto rest_full = RefitRestData::Create(set), rest_fast = RefitRestData::Create(*fast),
       rest_without = RefitRestData::Create(without);
  ASSERT_TRUE(rest_full.ok() && rest_fast.ok() && rest_without.ok());
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> angle(-3.0f, 3.0f), move(-2.0f, 2.0f);
  int differ = 0;
  for (int p = 0; p < 200; ++p) {
    std::vector<skinspheres::Mat4f> world(2);
    for (auto& g : world) {
      const Eigen::Vector3f axis = Eigen::Vector3f(move(rng), move(rng), move(rng)).normalized();
      g = (Eigen::Translation3f(move(rng), move(rng), move(rng)) * Eigen::AngleAxisf(angle(rng), axis)).matrix();
    }
    std::vector<skinspheres::Vec4f> a(2), b(2), c(2);
    ASSERT_TRUE((RefitJob{RefitMode::kFast, &set, &*rest_full, world, {}, a}.Run()));
    ASSERT_TRUE((RefitJob{RefitMode::kFast, &*fast, &*rest_fast, world, {}, b}.Run()));
    ASSERT_TRUE((RefitJob{RefitMode::kFast, &without, &*rest_without, world, {}, c}.Run()));
    for (size_t s = 0; s < 2; ++s) {
      ASSERT_EQ(std::memcmp(a[s].data(), b[s].data(), sizeof(float) * 4), 0) << "pose " << p << " sphere " << s;
      differ += a[s] != c[s];
    }
  }
  EXPECT_GT(differ, 300) << "the stored reference is what the refit uses";

  // A version-2 file: no reference sections; it reads as the set without one.
  const Bytes v2 = Downgrade(full, 2);
  EXPECT_EQ(Get32(v2, 32), Get32(full, 32) - 12);  // sections 29-40
  auto old = Read(v2);
  ASSERT_TRUE(old.ok()) << old.error().message;
  EXPECT_TRUE(old->fast_reference_inverse.empty() && old->fast_reference_spheres.empty());
  EXPECT_EQ(WriteSphereSetJson(*old), WriteSphereSetJson(WithRulesOnSpherePairs(without)));

  // Sections of the wrong length.
  Bytes bad = full;
  Put64(bad, EntryOf(bad, SphereSetSection::kFastReferenceSpheres) + 16, 4);
  FixChecksum(bad);
  auto refused = Read(bad);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("sections fast_reference_inverse and fast_reference_spheres have 32 and 4 "
                                         "elements, expected 32 and 8"),
            std::string::npos)
      << refused.error().message;
  // JSON with the reference on one joint, or one sphere, only.
  auto one_joint = nlohmann::json::parse(json);
  one_joint["skeleton"]["joints"][1].erase("fast_reference_inverse");
  auto refused_json = ReadSphereSetJson(one_joint.dump(), "set.json");
  ASSERT_FALSE(refused_json.ok());
  EXPECT_NE(refused_json.error().message.find("$.skeleton.joints[1].fast_reference_inverse is missing"),
            std::string::npos)
      << refused_json.error().message;
  auto one_sphere = nlohmann::json::parse(json);
  one_sphere["spheres"][1].erase("fast_reference");
  refused_json = ReadSphereSetJson(one_sphere.dump(), "set.json");
  ASSERT_FALSE(refused_json.ok());
  EXPECT_NE(refused_json.error().message.find("$.spheres[1].fast_reference is missing"), std::string::npos)
      << refused_json.error().message;
}

// Reach groups (sphere_set.h; binary layout version 3, sections 31-33; JSON "reach_groups"): the
// fitted set has them; both formats round-trip them and a fast-only file keeps them; a sphere with
// no group or five, a group row of the wrong length, and binary offsets that do not match the
// radii are refused by name.
TEST(SphereSetBinaryTest, ReachGroupsRoundTripAndFastOnlyFilesKeepThem) {
  const SphereSet& fitted = Builtin();
  ASSERT_EQ(fitted.reach_group_offsets.size(), fitted.size() + 1);
  ASSERT_GT(fitted.reach_group_radii.size(), fitted.size()) << "some sphere has two groups or more";
  const std::string json = WriteSphereSetJson(fitted);
  auto from_json = ReadSphereSetJson(json, "set.json");
  ASSERT_TRUE(from_json.ok()) << from_json.error().message;
  EXPECT_EQ(from_json->reach_group_offsets, fitted.reach_group_offsets);
  EXPECT_EQ(from_json->reach_group_radii, fitted.reach_group_radii);
  EXPECT_EQ(from_json->reach_group_weights, fitted.reach_group_weights);
  auto fast = Read(WriteSphereSetBinary(fitted, SphereSetBinaryContent::kFastOnly));
  ASSERT_TRUE(fast.ok()) << fast.error().message;
  EXPECT_EQ(fast->reach_group_offsets, fitted.reach_group_offsets);
  EXPECT_EQ(fast->reach_group_radii, fitted.reach_group_radii);
  EXPECT_EQ(fast->reach_group_weights, fitted.reach_group_weights);

  auto refused_with = [&](const std::function<void(nlohmann::json&)>& edit) {
    auto doc = nlohmann::json::parse(json);
    edit(doc);
    auto read = ReadSphereSetJson(doc.dump(), "set.json");
    return read.ok() ? std::string("accepted") : read.error().message;
  };
  EXPECT_NE(refused_with([](nlohmann::json& d) {
              d["spheres"][3]["reach_groups"] = nlohmann::json::array();
            }).find("$.spheres[3].reach_groups has 0 groups (1 to 4)"),
            std::string::npos);
  EXPECT_NE(refused_with([](nlohmann::json& d) {
              auto& g = d["spheres"][3]["reach_groups"];
              while (g.size() < 5) g.push_back(g[0]);
            }).find("$.spheres[3].reach_groups has 5 groups"),
            std::string::npos);
  EXPECT_NE(refused_with([](nlohmann::json& d) {
              d["spheres"][3]["reach_groups"][0].push_back(0.5);
            }).find("$.spheres[3].reach_groups[] has"),
            std::string::npos);
  EXPECT_NE(refused_with([](nlohmann::json& d) {
              d["spheres"][3].erase("reach_groups");
            }).find("$.spheres[3].reach_groups is missing"),
            std::string::npos);

  Bytes bad = WriteSphereSetBinary(fitted);
  Put64(bad, EntryOf(bad, SphereSetSection::kReachGroupRadii) + 16,
        Get64(bad, EntryOf(bad, SphereSetSection::kReachGroupRadii) + 16) - 1);
  FixChecksum(bad);
  auto refused = Read(bad);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("reach_group_offsets"), std::string::npos) << refused.error().message;
}

// The groups' blends (sphere_set.h; binary layout version 5, sections 37-38; JSON: each group row
// [radius, reaches, blends, deviations]): the fitted set has them; both formats and a fast-only file
// keep them, and the fast-only file refits as the whole set, bit for bit; a layout-4 file (and a JSON
// file with rows of 1 + K) reads as the set without them, which refits no tighter on any sphere;
// rows of a third length, and blend sections of another length than the reaches', are refused.
TEST(SphereSetBinaryTest, GroupBlendsRoundTripAndOlderFilesReadWithoutThem) {
  const SphereSet& fitted = Builtin();
  ASSERT_EQ(fitted.reach_group_blend.size(), fitted.reach_group_weights.size());
  ASSERT_EQ(fitted.reach_group_deviation.size(), fitted.reach_group_weights.size());
  const std::string json = WriteSphereSetJson(fitted);
  auto from_json = ReadSphereSetJson(json, "set.json");
  ASSERT_TRUE(from_json.ok()) << from_json.error().message;
  EXPECT_EQ(from_json->reach_group_blend, fitted.reach_group_blend);
  EXPECT_EQ(from_json->reach_group_deviation, fitted.reach_group_deviation);
  const Bytes full = WriteSphereSetBinary(fitted);
  auto fast = Read(WriteSphereSetBinary(fitted, SphereSetBinaryContent::kFastOnly));
  ASSERT_TRUE(fast.ok()) << fast.error().message;
  EXPECT_EQ(fast->reach_group_blend, fitted.reach_group_blend);
  EXPECT_EQ(fast->reach_group_deviation, fitted.reach_group_deviation);

  auto v4 = Read(Downgrade(full, 4));
  ASSERT_TRUE(v4.ok()) << v4.error().message;
  EXPECT_TRUE(v4->reach_group_blend.empty() && v4->reach_group_deviation.empty());
  EXPECT_EQ(v4->reach_group_weights, fitted.reach_group_weights);
  ExpectSameRules(*v4, WithRulesOnSpherePairs(fitted));
  // The JSON as written before blends (and before the rules on triangles: version 2 or 3).
  auto doc = nlohmann::json::parse(json);
  doc.erase("contact_rules");
  doc["version"] = fitted.has_pieces() ? kSphereSetVersionWithPieces : kSphereSetVersion;
  for (auto& sphere : doc["spheres"]) {
    const size_t k_count = sphere["influences"].size();
    for (auto& row : sphere["reach_groups"]) row.erase(row.begin() + static_cast<ptrdiff_t>(1 + k_count), row.end());
  }
  auto old_json = ReadSphereSetJson(doc.dump(), "old.json");
  ASSERT_TRUE(old_json.ok()) << old_json.error().message;
  EXPECT_EQ(WriteSphereSetJson(*old_json), WriteSphereSetJson(*v4));

  auto rest = RefitRestData::Create(fitted), rest_fast = RefitRestData::Create(*fast),
       rest_v4 = RefitRestData::Create(*v4);
  ASSERT_TRUE(rest.ok() && rest_fast.ok() && rest_v4.ok());
  auto fc = test::LoadFitted("builtin");
  ASSERT_TRUE(fc);
  std::mt19937 rng(29);
  int tighter = 0;
  for (int p = 0; p < 20; ++p) {
    const test::Pose pose = test::MakePose(fc->character, test::RandomLocal(fc->character, rng, 60.0f, 0.0f), "random");
    std::vector<skinspheres::Vec4f> a(fitted.size()), b(fitted.size()), c(fitted.size());
    ASSERT_TRUE((RefitJob{RefitMode::kFast, &fitted, &*rest, pose.world, {}, a}.Run()));
    ASSERT_TRUE((RefitJob{RefitMode::kFast, &*fast, &*rest_fast, pose.world, {}, b}.Run()));
    ASSERT_TRUE((RefitJob{RefitMode::kFast, &*v4, &*rest_v4, pose.world, {}, c}.Run()));
    for (size_t s = 0; s < a.size(); ++s) {
      ASSERT_EQ(std::memcmp(a[s].data(), b[s].data(), sizeof(float) * 4), 0) << "pose " << p << " sphere " << s;
      ASSERT_LE(a[s].w(), c[s].w()) << "pose " << p << " sphere " << s;
      tighter += a[s].w() < c[s].w();
    }
  }
  EXPECT_GT(tighter, 0);

  auto doc3 = nlohmann::json::parse(json);
  doc3["spheres"][3]["reach_groups"][0].push_back(0.5);
  auto bad_row = ReadSphereSetJson(doc3.dump(), "set.json");
  ASSERT_FALSE(bad_row.ok());
  EXPECT_NE(bad_row.error().message.find("$.spheres[3].reach_groups[] has"), std::string::npos)
      << bad_row.error().message;
  Bytes bad = full;
  Put64(bad, EntryOf(bad, SphereSetSection::kReachGroupDeviation) + 16,
        Get64(bad, EntryOf(bad, SphereSetSection::kReachGroupDeviation) + 16) - 1);
  FixChecksum(bad);
  auto refused = Read(bad);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("sections reach_group_blend and reach_group_deviation have"),
            std::string::npos)
      << refused.error().message;
}

// Triangle pieces (sphere_set.h) round-trip through both formats: JSON version 4 (version 3 for a
// set with its contact rules on sphere pairs), binary layout 4 and later (sections 34-36),
// converting one into the other and back bit-exact; a fast-only file leaves them out and still
// refits as the whole set does. A set without pieces whose rules are on sphere pairs still writes
// JSON version 2, and its binary file read as layout 3 (sections 34-36 dropped) is the same set.
// Pieces in a version-2 JSON document, grid points that do not hold whole quadruples, piece offsets
// that do not fit and a piece that breaks the ownership rules are refused by name.
TEST(SphereSetBinaryTest, TrianglePiecesRoundTripInBothFormats) {
  const SphereSet set = TwoJointsWithPieces();
  ASSERT_EQ(set.Validate(), std::nullopt);
  std::string json, json3;  // versions 4 and 3
  Bytes bytes;
  for (const SphereSet& with_rules : {set, WithRulesOnSpherePairs(set)}) {
    const bool on_triangles = with_rules.contact_rules == ContactRules::kTriangles;
    const std::string text = WriteSphereSetJson(with_rules);
    EXPECT_EQ(nlohmann::json::parse(text)["version"],
              on_triangles ? kSphereSetVersionWithRules : kSphereSetVersionWithPieces);
    auto from_json = ReadSphereSetJson(text, "set.json");
    ASSERT_TRUE(from_json.ok()) << from_json.error().message;
    EXPECT_EQ(from_json->piece_points, set.piece_points);
    EXPECT_EQ(from_json->piece_offsets, set.piece_offsets);
    EXPECT_EQ(from_json->pieces, set.pieces);
    ExpectSameRules(*from_json, with_rules);
    const Bytes binary = WriteSphereSetBinary(*from_json);
    EXPECT_EQ(Get32(binary, 16), kSphereSetBinaryVersion);
    auto from_binary = Read(binary);
    ASSERT_TRUE(from_binary.ok()) << from_binary.error().message;
    EXPECT_EQ(WriteSphereSetJson(*from_binary), text);
    EXPECT_EQ(WriteSphereSetBinary(*from_binary), binary);
    (on_triangles ? json : json3) = text;
    if (on_triangles) bytes = binary;
  }

  auto fast = Read(WriteSphereSetBinary(set, SphereSetBinaryContent::kFastOnly));
  ASSERT_TRUE(fast.ok()) << fast.error().message;
  EXPECT_FALSE(fast->has_pieces());
  auto rest = RefitRestData::Create(set);
  auto fast_rest = RefitRestData::Create(*fast);
  ASSERT_TRUE(rest.ok() && fast_rest.ok());
  std::vector<skinspheres::Mat4f> world(set.joint_count(), skinspheres::Mat4f::Identity());
  world[1](0, 3) = 0.4f;
  std::vector<Vec4f> a(set.size()), b(set.size());
  ASSERT_TRUE((RefitJob{RefitMode::kFast, &set, &*rest, world, {}, a}.Run()));
  ASSERT_TRUE((RefitJob{RefitMode::kFast, &*fast, &*fast_rest, world, {}, b}.Run()));
  for (size_t s = 0; s < set.size(); ++s) EXPECT_EQ(a[s], b[s]) << "sphere " << s;

  SphereSet whole = TwoJointsWithMesh();
  EXPECT_EQ(nlohmann::json::parse(WriteSphereSetJson(whole))["version"], kSphereSetVersionWithRules);
  EXPECT_EQ(nlohmann::json::parse(WriteSphereSetJson(WithRulesOnSpherePairs(whole)))["version"], kSphereSetVersion);
  auto as_v3 = Read(Downgrade(WriteSphereSetBinary(whole), 3));
  ASSERT_TRUE(as_v3.ok()) << as_v3.error().message;
  EXPECT_EQ(WriteSphereSetJson(*as_v3), WriteSphereSetJson(WithRulesOnSpherePairs(whole)));
  auto cut_as_v3 = Read(Downgrade(bytes, 3));
  ASSERT_FALSE(cut_as_v3.ok()) << "a layout-3 file has no pieces: triangle 1 is owned by no sphere";

  auto version2 = nlohmann::json::parse(json3);  // what a version-2 writer never wrote
  version2["version"] = kSphereSetVersion;
  auto read2 = ReadSphereSetJson(version2.dump(), "set.json");
  ASSERT_FALSE(read2.ok());
  EXPECT_NE(read2.error().message.find("pieces is not part of version 2"), std::string::npos) << read2.error().message;
  auto refused_with = [&](const std::function<void(nlohmann::json&)>& edit) {
    auto doc = nlohmann::json::parse(json);
    edit(doc);
    auto read = ReadSphereSetJson(doc.dump(), "set.json");
    return read.ok() ? std::string("accepted") : read.error().message;
  };
  EXPECT_NE(refused_with([](nlohmann::json& d) {
              d["mesh"]["piece_points"].push_back(1);
            }).find("$.mesh.piece_points does not hold whole"),
            std::string::npos);
  EXPECT_NE(refused_with([](nlohmann::json& d) {
              d["spheres"][1]["pieces"].push_back(1);
            }).find("$.spheres[1].pieces does not hold whole"),
            std::string::npos);
  EXPECT_NE(refused_with([](nlohmann::json& d) { d["spheres"][1]["pieces"][2] = 0; }).find("grid's pieces once"),
            std::string::npos);
  EXPECT_NE(refused_with([](nlohmann::json& d) { d["mesh"]["piece_points"][1] = 17; }).find("above 16"),
            std::string::npos);

  // Grid points with no pieces and no offsets (a file no fitter writes): refused by name, in both
  // formats, never read out of range.
  SphereSet orphan_points = set;
  orphan_points.pieces.clear();
  orphan_points.piece_offsets.clear();
  auto orphan_binary = Read(WriteSphereSetBinary(orphan_points));
  ASSERT_FALSE(orphan_binary.ok());
  EXPECT_NE(orphan_binary.error().message.find("piece lists are malformed"), std::string::npos)
      << orphan_binary.error().message;
  auto orphan_json = ReadSphereSetJson(WriteSphereSetJson(orphan_points), "set.json");
  ASSERT_FALSE(orphan_json.ok());
  EXPECT_NE(orphan_json.error().message.find("piece lists are malformed"), std::string::npos)
      << orphan_json.error().message;

  Bytes bad = bytes;
  Put64(bad, EntryOf(bad, SphereSetSection::kPieceOffsets) + 16, 2);
  FixChecksum(bad);
  auto refused = Read(bad);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("piece_offsets"), std::string::npos) << refused.error().message;
}

// The contact rules (sphere_set.h; binary layout 6, sections 39-40; JSON version 4, "contact_rules"):
// the fitted set states them on triangles. For it, a hand-made set at 2 hops with a rest gap, and a
// set with its rules on sphere pairs read from a version-3 JSON file (a bind_overlap pair included):
// the JSON and the binary give rules, hops and gap back bit for bit, each converts into the other and
// back unchanged (what `skinspheres convert` does), and every layout-6 file holds both sections, as
// (rules, hops) and the gap, the fast-only one too, which keeps them.
TEST(SphereSetBinaryTest, ContactRulesRoundTripInBothFormatsAndFastOnlyFilesKeepThem) {
  const SphereSet& fitted = Builtin();
  ASSERT_EQ(fitted.contact_rules, ContactRules::kTriangles);
  EXPECT_EQ(fitted.contact_hops, kDefaultContactHops);
  EXPECT_GT(fitted.rest_gap, 0.0f);
  for (const ExcludedPair& p : fitted.excluded_pairs) EXPECT_NE(p.reason, ExclusionReason::kBindOverlap);
  const SphereSet hand = WithRulesOnTriangles(TwoJointsWithPieces(), 2, 0.0375f);
  ASSERT_EQ(hand.contact_hops, 2u);
  ASSERT_GT(hand.rest_gap, 0.0f);
  SphereSet old = WithRulesOnSpherePairs(TwoJointsWithPieces());
  old.excluded_pairs = {{0, 1, ExclusionReason::kBindOverlap}};
  auto read3 = ReadSphereSetJson(WriteSphereSetJson(old), "v3.json");
  ASSERT_TRUE(read3.ok()) << read3.error().message;
  ExpectSameRules(*read3, old);

  const SphereSet& from_version3 = *read3;
  for (const SphereSet* set : {&fitted, &hand, &from_version3}) {
    const bool on_triangles = set->contact_rules == ContactRules::kTriangles;
    const std::string json = WriteSphereSetJson(*set);
    const nlohmann::json doc = nlohmann::json::parse(json);
    if (on_triangles) {
      EXPECT_EQ(doc["version"], kSphereSetVersionWithRules);
      EXPECT_EQ(doc["contact_rules"], nlohmann::json({{"on", "triangles"},
                                                      {"hops", set->contact_hops},
                                                      {"rest_gap", static_cast<double>(set->rest_gap)}}));
    } else {
      EXPECT_EQ(doc["version"], kSphereSetVersionWithPieces);
      EXPECT_FALSE(doc.contains("contact_rules"));
    }
    auto from_json = ReadSphereSetJson(json, "set.json");
    ASSERT_TRUE(from_json.ok()) << from_json.error().message;
    ExpectSameRules(*from_json, *set);
    for (const auto content : {SphereSetBinaryContent::kFull, SphereSetBinaryContent::kFastOnly}) {
      const Bytes bytes = WriteSphereSetBinary(*from_json, content);
      EXPECT_EQ(Get32(bytes, 16), kSphereSetBinaryVersion);
      const size_t rules = EntryOf(bytes, SphereSetSection::kContactRules);
      const size_t gap = EntryOf(bytes, SphereSetSection::kRestGap);
      ASSERT_EQ(Get64(bytes, rules + 16), 2u);
      ASSERT_EQ(Get64(bytes, gap + 16), 1u);
      EXPECT_EQ(Get32(bytes, Get64(bytes, rules + 8)), static_cast<uint32_t>(set->contact_rules));
      EXPECT_EQ(Get32(bytes, Get64(bytes, rules + 8) + 4), set->contact_hops);
      EXPECT_EQ(Get32(bytes, Get64(bytes, gap + 8)), Bits(set->rest_gap));
      auto from_binary = Read(bytes);
      ASSERT_TRUE(from_binary.ok()) << from_binary.error().message;
      EXPECT_EQ(from_binary->fast_only, content == SphereSetBinaryContent::kFastOnly);
      ExpectSameRules(*from_binary, *set);
      EXPECT_EQ(WriteSphereSetBinary(*from_binary, content), bytes);
      if (content == SphereSetBinaryContent::kFull) {
        EXPECT_EQ(WriteSphereSetJson(*from_binary), json);  // JSON -> binary -> JSON
        auto back = ReadSphereSetJson(WriteSphereSetJson(*from_binary), "back.json");
        ASSERT_TRUE(back.ok()) << back.error().message;
        EXPECT_EQ(WriteSphereSetBinary(*back), bytes);  // binary -> JSON -> binary
      }
    }
  }
}

// Files written before the contact rules on triangles (JSON versions 1 to 3, binary layouts 1 to 5)
// read as sets with their rules on sphere pairs, hops 0 and rest gap 0, every excluded pair kept with
// its reason, bind_overlap included (which only such sets give). A JSON file writes back as the same
// text, through the binary too; a layout-5 file writes back as layout 6 with sections 39-40 (0, 0)
// and 0, the same set. A set with its rules on triangles written as an older layout reads the same
// way: the older file has no place for them.
TEST(SphereSetBinaryTest, FilesBeforeTheRulesReadWithTheirRulesOnSpherePairs) {
  // The fitted set as a fitter before the rules wrote it: its pairs, and every other pair of spheres
  // that overlap at rest as bind_overlap.
  SphereSet legacy = WithRulesOnSpherePairs(Builtin());
  size_t bind_overlaps = 0;
  for (uint32_t i = 0; i < legacy.size(); ++i) {
    for (uint32_t j = i + 1; j < legacy.size(); ++j) {
      const bool listed =
          std::ranges::any_of(legacy.excluded_pairs, [&](const auto& p) { return p.i == i && p.j == j; });
      if (listed ||
          (legacy.centers_rest[i] - legacy.centers_rest[j]).norm() >= legacy.radii_rest[i] + legacy.radii_rest[j]) {
        continue;
      }
      legacy.excluded_pairs.push_back({i, j, ExclusionReason::kBindOverlap});
      ++bind_overlaps;
    }
  }
  std::ranges::sort(legacy.excluded_pairs,
                    [](const auto& a, const auto& b) { return std::pair(a.i, a.j) < std::pair(b.i, b.j); });
  ASSERT_GT(bind_overlaps, 0u);
  ASSERT_FALSE(legacy.Validate().has_value()) << legacy.Validate()->message;
  SphereSet on_triangles = legacy;  // refused: bind_overlap is not a reason of the rules on triangles
  on_triangles.contact_rules = ContactRules::kTriangles;
  EXPECT_TRUE(on_triangles.Validate().has_value());

  ASSERT_FALSE(legacy.has_pieces());
  const std::string json = WriteSphereSetJson(legacy);
  EXPECT_EQ(nlohmann::json::parse(json)["version"], kSphereSetVersion);
  for (uint32_t version = 1; version < kSphereSetBinaryVersion; ++version) {
    for (const auto content : {SphereSetBinaryContent::kFull, SphereSetBinaryContent::kFastOnly}) {
      auto read = Read(Downgrade(WriteSphereSetBinary(legacy, content), version));
      ASSERT_TRUE(read.ok()) << "layout " << version << ": " << read.error().message;
      EXPECT_EQ(read->fast_only, content == SphereSetBinaryContent::kFastOnly);
      ExpectSameRules(*read, legacy);
    }
  }
  const Bytes v6 = WriteSphereSetBinary(legacy);
  EXPECT_EQ(Get32(v6, Get64(v6, EntryOf(v6, SphereSetSection::kContactRules) + 8)), 0u);
  EXPECT_EQ(Get32(v6, Get64(v6, EntryOf(v6, SphereSetSection::kContactRules) + 8) + 4), 0u);
  EXPECT_EQ(Get32(v6, Get64(v6, EntryOf(v6, SphereSetSection::kRestGap) + 8)), 0u);
  auto v5 = Read(Downgrade(v6, 5));
  ASSERT_TRUE(v5.ok()) << v5.error().message;
  EXPECT_EQ(WriteSphereSetJson(*v5), json);
  EXPECT_EQ(WriteSphereSetBinary(*v5), v6);

  // The fitted set (rules on triangles) as a layout-5 file: its pairs, on sphere pairs.
  auto fitted_v5 = Read(Downgrade(WriteSphereSetBinary(Builtin()), 5));
  ASSERT_TRUE(fitted_v5.ok()) << fitted_v5.error().message;
  ExpectSameRules(*fitted_v5, WithRulesOnSpherePairs(Builtin()));
  EXPECT_EQ(WriteSphereSetJson(*fitted_v5), WriteSphereSetJson(WithRulesOnSpherePairs(Builtin())));

  // JSON versions 1 to 3: the set without its mesh, with it, and a set with pieces.
  SphereSet no_mesh = legacy;
  no_mesh.mesh = {};
  no_mesh.triangle_vertices.clear();
  SphereSet pieces = WithRulesOnSpherePairs(TwoJointsWithPieces());
  pieces.excluded_pairs = {{0, 1, ExclusionReason::kBindOverlap}};
  int version = kSphereSetVersionWithoutMesh;
  for (const SphereSet* set : {&no_mesh, &legacy, &pieces}) {
    const std::string text = WriteSphereSetJson(*set);
    EXPECT_EQ(nlohmann::json::parse(text)["version"], version++);
    auto read = ReadSphereSetJson(text, "old.json");
    ASSERT_TRUE(read.ok()) << read.error().message;
    ExpectSameRules(*read, *set);
    EXPECT_EQ(WriteSphereSetJson(*read), text);
    auto through = Read(WriteSphereSetBinary(*read));
    ASSERT_TRUE(through.ok()) << through.error().message;
    ExpectSameRules(*through, *set);
    EXPECT_EQ(WriteSphereSetJson(*through), text);
  }
}

// The fit settings (params) become the JSON's "params" object when a binary set is converted:
// params nested deeper than the JSON reader reads (copying and writing them would recurse past the
// stack, as a JSON file nested 100,000 deep once crashed the tool) and params that are not an
// object are refused by name; accepted ones are kept compact, as the JSON reader gives them, so
// that binary -> JSON -> binary gives the same bytes.
TEST(SphereSetBinaryTest, ParamsAreAJsonObjectTheJsonReaderWouldRead) {
  SphereSet set = Small();
  set.params_json = "{\"x\":" + std::string(100000, '[') + std::string(100000, ']') + "}";
  auto deep = Read(WriteSphereSetBinary(set));
  ASSERT_FALSE(deep.ok());
  EXPECT_EQ(deep.error().code, ErrorCode::kInvalidData);
  EXPECT_NE(deep.error().message.find("params) nest 100001 deep (at most 128"), std::string::npos)
      << deep.error().message;
  for (const char* not_object : {"[1,2]", "3", "{\"a\":"}) {
    set.params_json = not_object;
    auto read = Read(WriteSphereSetBinary(set));
    ASSERT_FALSE(read.ok()) << not_object;
    EXPECT_NE(read.error().message.find("the fit settings (params) are not a JSON object"), std::string::npos)
        << read.error().message;
  }
  // Bytes that are not UTF-8 never reach the file: the writer makes them U+FFFD, as the JSON writer does.
  set.params_json = "{\"a\":\"\xff\"}";
  auto latin1 = Read(WriteSphereSetBinary(set));
  ASSERT_TRUE(latin1.ok()) << latin1.error().message;
  EXPECT_EQ(latin1->params_json, "{\"a\":\"\xEF\xBF\xBD\"}");
  set.params_json = " { \"rays\" : 80 ,\"a\":[1, 2] } ";
  auto read = Read(WriteSphereSetBinary(set));
  ASSERT_TRUE(read.ok()) << read.error().message;
  EXPECT_EQ(read->params_json, R"({"a":[1,2],"rays":80})");
  const Bytes binary = WriteSphereSetBinary(*read);
  auto from_json = ReadSphereSetJson(WriteSphereSetJson(*read), "x.json");
  ASSERT_TRUE(from_json.ok()) << from_json.error().message;
  EXPECT_EQ(WriteSphereSetBinary(*from_json), binary);
  set.params_json.clear();  // no settings at all: read as an empty object (SphereSet's default)
  auto none = Read(WriteSphereSetBinary(set));
  ASSERT_TRUE(none.ok()) << none.error().message;
  EXPECT_EQ(none->params_json, "{}");
}

// The layout's padding (after the table, between sections, at the end) is zero: a set has one
// encoding, so binary -> set -> binary gives the same bytes. A non-zero padding byte is refused.
TEST(SphereSetBinaryTest, EveryNonZeroPaddingByteIsRefused) {
  const Bytes good = WriteSphereSetBinary(Small());
  std::vector<bool> covered(good.size(), false);
  const uint32_t sections = Get32(good, 32);
  std::fill_n(covered.begin(), kSphereSetBinaryHeaderSize + sections * kSphereSetBinarySectionEntrySize, true);
  for (uint32_t k = 0; k < sections; ++k) {
    const size_t entry = kSphereSetBinaryHeaderSize + k * kSphereSetBinarySectionEntrySize;
    const size_t at = Get64(good, entry + 8), bytes = Get64(good, entry + 16) * Get32(good, entry + 4);
    std::fill_n(covered.begin() + static_cast<ptrdiff_t>(at), bytes, true);
  }
  size_t padding = 0;
  for (size_t at = 0; at < good.size(); ++at) {
    if (covered[at]) continue;
    ++padding;
    ASSERT_EQ(good[at], std::byte{0}) << "the writer left byte " << at << " non-zero";
    Bytes bad = good;
    bad[at] = std::byte{0x01};
    FixChecksum(bad);
    auto read = Read(bad);
    ASSERT_FALSE(read.ok()) << "padding byte " << at << " = 1 was accepted";
    EXPECT_NE(read.error().message.find("padding byte at offset " + std::to_string(at) + " is not 0"),
              std::string::npos)
        << read.error().message;
  }
  EXPECT_GT(padding, 16u);  // after the table, between sections and at the end
  auto read = Read(good);
  ASSERT_TRUE(read.ok()) << read.error().message;
  EXPECT_EQ(WriteSphereSetBinary(*read), good);
}

// Strings (source file, params, joint and part names) are UTF-8, as in the JSON, so binary -> JSON
// is lossless: the reader refuses invalid UTF-8, naming the string; the writer never writes it
// (bytes from a Latin-1 name become U+FFFD, as the JSON writer makes them).
TEST(SphereSetBinaryTest, StringsThatAreNotUtf8AreRefusedByName) {
  const SphereSet set = Small();
  const Bytes good = WriteSphereSetBinary(set);
  const size_t offsets_at = Get64(good, EntryOf(good, SphereSetSection::kStringOffsets) + 8);
  const size_t bytes_at = Get64(good, EntryOf(good, SphereSetSection::kStringBytes) + 8);
  const size_t joints = set.joint_count(), strings = 2 + joints + set.parts.size();
  auto string_at = [&](size_t k) { return bytes_at + Get32(good, offsets_at + 4 * k); };
  auto string_length = [&](size_t k) {
    return Get32(good, offsets_at + 4 * (k + 1)) - Get32(good, offsets_at + 4 * k);
  };
  for (size_t k = 0; k < strings; ++k) {
    ASSERT_GT(string_length(k), 0u) << "string " << k;
    Bytes bad = good;
    bad[string_at(k)] = std::byte{0xFF};
    FixChecksum(bad);
    auto read = Read(bad);
    ASSERT_FALSE(read.ok()) << "string " << k << " with a 0xFF byte was accepted";
    const std::string which = k == 0           ? "source_file"
                              : k == 1         ? "params"
                              : k < 2 + joints ? "joint " + std::to_string(k - 2) + "'s name"
                                               : "part " + std::to_string(k - 2 - joints) + "'s name";
    EXPECT_NE(read.error().message.find(which + " is not valid UTF-8 (byte 0)"), std::string::npos)
        << read.error().message;
  }
  // Each malformed form in the source file ("small.glb", 9 bytes) is refused; each valid one read.
  ASSERT_EQ(string_length(0), 9u);
  const std::pair<std::string_view, bool> forms[] = {
      {"\xC3\xA9", true},
      {"\xE2\x82\xAC", true},
      {"\xF0\x9F\x98\x80", true},
      {"\xF4\x8F\xBF\xBF", true},
      {"\xC0\x80", false},
      {"\xC1\xBF", false},
      {"\xE0\x80\x80", false},
      {"\xED\xA0\x80", false},
      {"\xF0\x80\x80\x80", false},
      {"\xF4\x90\x80\x80", false},
      {"\xF5\x80\x80\x80", false},
      {"\x80", false},
      {"\xC3", false},
      {"\xE2\x82", false},
      {"\xE2\x28\xAC", false},
      {"\xF0\x9F\x98", false},
  };
  for (const auto& [form, valid] : forms) {
    Bytes edited = good;
    const size_t at = string_at(0) + 9 - form.size();  // at the end: a cut sequence ends the string
    std::memcpy(edited.data() + at, form.data(), form.size());
    FixChecksum(edited);
    auto read = Read(edited);
    EXPECT_EQ(read.ok(), valid) << "form of " << form.size() << " bytes starting " << int(uint8_t(form[0]));
  }
  // A name that is not UTF-8 is written as the JSON writer writes it: both read back the same.
  SphereSet latin1 = Small();
  latin1.joint_names[0] = "h\xE9po";
  latin1.parts[0].name = "t\xEAte";
  latin1.source_file = std::string("cut \xE2\x82") + "|overlong \xC0\xAF|surrogate \xED\xA0\x80|end \xF0\x9F\x98";
  auto from_binary = Read(WriteSphereSetBinary(latin1));
  ASSERT_TRUE(from_binary.ok()) << from_binary.error().message;
  EXPECT_EQ(from_binary->joint_names[0], "h\xEF\xBF\xBDpo");
  EXPECT_EQ(from_binary->parts[0].name, "t\xEF\xBF\xBDte");
  EXPECT_EQ(from_binary->source_file.find("cut \xEF\xBF\xBD|"), 0u) << from_binary->source_file;  // one per sequence
  auto from_json = ReadSphereSetJson(WriteSphereSetJson(latin1), "latin1.json");
  ASSERT_TRUE(from_json.ok()) << from_json.error().message;
  EXPECT_EQ(WriteSphereSetJson(*from_binary), WriteSphereSetJson(*from_json));
  EXPECT_EQ(WriteSphereSetBinary(*from_json), WriteSphereSetBinary(*from_binary));
}

}  // namespace
}  // namespace skinspheres::runtime
