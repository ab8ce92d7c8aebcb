// Sphere sets a user (or an attacker) can hand the runtime, beyond a malformed file: each case is
// a regression test for a crash, hang, unbounded read or silent acceptance found by probing.
#if !defined(_WIN32)
#include <sys/stat.h>
#include <unistd.h>
#endif

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <fstream>
#include <functional>
#include <future>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>

#include "runtime/format/binary_edit.h"
#include "runtime/format/contact_rules_sets.h"
#include "runtime/posed_characters.h"
#include "runtime/sample_sphere_set.h"
#include "skinspheres/runtime/api/joint_mapping.h"
#include "skinspheres/runtime/format/file_io.h"
#include "skinspheres/runtime/format/sphere_set_binary.h"
#include "skinspheres/runtime/format/sphere_set_io.h"
#include "skinspheres/runtime/refit/refit_job.h"
#include "test_support.h"

namespace skinspheres::runtime {
namespace {

void ExpectRefused(const Result<SphereSet>& r, const std::string& name, ErrorCode code, const std::string& needle) {
  ASSERT_FALSE(r.ok()) << name << " was accepted";
  EXPECT_EQ(r.error().code, code) << r.error().message;
  EXPECT_EQ(r.error().message.rfind(name + ": ", 0), 0u) << r.error().message;
  EXPECT_EQ(r.error().message.find('\n'), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find(needle), std::string::npos) << r.error().message;
}

using namespace test_binary;  // binary_edit.h

// Loads on another thread and fails after a minute (a FIFO read used to block forever).
Result<SphereSet> LoadWithin60s(const std::filesystem::path& path) {
  auto future = std::async(std::launch::async, [path] { return LoadSphereSet(path); });
  if (future.wait_for(std::chrono::seconds(60)) != std::future_status::ready) {
    ADD_FAILURE() << path << ": still loading after 60 s";
    std::ofstream unblock(path);  // a writer lets a blocked open go on
  }
  return future.get();
}

TEST(SphereSetHostile, ParamsNested100000DeepAreRefusedBeforeParsing) {
  // It crashed play --spheres with SIGSEGV (recursion on the parsed params).
  std::string text = WriteSphereSetJson(TwoSpheres());
  const std::string deep = std::string(100000, '[') + std::string(100000, ']');
  const size_t at = text.find("\"params\":{}");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 11, "\"params\":{\"x\":" + deep + "}");
  ExpectRefused(ReadSphereSetJson(text, "deep.json"), "deep.json", ErrorCode::kFormatRejected, "nests 100002 deep");
  // Within the limit the same set reads.
  text = WriteSphereSetJson(TwoSpheres());
  text.replace(text.find("\"params\":{}"), 11,
               "\"params\":{\"x\":" + std::string(100, '[') + std::string(100, ']') + "}");
  EXPECT_TRUE(ReadSphereSetJson(text, "ok.json").ok());
}

TEST(SphereSetHostile, OnlyRegularFilesWithinTheSizeLimitAreRead) {
  const auto dir = test::TempDir("sphere_set_files");
  const test::TestPipe pipe(dir, "fifo.json");
  ASSERT_TRUE(pipe.ok());
  ExpectRefused(LoadWithin60s(pipe.path()), PathText(pipe.path()), ErrorCode::kFileUnreadable, "pipe");
  const auto device = test::DeviceNotAFile();
  ExpectRefused(LoadWithin60s(device), PathText(device), ErrorCode::kFileUnreadable, "device");
  ExpectRefused(LoadWithin60s(dir), PathText(dir), ErrorCode::kFileUnreadable, "directory");
  const auto huge = dir / "huge.json";
  ASSERT_TRUE(test::MakeLongFile(huge, kMaxSphereSetBytes + 1, "{"));  // sparse where it can: no disk used
  ExpectRefused(LoadWithin60s(huge), PathText(huge), ErrorCode::kFormatRejected,
                "a sphere set may be at most 536870912 bytes");
}

TEST(SphereSetHostile, ValidateRefusesRadiiOfZeroOrLess) {
  for (const float r : {0.0f, -1.0f}) {
    SphereSet set = TwoSpheres();
    set.radii_rest[1] = r;
    const auto err = set.Validate();
    ASSERT_TRUE(err.has_value()) << r;
    EXPECT_NE(err->message.find("sphere 1 has radius"), std::string::npos) << err->message;
    ExpectRefused(ReadSphereSetJson(WriteSphereSetJson(set), "r.json"), "r.json", ErrorCode::kInvalidData,
                  "(must be > 0)");
  }
}

TEST(SphereSetHostile, ValidateRefusesEmptyAndDuplicatePartNames) {
  SphereSet set = TwoSpheres();
  ASSERT_FALSE(set.Validate().has_value());
  set.parts.push_back(set.parts[0]);  // a second part with the first one's name
  ASSERT_TRUE(set.Validate().has_value());
  EXPECT_NE(set.Validate()->message.find("parts 0 and " + std::to_string(set.parts.size() - 1) + " are both named '" +
                                         set.parts[0].name + "'"),
            std::string::npos)
      << set.Validate()->message;
  ExpectRefused(ReadSphereSetJson(WriteSphereSetJson(set), "dup.json"), "dup.json", ErrorCode::kInvalidData,
                "both named");
  ExpectRefused(ReadSphereSetBinary(WriteSphereSetBinary(set), "dup.ssb"), "dup.ssb", ErrorCode::kInvalidData,
                "both named");
  set = TwoSpheres();
  set.parts[0].name.clear();
  ASSERT_TRUE(set.Validate().has_value());
  EXPECT_NE(set.Validate()->message.find("part 0 has an empty name"), std::string::npos) << set.Validate()->message;
}

TEST(SphereSetHostile, ValidateRefusesUnownedAndDoublyOwnedTriangles) {
  SphereSet unowned = TwoSpheres();  // sphere 1 gives up triangle 1: no sphere holds it
  unowned.triangles = {0};
  unowned.triangle_offsets = {0, 1, 1};
  ASSERT_TRUE(unowned.Validate().has_value());
  EXPECT_NE(unowned.Validate()->message.find("own 1 triangle entries for 2 triangles"), std::string::npos)
      << unowned.Validate()->message;
  SphereSet twice = TwoSpheres();  // sphere 1 owns triangle 0 as well: 2 entries, but triangle 1 lost
  twice.triangles = {0, 0};
  ASSERT_TRUE(twice.Validate().has_value());
  EXPECT_NE(twice.Validate()->message.find("triangle 0 is owned by spheres 0 and 1"), std::string::npos)
      << twice.Validate()->message;
  SphereSet none = TwoSpheres();  // "spheres": [] with no triangle either
  none = SphereSet{};
  none.joint_names = {"root"};
  none.joint_parents = {-1};
  none.joint_rest_world = {Mat4f::Identity()};
  none.vertex_offsets = none.triangle_offsets = none.influence_offsets = {0};
  ASSERT_TRUE(none.Validate().has_value());
  EXPECT_NE(none.Validate()->message.find("no spheres"), std::string::npos) << none.Validate()->message;
  SphereSet empty_list = TwoSpheres();  // "spheres": [] on a mesh of 2 triangles
  empty_list.centers_rest.clear();
  empty_list.radii_rest.clear();
  empty_list.radii_fast.clear();
  empty_list.sphere_part.clear();
  empty_list.sphere_joint.clear();
  empty_list.sphere_level.clear();
  empty_list.vertices.clear();
  empty_list.triangles.clear();
  empty_list.influence_joints.clear();
  empty_list.influence_weights.clear();
  empty_list.vertex_offsets = empty_list.triangle_offsets = empty_list.influence_offsets = {0};
  empty_list.excluded_pairs.clear();
  ExpectRefused(ReadSphereSetJson(WriteSphereSetJson(empty_list), "empty.json"), "empty.json", ErrorCode::kInvalidData,
                "no spheres");
  // A huge triangle count from a tiny file is refused from the list's length, never allocated.
  SphereSet huge_count = TwoSpheres();
  huge_count.source_triangle_count = 4000000000u;
  ASSERT_TRUE(huge_count.Validate().has_value());
  EXPECT_NE(huge_count.Validate()->message.find("for 4000000000 triangles"), std::string::npos);
}

TEST(SphereSetHostile, StreamedReadingKeepsEveryPartOfTheSet) {
  // The reader takes spheres, pairs and mesh arrays out of the document as they complete: the
  // round trip stays exact, and keys in any order (ours are written sorted) read the same.
  const SphereSet set = TwoSpheresWithMesh();
  const std::string text = WriteSphereSetJson(set);
  auto read = ReadSphereSetJson(text, "set.json");
  ASSERT_TRUE(read.ok()) << read.error().message;
  EXPECT_EQ(WriteSphereSetJson(*read), text);
  // Reversed key order at the top level: spheres and mesh before format and version.
  const nlohmann::json j = nlohmann::json::parse(text);
  std::string reversed = "{";
  std::vector<std::string> keys;
  for (auto it = j.begin(); it != j.end(); ++it) keys.push_back(it.key());
  for (auto k = keys.rbegin(); k != keys.rend(); ++k) {
    reversed += (k == keys.rbegin() ? "\"" : ",\"") + *k + "\":" + j[*k].dump();
  }
  reversed += "}";
  auto again = ReadSphereSetJson(reversed, "reversed.json");
  ASSERT_TRUE(again.ok()) << again.error().message;
  EXPECT_EQ(WriteSphereSetJson(*again), text);
  // A mesh array of the wrong type, or missing, is named.
  nlohmann::json bad = j;
  bad["mesh"]["triangles"] = 5;
  ExpectRefused(ReadSphereSetJson(bad.dump(), "bad.json"), "bad.json", ErrorCode::kInvalidData,
                "$.mesh.triangles is missing");
  bad = j;
  bad["mesh"]["positions_bind"][0] = "x";
  ExpectRefused(ReadSphereSetJson(bad.dump(), "bad.json"), "bad.json", ErrorCode::kInvalidData,
                "$.mesh.positions_bind is not a number");
}

// An empty file and one shorter than the binary magic were reported as "not valid JSON"; an empty
// path as ": file not found" (no name at all).
TEST(SphereSetHostile, EmptyAndTinyFilesAndAnEmptyPathAreNamedForWhatTheyAre) {
  const auto dir = test::TempDir("sphere_set_tiny");
  const auto empty = dir / "empty.ssb", tiny = dir / "tiny.ssb";
  ASSERT_FALSE(WriteWholeFile(empty, ""));
  ASSERT_FALSE(WriteWholeFile(tiny, std::string_view(reinterpret_cast<const char*>(kSphereSetBinaryMagic), 5)));
  ExpectRefused(LoadSphereSet(empty), empty.string(), ErrorCode::kFormatRejected, "empty file");
  ExpectRefused(LoadSphereSet(tiny), tiny.string(), ErrorCode::kFormatRejected,
                "too short to be a sphere set (5 bytes)");
  const auto no_path = LoadSphereSet("");
  ASSERT_FALSE(no_path.ok());
  EXPECT_EQ(no_path.error().code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(no_path.error().message.rfind("empty path", 0), 0u) << no_path.error().message;
}

#if !defined(_WIN32)
// Opening a FIFO nobody reads for writing used to block forever (convert, fit -o, --dump...): it
// is refused at once, naming the path; a FIFO with a reader is written through. (POSIX: Windows
// has no FIFOs in the file system.)
TEST(SphereSetHostile, AFifoOutputWithoutAReaderIsRefusedNotWaitedOn) {
  const auto dir = test::TempDir("sphere_set_fifo_out");
  const auto fifo = dir / "out.json";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  auto saved = std::async(std::launch::async, [&] { return SaveSphereSet(TwoSpheres(), fifo); });
  if (saved.wait_for(std::chrono::seconds(60)) != std::future_status::ready) {
    ADD_FAILURE() << fifo << ": still opening after 60 s";
    std::ifstream unblock(fifo);  // a reader lets a blocked open go on
  }
  const auto err = saved.get();
  ASSERT_TRUE(err.has_value());
  EXPECT_EQ(err->message, fifo.string() + ": is a FIFO (named pipe) nobody reads: cannot write to it");
  // With a reader already there the write goes through, and the reader gets the whole set.
  auto reader = std::async(std::launch::async, [&] {
    std::ifstream in(fifo, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  });
  std::optional<Error> written;
  for (int attempt = 0; attempt < 6000; ++attempt) {  // until the reader has opened its end
    written = SaveSphereSet(TwoSpheres(), fifo);
    if (!written || written->message.find("nobody reads") == std::string::npos) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_FALSE(written.has_value()) << written->message;
  EXPECT_EQ(reader.get(), WriteSphereSetJson(TwoSpheres()) + "\n");
}
#endif

// Names are data: a joint or part name may hold a newline or a NUL (JSON escapes them, and they
// round-trip); where an error quoting one leaves the library (C API, tool) OneLine keeps it one line.
TEST(SphereSetHostile, ControlCharactersInNamesNeverBreakAnErrorLine) {
  SphereSet set = TwoSpheres();
  set.joint_names[0] = std::string("ro\not\0x", 7);
  auto back = ReadSphereSetJson(WriteSphereSetJson(set), "names.json");
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->joint_names[0], set.joint_names[0]);
  const std::vector<std::string> engine = {"other"};
  auto mapping = MapJoints(*back, engine);
  ASSERT_FALSE(mapping.ok());
  const std::string line = OneLine(mapping.error().message);
  EXPECT_NE(line.find("ro\\not\\x00x"), std::string::npos) << line;
  EXPECT_TRUE(std::none_of(line.begin(), line.end(), [](unsigned char c) { return c < 0x20 || c == 0x7f; })) << line;
  EXPECT_EQ(OneLine("a\tb\rc\x7f"), "a\\tb\\rc\\x7f");
  EXPECT_EQ(OneLine("plain: unchanged"), "plain: unchanged");
}

// A fast reference within each bound CheckFastReference had (an inverse scaled by 1e9, centres at
// 1e18) carried the centres to 1e27 at the rest pose: the fast refit's squared spread overflowed
// and every radius was inf, at every pose. Found by fuzzing (fuzz/fuzz_engine.h CheckFastRefit).
TEST(SphereSetHostile, ValidateRefusesAFastReferenceBeyondRangeAtTheRestPose) {
  SphereSet set = TwoSpheres();
  set.fast_reference_inverse = {skinspheres::Mat4f::Identity()};
  set.fast_reference_spheres = {skinspheres::Vec4f(0, 0, 0, 1), skinspheres::Vec4f(1, 0, 0, 1)};
  ASSERT_FALSE(set.Validate().has_value()) << set.Validate()->message;
  set.fast_reference_inverse[0].topLeftCorner<3, 3>() *= 1e9f;
  set.fast_reference_spheres[1].x() = 1e18f;
  ExpectRefused(ReadSphereSetJson(WriteSphereSetJson(set), "far.json"), "far.json", ErrorCode::kInvalidData,
                "sphere 1's fast reference sphere, carried to the rest pose by joint 0, lies beyond 1e18 units");
}

// A rest transform scaled by 1e-30 (finite, invertible) put sphere 1's centre at 1e30 in the
// joint's frame: inf in float, and the fast refit's radius inf at the rest pose and every other.
// Validate cannot tell (it inverts no rest transform); the rest data refuses it. Found by fuzzing
// (fuzz/fuzz_engine.h CheckFastRefit).
TEST(SphereSetHostile, RestDataRefusesCentresBeyondFloatRangeInTheirJointFrame) {
  SphereSet set = TwoSpheres();
  set.joint_rest_world[0].topLeftCorner<3, 3>() *= 1e-30f;
  set.centers_rest[1].x() = 1e10f;
  ASSERT_FALSE(set.Validate().has_value()) << set.Validate()->message;
  const auto rest = RefitRestData::Create(set);
  ASSERT_FALSE(rest.ok());
  EXPECT_NE(rest.error().message.find("sphere 1's centre in the reference frame of joint 0 is out of"),
            std::string::npos)
      << rest.error().message;
}

// An inverse bind matrix ending in 0 0 0 2: skinning (the whole 4x4) put vertices 0.36 to 0.5 units
// outside the fast spheres that CheckFastRadii / CheckFastReference / CheckReachGroups (the top three
// rows) had passed. The importers' own rounding (0.99999994) is still read. Found by fuzzing
// (fuzz/fuzz_engine.h CheckFastRefit).
TEST(SphereSetHostile, ValidateRefusesInverseBindMatricesThatAreNotAffine) {
  SphereSet set = TwoSpheresWithMesh();
  set.mesh.binds[0].inverse_bind(3, 3) = 0.99999994f;
  ASSERT_FALSE(set.Validate().has_value()) << set.Validate()->message;
  set.mesh.binds[0].inverse_bind(3, 3) = 2.0f;
  ExpectRefused(ReadSphereSetJson(WriteSphereSetJson(set), "ibm.json"), "ibm.json", ErrorCode::kInvalidData,
                "mesh bind entry 0's inverse bind matrix is not affine");
  set.mesh.binds[0].inverse_bind(3, 3) = 1.0f;
  set.mesh.binds[0].inverse_bind(3, 0) = 0.5f;
  EXPECT_TRUE(set.Validate().has_value());
}

// The contact rules (narrow_phase/contact_rules.h, CheckContactRules), on TwoJointsWithMesh: rest
// height 0.5 (a rest gap up to 0.025), sphere 0's triangle on joint a, sphere 1's on joint b, one bone
// apart. Rules out of range, a reason only sets with their rules on sphere pairs give, and a pair
// that rule 2 does not exclude whole (which would hide the contacts of its triangles) are refused by
// SphereSet::Validate and by both readers, naming the problem. The JSON writer cannot write a NaN or
// infinite gap, nor hops, a gap or unknown rules for a set whose rules are not on triangles:
// ContactRulesInJsonAreRefusedByName edits such documents by hand.
TEST(SphereSetHostile, BrokenContactRulesAreRefusedByValidateAndBothReaders) {
  const SphereSet good = WithRulesOnTriangles(TwoJointsWithMesh(), 1, 0.01f);
  ASSERT_FALSE(good.Validate().has_value()) << good.Validate()->message;
  ASSERT_EQ(good.excluded_pairs.size(), 1u);
  struct Case {
    const char* what;
    std::function<void(SphereSet&)> edit;
    std::string needle;
    bool json;
  };
  const std::string gap_range = "the rest gap is not finite and >= 0";
  const std::string on_pairs = "a set with its contact rules on sphere pairs has contact hops or a rest gap";
  const std::vector<Case> cases = {
      {"hops 3", [](SphereSet& s) { s.contact_hops = 3; }, "contact hops 3 above 2", true},
      {"negative rest gap", [](SphereSet& s) { s.rest_gap = -0.001f; }, gap_range, true},
      {"NaN rest gap", [](SphereSet& s) { s.rest_gap = std::numeric_limits<float>::quiet_NaN(); }, gap_range, false},
      {"infinite rest gap", [](SphereSet& s) { s.rest_gap = std::numeric_limits<float>::infinity(); }, gap_range,
       false},
      {"rest gap above its share", [](SphereSet& s) { s.rest_gap = 0.03f; },
       "the rest gap 0.030000 is more than 0.050000 of the rest height", true},
      {"bind_overlap on triangles", [](SphereSet& s) { s.excluded_pairs[0].reason = ExclusionReason::kBindOverlap; },
       "excluded pair (0, 1) overlaps at rest: a reason only sets with their contact rules on sphere pairs give", true},
      {"a pair rule 2 does not exclude", [](SphereSet& s) { s.contact_hops = 0; },
       "excluded pair (0, 1) holds triangles whose joints are more than 0 bones apart: it would hide their contacts",
       true},
      {"unknown rules", [](SphereSet& s) { s.contact_rules = static_cast<ContactRules>(2); }, "unknown contact rules",
       false},
      {"hops on sphere pairs", [](SphereSet& s) { s.contact_rules = ContactRules::kSpherePairs; }, on_pairs, false},
      {"rest gap on sphere pairs",
       [](SphereSet& s) {
         s = WithRulesOnSpherePairs(s);
         s.rest_gap = 0.001f;
       },
       on_pairs, false},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    SphereSet set = good;
    c.edit(set);
    const auto err = set.Validate();
    ASSERT_TRUE(err.has_value());
    EXPECT_EQ(err->code, ErrorCode::kInvalidData);
    EXPECT_NE(err->message.find(c.needle), std::string::npos) << err->message;
    ExpectRefused(ReadSphereSetBinary(WriteSphereSetBinary(set), "rules.ssb"), "rules.ssb", ErrorCode::kInvalidData,
                  c.needle);
    if (c.json) {
      ExpectRefused(ReadSphereSetJson(WriteSphereSetJson(set), "rules.json"), "rules.json", ErrorCode::kInvalidData,
                    c.needle);
    }
  }
  SphereSet unknown = good;
  unknown.contact_rules = static_cast<ContactRules>(2);
  ExpectRefused(ReadSphereSetBinary(WriteSphereSetBinary(unknown), "rules.ssb"), "rules.ssb", ErrorCode::kInvalidData,
                "unknown contact rules 2");
}

// A version-4 document's "contact_rules": required, an object with "on" ("triangles" or
// "sphere_pairs"), "hops" and "rest_gap" in range; refused before version 4, where the rules are on
// sphere pairs as fitted. Each refusal names the place or the rule.
TEST(SphereSetHostile, ContactRulesInJsonAreRefusedByName) {
  using nlohmann::json;
  const json good = json::parse(WriteSphereSetJson(WithRulesOnTriangles(TwoJointsWithMesh(), 1, 0.01f)));
  ASSERT_EQ(good["version"], kSphereSetVersionWithRules);
  ASSERT_TRUE(ReadSphereSetJson(good.dump(), "rules.json").ok());
  struct Case {
    const char* what;
    std::function<void(json&)> edit;
    std::string needle;
  };
  const std::string on = "$.contact_rules.on is not \"triangles\" or \"sphere_pairs\"";
  const std::vector<Case> cases = {
      {"missing in version 4", [](json& j) { j.erase("contact_rules"); }, "$.contact_rules is missing"},
      {"in version 3", [](json& j) { j["version"] = 3; }, "$.contact_rules is not part of version 3"},
      {"in version 2", [](json& j) { j["version"] = 2; }, "$.contact_rules is not part of version 2"},
      {"not an object", [](json& j) { j["contact_rules"] = "triangles"; }, "$.contact_rules is not an object"},
      {"on missing", [](json& j) { j["contact_rules"].erase("on"); }, "$.contact_rules.on is missing"},
      {"on unknown", [](json& j) { j["contact_rules"]["on"] = "spheres"; }, on},
      {"on not a string", [](json& j) { j["contact_rules"]["on"] = 1; }, on},
      {"hops missing", [](json& j) { j["contact_rules"].erase("hops"); }, "$.contact_rules.hops is missing"},
      {"hops 3", [](json& j) { j["contact_rules"]["hops"] = 3; }, "contact hops 3 above 2"},
      {"hops negative", [](json& j) { j["contact_rules"]["hops"] = -1; }, "$.contact_rules.hops is out of range"},
      {"hops fractional", [](json& j) { j["contact_rules"]["hops"] = 1.5; }, "$.contact_rules.hops is not an integer"},
      {"rest gap missing", [](json& j) { j["contact_rules"].erase("rest_gap"); },
       "$.contact_rules.rest_gap is missing"},
      {"rest gap negative", [](json& j) { j["contact_rules"]["rest_gap"] = -0.5; },
       "the rest gap is not finite and >= 0"},
      // The JSON writer writes a NaN as null.
      {"rest gap NaN", [](json& j) { j["contact_rules"]["rest_gap"] = std::numeric_limits<double>::quiet_NaN(); },
       "$.contact_rules.rest_gap is not a number"},
      {"rest gap as text", [](json& j) { j["contact_rules"]["rest_gap"] = "NaN"; },
       "$.contact_rules.rest_gap is not a number"},
      {"rest gap beyond float", [](json& j) { j["contact_rules"]["rest_gap"] = 1e39; },
       "$.contact_rules.rest_gap is out of range"},
      {"rest gap above its share", [](json& j) { j["contact_rules"]["rest_gap"] = 0.03; },
       "is more than 0.050000 of the rest height"},
      {"sphere pairs with hops", [](json& j) { j["contact_rules"]["on"] = "sphere_pairs"; },
       "a set with its contact rules on sphere pairs has contact hops or a rest gap"},
      {"bind_overlap on triangles", [](json& j) { j["excluded_pairs"][0][2] = "bind_overlap"; },
       "excluded pair (0, 1) overlaps at rest"},
      {"a pair rule 2 does not exclude", [](json& j) { j["contact_rules"]["hops"] = 0; },
       "excluded pair (0, 1) holds triangles whose joints are more than 0 bones apart"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    json j = good;
    c.edit(j);
    ExpectRefused(ReadSphereSetJson(j.dump(), "rules.json"), "rules.json", ErrorCode::kInvalidData, c.needle);
  }
}

// Sections 39-40 of a layout-6 file (sphere_set_binary.h): exactly (rules, hops) and one gap, and a
// rules value the reader knows; refused by name behind a valid checksum.
TEST(SphereSetHostile, ContactRuleSectionsInBinaryAreRefusedByName) {
  const Bytes good = WriteSphereSetBinary(WithRulesOnTriangles(TwoJointsWithMesh(), 1, 0.01f));
  ASSERT_TRUE(ReadSphereSetBinary(good, "rules.ssb").ok());
  const size_t rules = FindEntry(good, SphereSetSection::kContactRules);
  const size_t gap = FindEntry(good, SphereSetSection::kRestGap);
  ASSERT_TRUE(rules != 0 && gap != 0);
  struct Case {
    const char* what;
    std::function<void(Bytes&)> edit;
    std::string needle;
  };
  const std::vector<Case> cases = {
      {"rules count 3", [&](Bytes& b) { Put64(b, rules + 16, 3); }, "section contact_rules has 3 elements, expected 2"},
      {"rules count 1", [&](Bytes& b) { Put64(b, rules + 16, 1); }, "section contact_rules has 1 elements, expected 2"},
      {"gap count 0", [&](Bytes& b) { Put64(b, gap + 16, 0); }, "section rest_gap has 0 elements, expected 1"},
      {"gap count 2", [&](Bytes& b) { Put64(b, gap + 16, 2); }, "section rest_gap has 2 elements, expected 1"},
      {"rules 2", [&](Bytes& b) { Put32(b, Get64(b, rules + 8), 2); }, "unknown contact rules 2"},
      {"rules 2^32 - 1", [&](Bytes& b) { Put32(b, Get64(b, rules + 8), 0xFFFFFFFFu); },
       "unknown contact rules 4294967295"},
      {"hops 3", [&](Bytes& b) { Put32(b, Get64(b, rules + 8) + 4, 3); }, "contact hops 3 above 2"},
      {"gap NaN", [&](Bytes& b) { Put32(b, Get64(b, gap + 8), 0x7FC00000u); }, "the rest gap is not finite and >= 0"},
      {"gap -inf", [&](Bytes& b) { Put32(b, Get64(b, gap + 8), 0xFF800000u); }, "the rest gap is not finite and >= 0"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    Bytes bad = good;
    c.edit(bad);
    FixChecksum(bad);
    ExpectRefused(ReadSphereSetBinary(bad, "rules.ssb"), "rules.ssb", ErrorCode::kInvalidData, c.needle);
  }
}

// The fitted set lists only sphere pairs rule 2 excludes whole. One more, between the two spheres
// whose joints lie furthest apart in the skeleton (found by walking the parents), would hide every
// contact of their triangles: refused, by Validate and both readers.
TEST(SphereSetHostile, AFittedSetListingAPairRuleTwoDoesNotExcludeIsRefused) {
  const auto fc = test::LoadFitted("builtin");
  ASSERT_TRUE(fc);
  SphereSet set = fc->set;
  ASSERT_EQ(set.contact_rules, ContactRules::kTriangles);
  ASSERT_FALSE(set.Validate().has_value()) << set.Validate()->message;
  const auto depth = [&](int32_t j) {
    int d = 0;
    for (; set.joint_parents[j] >= 0; j = set.joint_parents[j]) ++d;
    return d;
  };
  const auto bones_apart = [&](int32_t a, int32_t b) {
    int d = 0;
    while (a != b) {
      if (depth(a) >= depth(b)) {
        a = set.joint_parents[a];
      } else {
        b = set.joint_parents[b];
      }
      ++d;
      if (a < 0 || b < 0) return 1 << 20;  // different roots
    }
    return d;
  };
  uint32_t far_i = 0, far_j = 0;
  int farthest = -1;
  for (uint32_t i = 0; i < set.size(); ++i) {
    for (uint32_t j = i + 1; j < set.size(); ++j) {
      const int d = bones_apart(set.sphere_joint[i], set.sphere_joint[j]);
      if (d > farthest) farthest = d, far_i = i, far_j = j;
    }
  }
  ASSERT_GT(farthest, int(set.contact_hops));
  ASSERT_TRUE(std::none_of(set.excluded_pairs.begin(), set.excluded_pairs.end(),
                           [&](const ExcludedPair& p) { return p.i == far_i && p.j == far_j; }));
  const ExcludedPair added{far_i, far_j, ExclusionReason::kAdjacentJoints};
  set.excluded_pairs.insert(std::upper_bound(set.excluded_pairs.begin(), set.excluded_pairs.end(), added,
                                             [](const ExcludedPair& a, const ExcludedPair& b) {
                                               return std::pair(a.i, a.j) < std::pair(b.i, b.j);
                                             }),
                            added);
  const std::string needle = "excluded pair (" + std::to_string(far_i) + ", " + std::to_string(far_j) +
                             ") holds triangles whose joints are more than " + std::to_string(set.contact_hops) +
                             " bones apart";
  const auto err = set.Validate();
  ASSERT_TRUE(err.has_value());
  EXPECT_NE(err->message.find(needle), std::string::npos) << err->message;
  ExpectRefused(ReadSphereSetBinary(WriteSphereSetBinary(set), "fitted.ssb"), "fitted.ssb", ErrorCode::kInvalidData,
                needle);
  ExpectRefused(ReadSphereSetJson(WriteSphereSetJson(set), "fitted.json"), "fitted.json", ErrorCode::kInvalidData,
                needle);
}

}  // namespace
}  // namespace skinspheres::runtime
