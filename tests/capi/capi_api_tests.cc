// The C API's lookups and lifetimes against the C++ runtime as the oracle: the sphere -> part and
// joint calls against the SphereSet's own arrays, the instance's extra and unmapped joints against
// MapJoints, the asset's reference count (instance_asset + retain keep it alive after the caller's
// release: run under ASan in .ci/run), the total count on SKINSPHERES_BUFFER_TOO_SMALL, the last
// error (one line, cleared by skinspheres_clear_last_error) and the refusal of every wrong call.
// Reads the fitted characters of the fixture folder (support/character_fixture.h).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "skinspheres/runtime/api/joint_mapping.h"
#include "skinspheres/runtime/format/sphere_set_io.h"
#include "skinspheres/skinspheres.h"
#include "support/character_fixture.h"

namespace rt = skinspheres::runtime;

namespace {

static_assert(static_cast<size_t>(SKINSPHERES_ALL_PART_PAIRS) == SIZE_MAX, "the selector reaches size_t as SIZE_MAX");

// A fixture set through both APIs: the C asset and the C++ SphereSet read from the same file.
struct Loaded {
  skinspheres_asset* asset = nullptr;
  rt::SphereSet set;
};

bool Load(const std::string& name, Loaded* out) {
  const std::filesystem::path path = skinspheres::test::FixtureDir() / name;
  auto set = rt::LoadSphereSet(path);
  if (!set.ok()) return false;
  out->set = std::move(set).value();
  return skinspheres_asset_load_file(path.string().c_str(), &out->asset) == SKINSPHERES_OK;
}

// The last error is a single non-empty line.
void ExpectOneLine(const char* what) {
  const std::string message = skinspheres_last_error();
  EXPECT_FALSE(message.empty()) << what;
  EXPECT_EQ(message.find('\n'), std::string::npos) << what << ": " << message;
}

class CApi : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!Load("builtin.ssb", &builtin_))
      GTEST_SKIP() << "no fixture builtin.ssb in " << skinspheres::test::FixtureDir();
  }
  void TearDown() override { skinspheres_asset_release(builtin_.asset); }
  Loaded builtin_;
};

TEST_F(CApi, SpherePartAndJointsAreTheSphereSets) {
  const rt::SphereSet& set = builtin_.set;
  ASSERT_EQ(skinspheres_asset_sphere_count(builtin_.asset), set.size());
  size_t several = 0;
  for (size_t s = 0; s < set.size(); ++s) {
    size_t part = SIZE_MAX;
    ASSERT_EQ(skinspheres_asset_sphere_part(builtin_.asset, s, &part), SKINSPHERES_OK);
    EXPECT_EQ(part, set.sphere_part[s]);
    const uint32_t begin = set.influence_offsets[s], end = set.influence_offsets[s + 1];
    std::vector<uint32_t> joints(end - begin + 1, UINT32_MAX);
    std::vector<float> weights(end - begin + 1, -1.0f);
    size_t count = 0;
    ASSERT_EQ(skinspheres_asset_sphere_joints(builtin_.asset, s, joints.data(), weights.data(), joints.size(), &count),
              SKINSPHERES_OK);
    ASSERT_EQ(count, end - begin);
    for (uint32_t k = begin; k < end; ++k) {
      EXPECT_EQ(joints[k - begin], set.influence_joints[k]);
      EXPECT_EQ(weights[k - begin], set.influence_weights[k]);
    }
    EXPECT_EQ(joints[count], UINT32_MAX) << "nothing written past the count";
    // The main joint: of the largest weight, the lowest joint index among equal weights.
    uint32_t main = UINT32_MAX;
    float best = -1.0f;
    for (uint32_t k = begin; k < end; ++k) {
      const float w = set.influence_weights[k];
      const uint32_t j = set.influence_joints[k];
      if (w > best || (w == best && j < main)) best = w, main = j;
    }
    size_t joint = SIZE_MAX;
    ASSERT_EQ(skinspheres_asset_sphere_joint(builtin_.asset, s, &joint), SKINSPHERES_OK);
    EXPECT_EQ(joint, main);
    // Too small: the first entries copied, the total given.
    if (count > 1) {
      ++several;
      uint32_t one_joint = UINT32_MAX;
      float one_weight = -1.0f;
      size_t total = 0;
      EXPECT_EQ(skinspheres_asset_sphere_joints(builtin_.asset, s, &one_joint, &one_weight, 1, &total),
                SKINSPHERES_BUFFER_TOO_SMALL);
      EXPECT_EQ(total, count);
      EXPECT_EQ(one_joint, set.influence_joints[begin]);
      EXPECT_EQ(one_weight, set.influence_weights[begin]);
      ExpectOneLine("sphere_joints too small");
      // Counting alone: no arrays, capacity 0.
      EXPECT_EQ(skinspheres_asset_sphere_joints(builtin_.asset, s, nullptr, nullptr, 0, &total),
                SKINSPHERES_BUFFER_TOO_SMALL);
      EXPECT_EQ(total, count);
    }
  }
  EXPECT_GT(several, 0u) << "no sphere with several joints: the buffer-too-small case is not tested";
}

