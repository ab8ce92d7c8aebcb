// The narrow phase (narrow_phase.h) on hand-made sets of closed sphere meshes, against analytic
// answers: the contact rules (contact_rules.h: shared vertex by index and by rest position, joints
// within the hops, near at rest within the rest gap), the same contacts from one sphere as from two,
// and the depth estimate on two meshes overlapping by known depths.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "narrow_phase/internal.h"
#include "runtime/narrow_phase/same_contacts.h"
#include "skinspheres/runtime/broad_phase/pair_filter.h"
#include "skinspheres/runtime/narrow_phase/narrow_phase.h"
#include "skinspheres/runtime/narrow_phase/triangle_contact.h"

namespace skinspheres::runtime {
namespace {

using Eigen::Vector3f;

// A hand-made set: joints root, a and b (a and b children of root: two bones apart), part "a" and
// part "b", one sphere per closed mesh, each mesh skinned wholly by its part's joint, no excluded
// pairs, the contact rules on triangles with a rest gap of 0; positions are given directly (mode a),
// so the rest pose and the tested pose can differ.
struct TwoMeshes {
  SphereSet set;
  std::vector<Vector3f> rest;  // = positions_bind (identity skin)
};

// A UV sphere: `rings` latitude rings, `segments` per ring, poles on the axis `pole`.
void AddUvSphere(const Vector3f& centre, float radius, const Vector3f& pole, int rings, int segments,
                 std::vector<Vector3f>* positions, std::vector<uint32_t>* triangles) {
  const Vector3f z = pole.normalized();
  const Vector3f x = (std::abs(z.x()) < 0.9f ? Vector3f::UnitX() : Vector3f::UnitY()).cross(z).normalized();
  const Vector3f y = z.cross(x);
  const uint32_t base = uint32_t(positions->size());
  positions->push_back(centre + radius * z);
  for (int r = 1; r < rings; ++r) {
    const float th = std::numbers::pi_v<float> * float(r) / float(rings);
    for (int s = 0; s < segments; ++s) {
      const float ph = 2.0f * std::numbers::pi_v<float> * float(s) / float(segments);
      positions->push_back(centre + radius * (std::sin(th) * (std::cos(ph) * x + std::sin(ph) * y) + std::cos(th) * z));
    }
  }
  positions->push_back(centre - radius * z);
  const uint32_t south = uint32_t(positions->size()) - 1;
  auto ring = [&](int r, int s) { return base + 1 + uint32_t((r - 1) * segments + (s % segments)); };
  for (int s = 0; s < segments; ++s) triangles->insert(triangles->end(), {base, ring(1, s), ring(1, s + 1)});
  for (int r = 1; r + 1 < rings; ++r) {
    for (int s = 0; s < segments; ++s) {
      triangles->insert(triangles->end(), {ring(r, s), ring(r + 1, s), ring(r + 1, s + 1)});
      triangles->insert(triangles->end(), {ring(r, s), ring(r + 1, s + 1), ring(r, s + 1)});
    }
  }
  for (int s = 0; s < segments; ++s)
    triangles->insert(triangles->end(), {south, ring(rings - 1, s + 1), ring(rings - 1, s)});
}

// Two sphere meshes at rest: A at the origin, B at distance `rest_gap` + ra + rb along X.
TwoMeshes MakeTwoSphereMeshes(float ra, float rb, float rest_distance, const Vector3f& pole_a, const Vector3f& pole_b,
                              int rings = 48, int segments = 96) {
  TwoMeshes m;
  std::vector<Vector3f> pos;
  std::vector<uint32_t> tris;
  AddUvSphere(Vector3f::Zero(), ra, pole_a, rings, segments, &pos, &tris);
  const uint32_t split_v = uint32_t(pos.size()), split_t = uint32_t(tris.size() / 3);
  AddUvSphere(Vector3f(rest_distance, 0, 0), rb, pole_b, rings, segments, &pos, &tris);
  SphereSet& s = m.set;
  s.source_file = "two_spheres";
  s.source_vertex_count = uint32_t(pos.size());
  s.source_triangle_count = uint32_t(tris.size() / 3);
  s.joint_names = {"root", "a", "b"};
  s.joint_parents = {-1, 0, 0};
  s.joint_rest_world = {Mat4f::Identity(), Mat4f::Identity(), Mat4f::Identity()};
  s.parts = {{"a", {1}}, {"b", {2}}};
  s.centers_rest = {Vector3f::Zero(), Vector3f(rest_distance, 0, 0)};
  s.radii_rest = {ra * 1.001f, rb * 1.001f};
  s.radii_fast = s.radii_rest;
  s.sphere_part = {0, 1};
  s.sphere_joint = {1, 2};
  s.sphere_level = {0, 0};
  s.vertex_offsets = {0, split_v, uint32_t(pos.size())};
  for (uint32_t v = 0; v < pos.size(); ++v) s.vertices.push_back(v);
  s.triangle_offsets = {0, split_t, uint32_t(tris.size() / 3)};
  for (uint32_t t = 0; t < tris.size() / 3; ++t) s.triangles.push_back(t);
  s.influence_offsets = {0, 1, 2};
  s.influence_joints = {1, 2};
  s.influence_weights = {1.0f, 1.0f};
  s.triangle_vertices = tris;
  s.mesh.positions_bind = pos;
  s.mesh.binds = {skinning::BindEntry{1, Mat4f::Identity()}, skinning::BindEntry{2, Mat4f::Identity()}};
  for (uint32_t v = 0; v <= pos.size(); ++v) s.mesh.influence_offsets.push_back(v);
  for (uint32_t v = 0; v < pos.size(); ++v) s.mesh.influence_binds.push_back(v < split_v ? 0 : 1);
  s.mesh.influence_weights.assign(pos.size(), 1.0f);
  m.rest = pos;
  return m;
}

// Runs the job on positions with B moved by `shift`; spheres are the meshes' bounding spheres.
FrameContacts RunShifted(const TwoMeshes& m, const NarrowPhaseData& data, const Vector3f& shift, float ra, float rb) {
  std::vector<Vector3f> pos = m.rest;
  for (uint32_t v = m.set.vertex_offsets[1]; v < m.set.vertex_offsets[2]; ++v) pos[v] += shift;
  const Vector3f cb = m.set.centers_rest[1] + shift;
  const std::vector<Vec4f> spheres = {Vec4f(0, 0, 0, ra * 1.001f), Vec4f(cb.x(), cb.y(), cb.z(), rb * 1.001f)};
  const std::vector<SpherePair> pairs = {SpherePair{0, 1, 0.0f, 0, 1}};
  NarrowPhaseContext ctx;
  ctx.Resize(data, false);
  FrameContacts out;
  NarrowPhaseJob job{&m.set, &data, spheres, pairs, pos, {}, &ctx, &out};
  EXPECT_TRUE(job.Run());
  return out;
}

TEST(NarrowPhaseDepth, TwoSphereMeshesOverlappingByAKnownDepth) {
  struct Case {
    float ra, rb;
    Vector3f pole_a, pole_b;
    const char* label;
  };
  const Case cases[] = {
      {1.0f, 1.0f, Vector3f::UnitX(), Vector3f::UnitX(), "equal radii, poles on the axis"},
      {1.0f, 0.5f, Vector3f::UnitX(), Vector3f::UnitX(), "radii 1 and 0.5, poles on the axis"},
      {0.8f, 1.2f, Vector3f(0.3f, 1, 0.2f), Vector3f(1, -0.4f, 0.7f), "radii 0.8 and 1.2, tilted tessellations"},
  };
  for (const Case& c : cases) {
    const float rest_distance = c.ra + c.rb + 0.5f;  // apart at rest
    const TwoMeshes m = MakeTwoSphereMeshes(c.ra, c.rb, rest_distance, c.pole_a, c.pole_b);
    auto filter = PairFilter::FromSphereSet(m.set);
    ASSERT_TRUE(filter.ok());
    auto data = NarrowPhaseData::Create(m.set, *filter);
    ASSERT_TRUE(data.ok()) << data.error().message;
    for (float fraction : {0.05f, 0.2f, 0.5f}) {
      const float depth = fraction * std::min(c.ra, c.rb);
      const float distance = c.ra + c.rb - depth;
      const FrameContacts out = RunShifted(m, *data, Vector3f(distance - rest_distance, 0, 0), c.ra, c.rb);
      ASSERT_EQ(out.parts.size(), 1u) << c.label;
      const PartContact& pc = out.parts[0];
      EXPECT_EQ(pc.part_a, 0);
      EXPECT_EQ(pc.part_b, 1);
      EXPECT_GT(pc.intersecting_count, 20u);
      // Tessellation: a chord of a 96-segment ring sits r (1 - cos(pi/96)) = 0.05% of r inside the
      // sphere; near the rim the polygonal contour is a little off the circle as well.
      EXPECT_NEAR(pc.depth, depth, 0.02f * depth + 0.002f * std::max(c.ra, c.rb)) << c.label << " depth " << depth;
      // The normal points from B (part b) to A (part a): -X.
      EXPECT_NEAR(pc.normal[0], -1.0f, 1e-3f) << c.label;
      // The contour plane: x = (d^2 + ra^2 - rb^2) / 2d.
      const float plane = (distance * distance + c.ra * c.ra - c.rb * c.rb) / (2 * distance);
      EXPECT_NEAR(pc.center[0], plane, 0.01f * depth + 0.002f) << c.label;
      std::printf("[depth] %s: overlap %.4f, estimate %.4f (%zu triangle pairs)\n", c.label, depth, pc.depth,
                  size_t(pc.triangle_pair_count));
    }
  }
}

// Touching or penetrating: two unit spheres overlapping by 0.05 and by 0.3, with the tolerance at
// 5% of the rest height (about 0.1: the spheres' extent along +Y, computed here from the mesh).
TEST(NarrowPhaseDepth, TouchingUpToTheToleranceThenPenetrating) {
  const TwoMeshes m = MakeTwoSphereMeshes(1.0f, 1.0f, 2.5f, Vector3f::UnitX(), Vector3f::UnitX());
  float low = m.rest[0].y(), high = low;
  for (const Vector3f& p : m.rest) {
    low = std::min(low, p.y());
    high = std::max(high, p.y());
  }
  const float height = high - low;
  ASSERT_GT(height, 1.9f);
  auto filter = PairFilter::FromSphereSet(m.set);
  ASSERT_TRUE(filter.ok());
  NarrowPhaseSettings settings;
  settings.touch_tolerance_share = 0.05f;
  auto data = NarrowPhaseData::Create(m.set, *filter, settings);
  ASSERT_TRUE(data.ok()) << data.error().message;
  EXPECT_EQ(data->rest_height(), height);
  EXPECT_EQ(data->touch_tolerance(), 0.05f * height);
  for (const auto& [overlap, kind] :
       {std::pair{0.05f, PartContactKind::kTouching}, std::pair{0.3f, PartContactKind::kPenetrating}}) {
    const FrameContacts out = RunShifted(m, *data, Vector3f(2.0f - overlap - 2.5f, 0, 0), 1.0f, 1.0f);
    ASSERT_EQ(out.parts.size(), 1u);
    EXPECT_EQ(out.parts[0].kind, kind) << "overlap " << overlap << ", depth " << out.parts[0].depth << ", tolerance "
                                       << data->touch_tolerance() << ": " << ToString(out.parts[0].kind);
  }
  // The default: 0.5% of the height, so the 0.05 overlap penetrates.
  auto by_default = NarrowPhaseData::Create(m.set, *filter);
  ASSERT_TRUE(by_default.ok());
  EXPECT_EQ(by_default->touch_tolerance(), kDefaultTouchToleranceShare * height);
  EXPECT_EQ(RunShifted(m, *by_default, Vector3f(-0.55f, 0, 0), 1.0f, 1.0f).parts.at(0).kind,
            PartContactKind::kPenetrating);
  // Apart but within a margin: touching, whatever the tolerance.
  NarrowPhaseSettings margin;
  margin.margin = 0.05f;
  margin.touch_tolerance_share = 0.0f;
  auto with_margin = NarrowPhaseData::Create(m.set, *filter, margin);
  ASSERT_TRUE(with_margin.ok()) << with_margin.error().message;
  const FrameContacts near = RunShifted(m, *with_margin, Vector3f(-0.48f, 0, 0), 1.0f, 1.0f);
  ASSERT_EQ(near.parts.size(), 1u);
  EXPECT_EQ(near.parts[0].intersecting_count, 0u);
  EXPECT_EQ(near.parts[0].kind, PartContactKind::kTouching);
  for (float bad : {-0.01f, 1.0f, std::numeric_limits<float>::quiet_NaN()}) {
    NarrowPhaseSettings refused;
    refused.touch_tolerance_share = bad;
    auto r = NarrowPhaseData::Create(m.set, *filter, refused);
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_EQ(r.error().code, ErrorCode::kInvalidArgument);
    EXPECT_NE(r.error().message.find("touch tolerance"), std::string::npos) << r.error().message;
  }
  EXPECT_STREQ(ToString(PartContactKind::kTouching), "touching");
  EXPECT_STREQ(ToString(PartContactKind::kPenetrating), "penetrating");
}

TEST(NarrowPhaseRules, RestContactsAndSharedVerticesAreNeverReported) {
  // Overlapping at rest by 0.3: every pair that intersects at rest is excluded; pushing B further
  // in reports only pairs that did not intersect at rest.
  const TwoMeshes m = MakeTwoSphereMeshes(1.0f, 1.0f, 1.7f, Vector3f::UnitY(), Vector3f::UnitY(), 24, 48);
  auto filter = PairFilter::FromSphereSet(m.set);
  ASSERT_TRUE(filter.ok());
  auto data = NarrowPhaseData::Create(m.set, *filter);
  ASSERT_TRUE(data.ok());
  // Rule 3 holds exactly the pairs that intersect at rest (a rest gap of 0, no margin).
  size_t crossing_at_rest = 0;
  const uint32_t split = m.set.triangle_offsets[1];
  for (uint32_t t = 0; t < split; ++t) {
    for (uint32_t u = split; u < m.set.source_triangle_count; ++u) {
      const uint32_t* a = &m.set.triangle_vertices[3 * t];
      const uint32_t* b = &m.set.triangle_vertices[3 * u];
      const bool crossing =
          TrianglesIntersect(m.rest[a[0]], m.rest[a[1]], m.rest[a[2]], m.rest[b[0]], m.rest[b[1]], m.rest[b[2]]);
      crossing_at_rest += crossing;
      ASSERT_EQ(data->RestExcluded(t, u), crossing) << t << " " << u;
    }
  }
  EXPECT_GT(crossing_at_rest, 20u);
  EXPECT_TRUE(RunShifted(m, *data, Vector3f::Zero(), 1.0f, 1.0f).empty()) << "the rest pose reports nothing";
  const FrameContacts deeper = RunShifted(m, *data, Vector3f(-0.2f, 0, 0), 1.0f, 1.0f);
  ASSERT_EQ(deeper.parts.size(), 1u);
  for (const auto& c : deeper.triangle_pairs) {
    EXPECT_FALSE(data->RestExcluded(c.triangle_a, c.triangle_b));
    EXPECT_FALSE(TrianglesIntersect(
        m.rest[m.set.triangle_vertices[3 * c.triangle_a]], m.rest[m.set.triangle_vertices[3 * c.triangle_a + 1]],
        m.rest[m.set.triangle_vertices[3 * c.triangle_a + 2]], m.rest[m.set.triangle_vertices[3 * c.triangle_b]],
        m.rest[m.set.triangle_vertices[3 * c.triangle_b + 1]], m.rest[m.set.triangle_vertices[3 * c.triangle_b + 2]]));
  }
  // The oracle agrees.
  FrameContacts oracle;
  std::vector<Vector3f> pos = m.rest;
  for (uint32_t v = m.set.vertex_offsets[1]; v < m.set.vertex_offsets[2]; ++v) pos[v].x() -= 0.2f;
  ASSERT_TRUE(FindContactsBruteForce(m.set, *data, *filter, pos, &oracle));
  EXPECT_SAME_CONTACTS(deeper, oracle, "deeper");
}

TEST(NarrowPhaseRules, VerticesWeldedByRestPosition) {
  // Two triangles that share a corner by rest POSITION only (vertex 2 and vertex 3 coincide), in
  // spheres 0 and 1 of different parts: crossing each other, they are still never reported; moved
  // apart from the weld they are.
  SphereSet s;
  s.source_file = "weld";
  s.source_vertex_count = 6;
  s.source_triangle_count = 2;
  s.joint_names = {"root", "a", "b"};
  s.joint_parents = {-1, 0, 0};
  s.joint_rest_world = {Mat4f::Identity(), Mat4f::Identity(), Mat4f::Identity()};
  s.parts = {{"a", {1}}, {"b", {2}}};
  s.centers_rest = {Vector3f(0.5f, 0.3f, 0), Vector3f(0.5f, 0.3f, 0)};
  s.radii_rest = {2, 2};
  s.radii_fast = {2, 2};
  s.sphere_part = {0, 1};
  s.sphere_joint = {1, 2};
  s.sphere_level = {0, 0};
  s.vertex_offsets = {0, 3, 6};
  s.vertices = {0, 1, 2, 3, 4, 5};
  s.triangle_offsets = {0, 1, 2};
  s.triangles = {0, 1};
  s.influence_offsets = {0, 1, 2};
  s.influence_joints = {1, 2};
  s.influence_weights = {1, 1};
  s.triangle_vertices = {0, 1, 2, 3, 4, 5};
  // Triangle 0 in z = 0; triangle 1 stands up through it and has its corner 3 at vertex 2's spot.
  s.mesh.positions_bind = {Vector3f(0, 0, 0), Vector3f(1, 0, 0),       Vector3f(0, 1, 0),
                           Vector3f(0, 1, 0), Vector3f(0.3f, 0.2f, 1), Vector3f(0.3f, 0.2f, -1)};
  s.mesh.binds = {skinning::BindEntry{1, Mat4f::Identity()}, skinning::BindEntry{2, Mat4f::Identity()}};
  s.mesh.influence_offsets = {0, 1, 2, 3, 4, 5, 6};
  s.mesh.influence_binds = {0, 0, 0, 1, 1, 1};
  s.mesh.influence_weights.assign(6, 1.0f);
  ASSERT_FALSE(s.Validate().has_value()) << s.Validate()->message;
  auto filter = PairFilter::FromSphereSet(s);
  ASSERT_TRUE(filter.ok());
  auto data = NarrowPhaseData::Create(s, *filter);
  ASSERT_TRUE(data.ok()) << data.error().message;
  EXPECT_TRUE(data->ShareVertex(0, 1));
  std::vector<Vector3f> pos = s.mesh.positions_bind;
  FrameContacts out;
  ASSERT_TRUE(FindContactsBruteForce(s, *data, *filter, pos, &out));
  EXPECT_TRUE(out.empty());
  // The same two triangles when the second one's corner is a vertex of its own rest position.
  SphereSet apart = s;
  apart.mesh.positions_bind[3] = Vector3f(-0.5f, 1.5f, 0);
  auto data2 = NarrowPhaseData::Create(apart, *filter);
  ASSERT_TRUE(data2.ok());
  EXPECT_FALSE(data2->ShareVertex(0, 1));
  ASSERT_TRUE(FindContactsBruteForce(apart, *data2, *filter, apart.mesh.positions_bind, &out));
  EXPECT_TRUE(out.empty()) << "they cross at rest: rule 3";
  EXPECT_TRUE(data2->RestExcluded(0, 1));
}

}  // namespace
}  // namespace skinspheres::runtime

