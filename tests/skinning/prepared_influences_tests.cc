// PreparedInfluences::Build: grouping by influence count, slot order, required sizes, and the
// refusals (with messages) of inconsistent CSR input.
#include <gtest/gtest.h>

#include "skinning/synthetic_mesh.h"
#include "skinspheres/skinning/prepared_influences.h"

namespace skinspheres::skinning {
namespace {

TEST(PreparedInfluences, GroupsByCountKeepingOrderAndPairs) {
  const test::SyntheticMesh m = test::MakeSyntheticMesh(1000, 30, 0, 9, 17);
  PreparedInfluences p;
  std::string error;
  ASSERT_TRUE(p.Build(m.vertex_count, m.offsets, m.binds, m.weights, {}, &error)) << error;
  ASSERT_EQ(p.size(), m.vertex_count);
  uint32_t last_count = 0, slot = 0;
  std::vector<int> seen(m.vertex_count, 0);
  for (const PreparedInfluences::Group& g : p.groups()) {
    EXPECT_TRUE(slot == 0 || g.influence_count > last_count) << "groups ascend by count";
    EXPECT_EQ(g.first_slot, slot);
    last_count = g.influence_count;
    uint32_t prev_vertex = 0;
    for (uint32_t s = g.first_slot; s < g.first_slot + g.slot_count; ++s) {
      const uint32_t v = p.vertices()[s];
      EXPECT_TRUE(s == g.first_slot || v > prev_vertex) << "input order kept inside a group";
      prev_vertex = v;
      ++seen[v];
      ASSERT_EQ(m.offsets[v + 1] - m.offsets[v], g.influence_count);
      for (uint32_t k = 0; k < g.influence_count; ++k) {
        const size_t pair = g.first_influence + size_t{s - g.first_slot} * g.influence_count + k;
        EXPECT_EQ(p.matrix_offsets()[pair], 16u * m.binds[m.offsets[v] + k]);
        EXPECT_EQ(p.weights()[pair], m.weights[m.offsets[v] + k]);
      }
    }
    slot += g.slot_count;
  }
  for (int c : seen) EXPECT_EQ(c, 1);
  EXPECT_EQ(p.required_vertex_count(), m.vertex_count);
}

TEST(PreparedInfluences, SubsetSetsRequiredSizes) {
  const test::SyntheticMesh m = test::MakeSyntheticMesh(50, 30, 1, 3, 2);
  const std::vector<uint32_t> subset = {4, 9, 4};
  PreparedInfluences p;
  ASSERT_TRUE(p.Build(m.vertex_count, m.offsets, m.binds, m.weights, subset));
  EXPECT_EQ(p.size(), 3u);
  EXPECT_EQ(p.required_vertex_count(), 10u);
  uint32_t max_bind = 0;
  for (uint32_t v : subset)
    for (uint32_t k = m.offsets[v]; k < m.offsets[v + 1]; ++k) max_bind = std::max<uint32_t>(max_bind, m.binds[k]);
  EXPECT_EQ(p.required_matrix_count(), max_bind + 1u);
}

TEST(PreparedInfluences, RefusesInconsistentInput) {
  const test::SyntheticMesh m = test::MakeSyntheticMesh(50, 30, 1, 3, 2);
  PreparedInfluences p;
  std::string error;
  const std::vector<uint32_t> bad_subset = {3, 50};
  EXPECT_FALSE(p.Build(m.vertex_count, m.offsets, m.binds, m.weights, bad_subset, &error));
  EXPECT_NE(error.find("subset entry 1"), std::string::npos) << error;
  EXPECT_TRUE(p.empty());
  EXPECT_FALSE(p.Build(m.vertex_count + 1, m.offsets, m.binds, m.weights, {}, &error));
  EXPECT_NE(error.find("offsets"), std::string::npos) << error;
  std::vector<uint32_t> offsets = m.offsets;
  std::swap(offsets[3], offsets[4]);
  EXPECT_FALSE(p.Build(m.vertex_count, offsets, m.binds, m.weights, {}, &error));
  EXPECT_NE(error.find("vertex 3"), std::string::npos) << error;
  EXPECT_FALSE(p.Build(m.vertex_count, m.offsets, m.binds, std::span<const float>(m.weights).first(10), {}, &error));
}

}  // namespace
}  // namespace skinspheres::skinning