TEST_F(CApi, WrongCallsAreRefusedWithOneLine) {
  const size_t spheres = skinspheres_asset_sphere_count(builtin_.asset);
  size_t index = 7, count = 7;
  uint32_t joint = 0;
  float weight = 0.0f;
  const auto refused = [](skinspheres_status st, const char* what) {
    EXPECT_EQ(st, SKINSPHERES_INVALID_ARGUMENT) << what;
    ExpectOneLine(what);
    skinspheres_clear_last_error();
  };
  refused(skinspheres_asset_sphere_part(nullptr, 0, &index), "sphere_part null asset");
  refused(skinspheres_asset_sphere_part(builtin_.asset, spheres, &index), "sphere_part out of range");
  refused(skinspheres_asset_sphere_part(builtin_.asset, SIZE_MAX, &index), "sphere_part SIZE_MAX");
  refused(skinspheres_asset_sphere_part(builtin_.asset, 0, nullptr), "sphere_part null out");
  EXPECT_EQ(index, 7u) << "unchanged when refused";
  refused(skinspheres_asset_sphere_joint(nullptr, 0, &index), "sphere_joint null asset");
  refused(skinspheres_asset_sphere_joint(builtin_.asset, spheres, &index), "sphere_joint out of range");
  refused(skinspheres_asset_sphere_joint(builtin_.asset, 0, nullptr), "sphere_joint null out");
  refused(skinspheres_asset_sphere_joints(nullptr, 0, &joint, &weight, 1, &count), "sphere_joints null asset");
  EXPECT_EQ(count, 0u);
  refused(skinspheres_asset_sphere_joints(builtin_.asset, spheres, &joint, &weight, 1, &count),
          "sphere_joints out of range");
  refused(skinspheres_asset_sphere_joints(builtin_.asset, 0, &joint, &weight, 1, nullptr), "sphere_joints null count");
  // The pointer lookups: NULL, and the last error says why.
  EXPECT_EQ(skinspheres_asset_joint_name(builtin_.asset, skinspheres_asset_joint_count(builtin_.asset)), nullptr);
  ExpectOneLine("joint_name out of range");
  skinspheres_clear_last_error();
  EXPECT_EQ(skinspheres_asset_part_name(builtin_.asset, skinspheres_asset_part_count(builtin_.asset)), nullptr);
  ExpectOneLine("part_name out of range");
  EXPECT_EQ(skinspheres_asset_joint_rest_world(nullptr, 0), nullptr);
  ExpectOneLine("joint_rest_world null");
  EXPECT_EQ(skinspheres_instance_extra_joint_name(nullptr, 0), nullptr);
  ExpectOneLine("extra_joint_name null");
  // The strided calls.
  std::vector<float> joints(16 * skinspheres_asset_joint_count(builtin_.asset), 0.0f);
  std::vector<float> positions(3 * skinspheres_asset_vertex_count(builtin_.asset), 0.0f);
  const skinspheres_matrix_layout row_major = {64, 16, 4};
  refused(skinspheres_instance_update_fast_strided(nullptr, joints.data(), 1, &row_major), "update_fast_strided null");
  skinspheres_instance* inst = nullptr;
  ASSERT_EQ(skinspheres_instance_create(builtin_.asset, nullptr, 0, &inst), SKINSPHERES_OK);
  refused(skinspheres_instance_update_fast_strided(inst, nullptr, 3, &row_major), "update_fast_strided null joints");
  refused(skinspheres_instance_update_exact_strided(inst, nullptr, 3, 12, nullptr, 0, nullptr),
          "update_exact_strided null positions");
  refused(skinspheres_instance_update_exact_strided(inst, positions.data(), positions.size() / 3, 12, nullptr, 3,
                                                    &row_major),
          "update_exact_strided null joints with a count");
  refused(skinspheres_instance_find_contacts_strided(inst, nullptr, 3, 12, nullptr, nullptr),
          "find_contacts_strided null positions with a count");
  refused(skinspheres_instance_find_contacts_strided(nullptr, nullptr, 0, 12, nullptr, nullptr),
          "find_contacts_strided null instance");
  refused(skinspheres_crowd_update_and_find_sphere_pairs_strided(nullptr, nullptr, 2, SKINSPHERES_MODE_FAST, nullptr,
                                                                 nullptr),
          "crowd strided null arrays");
  // A short strided list is refused as the packed one is (by the instance, with its message).
  EXPECT_EQ(skinspheres_instance_update_fast_strided(inst, joints.data(), 1, &row_major), SKINSPHERES_INVALID_ARGUMENT);
  ExpectOneLine("update_fast_strided short list");
  const std::string strided_message = skinspheres_last_error();
  EXPECT_EQ(skinspheres_instance_update_fast(inst, joints.data(), 1), SKINSPHERES_INVALID_ARGUMENT);
  EXPECT_EQ(strided_message, skinspheres_last_error());
  // Out-of-range selector and buffers with no room.
  size_t total = 7;
  refused(skinspheres_instance_get_triangle_contacts(inst, 0, nullptr, 0, &total), "triangle contacts out of range");
  EXPECT_EQ(total, 0u);
  refused(skinspheres_instance_get_sphere_pairs(inst, nullptr, 4, &total), "null buffer with a capacity");
  skinspheres_instance_destroy(inst);
}