namespace skinspheres::runtime {
namespace {

// The triangle pairs of a frame, as (t, u) with t < u.
std::vector<std::pair<uint32_t, uint32_t>> TrianglePairs(const FrameContacts& out) {
  std::vector<std::pair<uint32_t, uint32_t>> pairs;
  for (const TriangleContact& c : out.triangle_pairs)
    pairs.push_back({std::min(c.triangle_a, c.triangle_b), std::max(c.triangle_a, c.triangle_b)});
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}

// Rule 2: with b hung under a (one bone apart) the two meshes are never in contact at hops 1, and are
// at hops 0; siblings (two bones apart) are at hops 1 and not at hops 2.
TEST(NarrowPhaseRules, JointsWithinTheHopsAreNeverContacts) {
  struct Case {
    int32_t parent_of_b;
    uint32_t hops;
    bool contacts;
  };
  for (const Case c : {Case{1, 1, false}, Case{1, 0, true}, Case{0, 1, true}, Case{0, 2, false}}) {
    TwoMeshes m = MakeTwoSphereMeshes(1.0f, 1.0f, 2.5f, Vector3f::UnitY(), Vector3f::UnitY(), 16, 32);
    m.set.joint_parents[2] = c.parent_of_b;
    // The root a bind entry too (weighing nothing), so that siblings meet in the skin's joint tree.
    m.set.mesh.binds.push_back(skinning::BindEntry{0, Mat4f::Identity()});
    ASSERT_EQ(WriteContactRules(&m.set, c.hops, 0.0f), std::nullopt);
    EXPECT_EQ(m.set.excluded_pairs.size(), c.contacts ? 0u : 1u) << "the sphere pair goes whole with its joints";
    auto filter = PairFilter::FromSphereSet(m.set);
    ASSERT_TRUE(filter.ok());
    auto data = NarrowPhaseData::Create(m.set, *filter);
    ASSERT_TRUE(data.ok()) << data.error().message;
    const FrameContacts out = RunShifted(m, *data, Vector3f(-0.8f, 0, 0), 1.0f, 1.0f);
    EXPECT_EQ(out.empty(), !c.contacts) << "b under " << c.parent_of_b << ", hops " << c.hops;
    std::vector<Vector3f> pos = m.rest;
    for (uint32_t v = m.set.vertex_offsets[1]; v < m.set.vertex_offsets[2]; ++v) pos[v].x() -= 0.8f;
    FrameContacts oracle;
    ASSERT_TRUE(FindContactsBruteForce(m.set, *data, *filter, pos, &oracle));
    EXPECT_SAME_CONTACTS(out, oracle, "hops " << c.hops);
  }
}

// Rule 3: two meshes 0.05 apart at rest, pushed 0.12 into each other. With a rest gap of 0.1 (5% of
// the rest height, the most a set may state) the pairs that lay within it at rest (around the facing
// caps) are never contacts; every pair reported lay at least 0.1 apart, and they are the pairs a gap
// of 0 reports less those.
TEST(NarrowPhaseRules, PairsNearerThanTheRestGapAtRestAreNeverContacts) {
  TwoMeshes m = MakeTwoSphereMeshes(1.0f, 1.0f, 2.05f, Vector3f::UnitY(), Vector3f::UnitY(), 24, 48);
  std::vector<std::pair<uint32_t, uint32_t>> all, gapped;
  for (const float gap : {0.0f, 0.1f}) {
    m.set.rest_gap = gap;
    ASSERT_EQ(m.set.Validate(), std::nullopt);
    auto filter = PairFilter::FromSphereSet(m.set);
    ASSERT_TRUE(filter.ok());
    auto data = NarrowPhaseData::Create(m.set, *filter);
    ASSERT_TRUE(data.ok()) << data.error().message;
    EXPECT_EQ(data->rest_distance(), gap);
    (gap == 0.0f ? all : gapped) = TrianglePairs(RunShifted(m, *data, Vector3f(-0.12f, 0, 0), 1.0f, 1.0f));
  }
  std::printf("[rest gap] %zu pairs with a gap of 0, %zu with 0.1\n", all.size(), gapped.size());
  ASSERT_GT(gapped.size(), 10u);
  size_t left_out = 0;
  for (const auto& [t, u] : all) {
    const uint32_t* a = &m.set.triangle_vertices[3 * t];
    const uint32_t* b = &m.set.triangle_vertices[3 * u];
    const float rest =
        TriangleDistance(m.rest[a[0]], m.rest[a[1]], m.rest[a[2]], m.rest[b[0]], m.rest[b[1]], m.rest[b[2]]);
    const bool kept = std::binary_search(gapped.begin(), gapped.end(), std::pair{t, u});
    EXPECT_EQ(kept, rest >= 0.1f) << t << " " << u << " lay " << rest << " apart at rest";
    left_out += !kept;
  }
  EXPECT_GT(left_out, 10u);
  EXPECT_EQ(all.size(), gapped.size() + left_out);
}

// The rules do not know the spheres: one sphere owning both meshes (tested against itself) reports the
// same triangle pairs as a sphere per mesh, and both equal the oracle.
TEST(NarrowPhaseRules, OneSphereReportsWhatTwoDo) {
  const TwoMeshes two = MakeTwoSphereMeshes(1.0f, 1.0f, 2.5f, Vector3f::UnitX(), Vector3f(0.2f, 1, 0), 16, 32);
  TwoMeshes one = two;
  SphereSet& s = one.set;
  s.centers_rest = {Vector3f(1.25f, 0, 0)};
  s.radii_rest = {2.3f};
  s.radii_fast = s.radii_rest;
  s.sphere_part = {0};
  s.sphere_joint = {1};
  s.sphere_level = {0};
  s.vertex_offsets = {0, s.source_vertex_count};
  s.triangle_offsets = {0, s.source_triangle_count};
  s.influence_offsets = {0, 2};
  s.influence_joints = {1, 2};
  s.influence_weights = {0.5f, 0.5f};
  ASSERT_EQ(WriteContactRules(&s, 1, 0.0f), std::nullopt);
  ASSERT_EQ(s.Validate(), std::nullopt) << s.Validate()->message;
  for (const float push : {0.7f, 1.1f}) {
    std::vector<Vector3f> pos = two.rest;
    for (uint32_t v = two.set.vertex_offsets[1]; v < two.set.vertex_offsets[2]; ++v) pos[v].x() -= push;
    FrameContacts from_two, from_one, oracle;
    {
      auto filter = PairFilter::FromSphereSet(two.set);
      auto data = NarrowPhaseData::Create(two.set, *filter);
      ASSERT_TRUE(data.ok());
      from_two = RunShifted(two, *data, Vector3f(-push, 0, 0), 1.0f, 1.0f);
    }
    auto filter = PairFilter::FromSphereSet(s);
    auto data = NarrowPhaseData::Create(s, *filter);
    ASSERT_TRUE(data.ok()) << data.error().message;
    EXPECT_EQ(narrow_phase::Access::Of(*data).self_spheres.size(), 1u);
    NarrowPhaseContext ctx;
    ctx.Resize(*data, false);
    const std::vector<Vec4f> spheres = {Vec4f(1.25f - 0.5f * push, 0, 0, 2.3f)};
    NarrowPhaseJob job{&s, &*data, spheres, {}, pos, {}, &ctx, &from_one};
    ASSERT_TRUE(job.Run());
    ASSERT_TRUE(FindContactsBruteForce(s, *data, *filter, pos, &oracle));
    EXPECT_SAME_CONTACTS(from_one, oracle, "one sphere, push " << push);
    EXPECT_FALSE(from_one.empty());
    EXPECT_EQ(TrianglePairs(from_one), TrianglePairs(from_two)) << "push " << push;
    ASSERT_EQ(from_one.sphere_pairs.size(), 1u);
    EXPECT_EQ(from_one.sphere_pairs[0].i, 0u);
    EXPECT_EQ(from_one.sphere_pairs[0].j, 0u);
  }
}

}  // namespace
}  // namespace skinspheres::runtime
