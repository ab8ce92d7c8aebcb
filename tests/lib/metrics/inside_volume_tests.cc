// Tests of inside_volume.h against analytic oracles: closed sphere and box meshes (exact volumes by
// the divergence theorem), a unit cube whose shared edges pass through voxel centres, an open box,
// overlapping and nested pieces (one of them inside-out).
#include <gtest/gtest.h>

#include <numbers>

#include "shapes/box_mesh.h"
#include "shapes/uv_sphere.h"
#include "skinspheres/lib/metrics/inside_volume.h"

namespace skinspheres::lib {
namespace {

using Mesh = test::TriangleMesh;
using test::BoxMesh;

// UV sphere, outward-facing, closed (poles shared, on the Y axis).
Mesh SphereMesh(const Eigen::Vector3f& c, float r, int rings = 64, int segments = 128) {
  return test::UvSphere(c, r, rings, segments, /*pole_axis=*/1);
}

double SphereVolume(double r) { return 4.0 / 3.0 * std::numbers::pi * r * r * r; }

TEST(InsideVolume, BoxMeshIsOutwardAndClosed) {  // guards the oracle itself
  EXPECT_NEAR(BoxMesh({0, 0, 0}, {1, 2, 3}).SignedVolume(), 6.0, 1e-9);
  EXPECT_NEAR(SphereMesh({0, 0, 0}, 1).SignedVolume(), SphereVolume(1), 0.01 * SphereVolume(1));
}

TEST(InsideVolume, ClosedSphereVolume) {
  const Mesh m = SphereMesh({0.3f, 1.f, -0.2f}, 0.7f);
  const auto v = MeshInsideVolume(m.positions, m.triangles, 128);
  ASSERT_TRUE(v.ok()) << v.error().message;
  EXPECT_NEAR(*v, m.SignedVolume(), 0.005 * m.SignedVolume());
  EXPECT_NEAR(*v, SphereVolume(0.7), 0.01 * SphereVolume(0.7));
  // Orientation does not matter (parity).
  Mesh flipped = m;
  flipped.Flip();
  const auto vf = MeshInsideVolume(flipped.positions, flipped.triangles, 128);
  ASSERT_TRUE(vf.ok());
  EXPECT_EQ(*vf, *v);
}

TEST(InsideVolume, BoxVolume) {
  const Mesh m = BoxMesh({-0.5f, 0.f, 0.25f}, {0.5f, 2.f, 1.75f});
  const auto v = MeshInsideVolume(m.positions, m.triangles, 128);
  ASSERT_TRUE(v.ok());
  EXPECT_NEAR(*v, 3.0, 0.02 * 3.0);
}

TEST(InsideVolume, UnitCubeIsExactEvenWhereColumnsHitSharedEdges) {
  // Grid: h = 1/64, voxel centres at (i - 0.5)·h: exactly 64³ of them inside the cube, and every
  // face diagonal (an edge shared by two triangles) passes through 64 column centres, the case of
  // the top-left tie rule. (The 6-ray vote would even survive a double-counted edge: such a
  // column misleads one ray of an outside voxel, and the winding number keeps inside voxels.)
  Mesh m = BoxMesh({0, 0, 0}, {1, 1, 1});
  auto v = MeshInsideVolume(m.positions, m.triangles, 64);
  ASSERT_TRUE(v.ok());
  EXPECT_EQ(*v, 1.0);
  m.Flip();
  v = MeshInsideVolume(m.positions, m.triangles, 64);
  ASSERT_TRUE(v.ok());
  EXPECT_EQ(*v, 1.0);
  // A cube split the other way (q1, q2, q3 / q1, q3, q0 per face).
  Mesh other = BoxMesh({0, 0, 0}, {1, 1, 1});
  for (size_t f = 0; f + 1 < other.triangles.size(); f += 2) {
    const Eigen::Vector3i a = other.triangles[f], b = other.triangles[f + 1];  // (q0,q1,q2), (q0,q2,q3)
    other.triangles[f] = Eigen::Vector3i(a[1], a[2], b[2]);
    other.triangles[f + 1] = Eigen::Vector3i(a[1], b[2], a[0]);
  }
  EXPECT_NEAR(other.SignedVolume(), 1.0, 1e-9);
  v = MeshInsideVolume(other.positions, other.triangles, 64);
  ASSERT_TRUE(v.ok());
  EXPECT_EQ(*v, 1.0);
}

TEST(InsideVolume, OpenBoxStillHasItsVolume) {
  for (int face = 0; face < 6; ++face) {
    const Mesh m = BoxMesh({0, 0, 0}, {1, 2, 3}, face);
    ASSERT_EQ(m.triangles.size(), 10u);
    const auto v = MeshInsideVolume(m.positions, m.triangles, 128);
    ASSERT_TRUE(v.ok());
    EXPECT_NEAR(*v, 6.0, 0.03 * 6.0) << "missing face " << face;
  }
}

TEST(InsideVolume, OverlappingAndNestedPiecesCountAsTheirUnion) {
  // Two overlapping closed boxes: union = 2 + 2 - 0.5·... compute: [0,2]x[0,1]x[0,1] ∪ [1,3]x[0.5,1.5]x[0,1]
  Mesh m = BoxMesh({0, 0, 0}, {2, 1, 1});
  m.Append(BoxMesh({1, 0.5f, 0}, {3, 1.5f, 1}));
  const double union_volume = 2.0 + 2.0 - 1.0 * 0.5 * 1.0;
  auto v = MeshInsideVolume(m.positions, m.triangles, 128);
  ASSERT_TRUE(v.ok());
  EXPECT_NEAR(*v, union_volume, 0.02 * union_volume);
  // A closed piece inside another (Xbot's joints mesh inside its surface): parity alone says
  // "outside" there, the winding number says 2.
  Mesh nested = SphereMesh({0, 0, 0}, 1.f, 32, 64);
  nested.Append(SphereMesh({0.2f, 0, 0}, 0.5f, 32, 64));
  v = MeshInsideVolume(nested.positions, nested.triangles, 128);
  ASSERT_TRUE(v.ok());
  const double outer = SphereMesh({0, 0, 0}, 1.f, 32, 64).SignedVolume();
  EXPECT_NEAR(*v, outer, 0.01 * outer);
  // The same with the inner piece inside-out: parity is even and the raw winding number would be
  // 1 - 1 = 0 there; each piece's orientation is normalised first.
  Mesh inner = SphereMesh({0.2f, 0, 0}, 0.5f, 32, 64);
  inner.Flip();
  Mesh nested_flipped = SphereMesh({0, 0, 0}, 1.f, 32, 64);
  nested_flipped.Append(inner);
  const auto vf = MeshInsideVolume(nested_flipped.positions, nested_flipped.triangles, 128);
  ASSERT_TRUE(vf.ok());
  EXPECT_EQ(*vf, *v);
}

}  // namespace
}  // namespace skinspheres::lib