TEST_F(CApi, ClearLastError) {
  skinspheres_asset* missing = nullptr;
  EXPECT_EQ(skinspheres_asset_load_file("no_such_set.ssb", &missing), SKINSPHERES_FILE_NOT_FOUND);
  EXPECT_NE(std::string(skinspheres_last_error()).find("no_such_set.ssb"), std::string::npos);
  skinspheres_clear_last_error();
  EXPECT_STREQ(skinspheres_last_error(), "");
  // A success leaves it empty; a per-frame failure (a static message) is cleared the same way.
  EXPECT_EQ(skinspheres_asset_sphere_count(builtin_.asset), builtin_.set.size());
  EXPECT_STREQ(skinspheres_last_error(), "");
  size_t part = 0;
  EXPECT_EQ(skinspheres_asset_sphere_part(builtin_.asset, SIZE_MAX, &part), SKINSPHERES_INVALID_ARGUMENT);
  EXPECT_STRNE(skinspheres_last_error(), "");
  skinspheres_clear_last_error();
  EXPECT_STREQ(skinspheres_last_error(), "");
}

TEST_F(CApi, InstanceAssetAndRetainKeepTheAssetAlive) {
  skinspheres_asset* asset = nullptr;
  const std::string path = (skinspheres::test::FixtureDir() / "builtin.ssb").string();
  ASSERT_EQ(skinspheres_asset_load_file(path.c_str(), &asset), SKINSPHERES_OK);
  skinspheres_instance* inst = nullptr;
  ASSERT_EQ(skinspheres_instance_create(asset, nullptr, 0, &inst), SKINSPHERES_OK);
  EXPECT_EQ(skinspheres_instance_asset(inst), asset);
  EXPECT_EQ(skinspheres_instance_asset(nullptr), nullptr);
  skinspheres_asset_release(asset);  // the caller's reference: the instance's remains
  skinspheres_asset* kept = skinspheres_asset_retain(skinspheres_instance_asset(inst));
  EXPECT_EQ(kept, asset);
  EXPECT_EQ(skinspheres_asset_retain(nullptr), nullptr);
  const std::string first_joint = skinspheres_asset_joint_name(kept, 0);
  skinspheres_instance_destroy(inst);  // the instance's reference: the retained one remains
  // Still alive (ASan would report a use after free): readable, and instances can be made from it.
  EXPECT_EQ(skinspheres_asset_sphere_count(kept), builtin_.set.size());
  EXPECT_EQ(first_joint, skinspheres_asset_joint_name(kept, 0));
  skinspheres_instance* again = nullptr;
  ASSERT_EQ(skinspheres_instance_create(kept, nullptr, 0, &again), SKINSPHERES_OK);
  std::vector<float> rest(16 * skinspheres_asset_joint_count(kept));
  for (size_t j = 0; j < skinspheres_asset_joint_count(kept); ++j) {
    std::memcpy(&rest[16 * j], skinspheres_asset_joint_rest_world(kept, j), 16 * sizeof(float));
  }
  EXPECT_EQ(skinspheres_instance_update_fast(again, rest.data(), skinspheres_asset_joint_count(kept)), SKINSPHERES_OK);
  skinspheres_asset_release(kept);  // the instance's reference keeps it until it goes
  EXPECT_EQ(skinspheres_asset_sphere_count(skinspheres_instance_asset(again)), builtin_.set.size());
  skinspheres_instance_destroy(again);  // the last reference: freed (LeakSanitizer checks it is)
}

TEST_F(CApi, TotalCountOnBufferTooSmall) {
  // The rest pose with every translation halved (c_consumer's squashed pose): spheres overlap.
  const size_t joints = skinspheres_asset_joint_count(builtin_.asset);
  std::vector<float> pose(16 * joints);
  for (size_t j = 0; j < joints; ++j) {
    std::memcpy(&pose[16 * j], skinspheres_asset_joint_rest_world(builtin_.asset, j), 16 * sizeof(float));
    for (size_t k = 12; k < 15; ++k) pose[16 * j + k] *= 0.5f;
  }
  skinspheres_instance* inst = nullptr;
  ASSERT_EQ(skinspheres_instance_create(builtin_.asset, nullptr, 0, &inst), SKINSPHERES_OK);
  size_t count = 0, total = 0;
  ASSERT_EQ(skinspheres_instance_update_fast(inst, pose.data(), joints), SKINSPHERES_OK);
  ASSERT_EQ(skinspheres_instance_find_sphere_pairs(inst, &count), SKINSPHERES_OK);
  ASSERT_GT(count, 2u);
  EXPECT_EQ(skinspheres_instance_get_sphere_pairs(inst, nullptr, 0, &total), SKINSPHERES_BUFFER_TOO_SMALL);
  EXPECT_EQ(total, count);
  std::vector<skinspheres_sphere_pair> pairs(count);
  EXPECT_EQ(skinspheres_instance_get_sphere_pairs(inst, pairs.data(), 2, &total), SKINSPHERES_BUFFER_TOO_SMALL);
  EXPECT_EQ(total, count);
  EXPECT_EQ(skinspheres_instance_get_sphere_pairs(inst, pairs.data(), pairs.size(), &total), SKINSPHERES_OK);
  EXPECT_EQ(total, count);
  size_t parts = 0, triangles = 0;
  ASSERT_EQ(skinspheres_instance_find_contacts(inst, nullptr, 0, &parts, &triangles), SKINSPHERES_OK);
  ASSERT_GT(parts, 0u) << "no part pair in contact: the buffer-too-small cases are not tested";
  {
    EXPECT_EQ(skinspheres_instance_get_part_contacts(inst, nullptr, 0, &total), SKINSPHERES_BUFFER_TOO_SMALL);
    EXPECT_EQ(total, parts);
    EXPECT_EQ(skinspheres_instance_get_triangle_contacts(inst, SKINSPHERES_ALL_PART_PAIRS, nullptr, 0, &total),
              SKINSPHERES_BUFFER_TOO_SMALL);
    EXPECT_EQ(total, triangles);
    skinspheres_part_contact first;
    EXPECT_EQ(skinspheres_instance_get_part_contacts(inst, &first, 1, &total),
              parts > 1 ? SKINSPHERES_BUFFER_TOO_SMALL : SKINSPHERES_OK);
    EXPECT_EQ(total, parts);
    EXPECT_EQ(skinspheres_instance_get_triangle_contacts(inst, 0, nullptr, 0, &total), SKINSPHERES_BUFFER_TOO_SMALL);
    EXPECT_EQ(total, first.triangle_pair_count);
  }
  skinspheres_instance_destroy(inst);
}

// An engine list with an extra joint and without one of the set's joints that is never read, in
// the engine's own order (reversed): the instance reports what MapJoints reports.
TEST(CApiJoints, ExtraAndUnmappedJointsAreMapJoints) {
  Loaded loaded;
  rt::SphereSet* set = nullptr;
  size_t not_read = SIZE_MAX;
  for (const char* name : {"builtin.ssb", "Xbot.glb.ssb", "Soldier.glb.ssb", "CesiumMan.glb.ssb"}) {
    skinspheres_asset_release(loaded.asset);
    loaded = {};
    if (!Load(name, &loaded)) continue;
    const std::vector<bool> read = rt::JointsReadPerFrame(loaded.set);
    for (size_t j = 0; j < read.size() && not_read == SIZE_MAX; ++j) {
      if (!read[j]) not_read = j;
    }
    if (not_read != SIZE_MAX) {
      set = &loaded.set;
      break;
    }
  }
  if (set == nullptr) {
    skinspheres_asset_release(loaded.asset);
    GTEST_SKIP() << "no fixture set with a joint that is not read";
  }
  std::vector<std::string> names;
  for (size_t j = set->joint_count(); j-- > 0;) {
    if (j != not_read) names.push_back(set->joint_names[j]);
    if (j == set->joint_count() / 2) names.push_back("IK_target_l");
  }
  names.push_back("prop_sword");
  auto mapping = rt::MapJoints(*set, names);
  ASSERT_TRUE(mapping.ok()) << mapping.error().message;
  ASSERT_EQ(mapping->extra_engine_joints.size(), 2u);
  ASSERT_GE(mapping->unmapped_set_joints.size(), 1u);
  std::vector<const char*> c_names;
  for (const std::string& n : names) c_names.push_back(n.c_str());
  skinspheres_instance* inst = nullptr;
  ASSERT_EQ(skinspheres_instance_create(loaded.asset, c_names.data(), c_names.size(), &inst), SKINSPHERES_OK);
  skinspheres_asset_release(loaded.asset);
  std::vector<std::string> extra, unmapped;
  for (size_t k = 0; k < skinspheres_instance_extra_joint_count(inst); ++k) {
    extra.emplace_back(skinspheres_instance_extra_joint_name(inst, k));
  }
  for (size_t k = 0; k < skinspheres_instance_unmapped_joint_count(inst); ++k) {
    unmapped.emplace_back(skinspheres_instance_unmapped_joint_name(inst, k));
  }
  EXPECT_EQ(extra, mapping->extra_engine_joints);
  EXPECT_EQ(unmapped, mapping->unmapped_set_joints);
  EXPECT_NE(std::find(unmapped.begin(), unmapped.end(), set->joint_names[not_read]), unmapped.end());
  skinspheres_clear_last_error();
  EXPECT_EQ(skinspheres_instance_extra_joint_name(inst, extra.size()), nullptr);
  ExpectOneLine("extra joint out of range");
  EXPECT_EQ(skinspheres_instance_unmapped_joint_name(inst, unmapped.size()), nullptr);
  ExpectOneLine("unmapped joint out of range");
  skinspheres_instance_destroy(inst);
  // Without names: the set's own order, nothing extra or unmapped.
  skinspheres_asset* asset = nullptr;
  ASSERT_EQ(skinspheres_asset_load_file((skinspheres::test::FixtureDir() / "builtin.ssb").string().c_str(), &asset),
            SKINSPHERES_OK);
  ASSERT_EQ(skinspheres_instance_create(asset, nullptr, 0, &inst), SKINSPHERES_OK);
  EXPECT_EQ(skinspheres_instance_extra_joint_count(inst), 0u);
  EXPECT_EQ(skinspheres_instance_unmapped_joint_count(inst), 0u);
  EXPECT_EQ(skinspheres_instance_unmapped_joint_name(inst, 0), nullptr);
  skinspheres_instance_destroy(inst);
  skinspheres_asset_release(asset);
}

}  // namespace
