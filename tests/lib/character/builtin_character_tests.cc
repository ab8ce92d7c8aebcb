// Tests for MakeBuiltinCharacter: mesh validity per piece, skeleton, skin, shape (elliptic torso),
// clips, and the touch clip's contacts checked with an independent FK + skinning oracle
// (clip_eval_for_tests.h) and ray-parity point-in-mesh tests on the posed mesh.
#include <gtest/gtest.h>

#include <map>
#include <set>

#include "skinspheres/lib/character/builtin_character.h"
#include "skinspheres/runtime/narrow_phase/triangle_contact.h"
#include "support/clip_eval_for_tests.h"
#include "test_support.h"

namespace skinspheres::lib {
namespace {

using Eigen::Vector3f;

const MeshRange& Piece(const RawCharacter& c, const std::string& name) {
  for (const auto& m : c.meshes) {
    if (m.name == name) return m;
  }
  ADD_FAILURE() << "no piece " << name;
  return c.meshes.front();
}

const skinning::AnimationClip* Clip(const RawCharacter& c, const std::string& name) {
  for (const auto& clip : c.clips) {
    if (clip.name == name) return &clip;
  }
  return nullptr;
}

// Möller–Trumbore; true when the ray o + t·d (t > 0) crosses the triangle.
bool RayHits(const Vector3f& o, const Vector3f& d, const Vector3f& a, const Vector3f& b, const Vector3f& c) {
  const Vector3f e1 = b - a, e2 = c - a, p = d.cross(e2);
  const float det = e1.dot(p);
  if (std::abs(det) < 1e-12f) return false;
  const float inv = 1.0f / det;
  const Vector3f s = o - a;
  const float u = s.dot(p) * inv;
  if (u < 0 || u > 1) return false;
  const Vector3f q = s.cross(e1);
  const float v = d.dot(q) * inv;
  if (v < 0 || u + v > 1) return false;
  return e2.dot(q) * inv > 0;
}

// Ray parity against one closed piece of the posed mesh.
bool InsidePiece(const RawCharacter& c, const std::vector<Vector3f>& pos, const MeshRange& m, const Vector3f& p) {
  const Vector3f dir = Vector3f(0.3713f, 0.5137f, 0.7731f).normalized();
  int hits = 0;
  for (uint32_t t = m.first_triangle; t < m.first_triangle + m.triangle_count; ++t) {
    const auto& tri = c.triangles[t];
    hits += RayHits(p, dir, pos[tri[0]], pos[tri[1]], pos[tri[2]]) ? 1 : 0;
  }
  return hits % 2 == 1;
}

// Vertices of `piece` whose largest weight is on `joint`.
std::vector<uint32_t> DominatedBy(const RawCharacter& c, const std::string& piece, const std::string& joint) {
  const int32_t j = c.skeleton.Find(joint);
  const MeshRange& m = Piece(c, piece);
  std::vector<uint32_t> out;
  for (uint32_t v = m.first_vertex; v < m.first_vertex + m.vertex_count; ++v) {
    float best = 0;
    int32_t best_joint = -1;
    for (uint32_t k = c.skin.influence_offsets[v]; k < c.skin.influence_offsets[v + 1]; ++k) {
      if (c.skin.influence_weights[k] > best) {
        best = c.skin.influence_weights[k];
        best_joint = c.skin.binds[c.skin.influence_binds[k]].joint;
      }
    }
    if (best_joint == j) out.push_back(v);
  }
  return out;
}

TEST(BuiltinCharacter, SkeletonHasMixamoNamesAndValidParents) {
  const RawCharacter& c = test::BuiltinCharacter();
  EXPECT_TRUE(c.skeleton.Validate());
  EXPECT_GE(c.skeleton.size(), 20u);
  for (const char* n : {"Hips",         "Spine",     "Spine1",      "Spine2",      "Neck",          "Head",
                        "LeftShoulder", "LeftArm",   "LeftForeArm", "LeftHand",    "RightShoulder", "RightArm",
                        "RightForeArm", "RightHand", "LeftUpLeg",   "LeftLeg",     "LeftFoot",      "LeftToeBase",
                        "RightUpLeg",   "RightLeg",  "RightFoot",   "RightToeBase"}) {
    EXPECT_GE(c.skeleton.Find(n), 0) << n;
  }
  std::set<std::string> unique(c.skeleton.joint_names.begin(), c.skeleton.joint_names.end());
  EXPECT_EQ(unique.size(), c.skeleton.size());
}

TEST(BuiltinCharacter, SizesAndRanges) {
  const RawCharacter& c = test::BuiltinCharacter();
  EXPECT_GE(c.triangle_count(), 3000u);
  EXPECT_LE(c.triangle_count(), 10000u);
  EXPECT_EQ(c.skin.vertex_count(), c.vertex_count());
  uint32_t v = 0, t = 0;
  for (const auto& m : c.meshes) {
    EXPECT_EQ(m.first_vertex, v);
    EXPECT_EQ(m.first_triangle, t);
    EXPECT_TRUE(m.skinned);
    v += m.vertex_count;
    t += m.triangle_count;
    for (uint32_t i = m.first_triangle; i < m.first_triangle + m.triangle_count; ++i) {
      for (int k = 0; k < 3; ++k) {
        EXPECT_GE(static_cast<uint32_t>(c.triangles[i][k]), m.first_vertex);
        EXPECT_LT(static_cast<uint32_t>(c.triangles[i][k]), m.first_vertex + m.vertex_count);
      }
    }
  }
  EXPECT_EQ(v, c.vertex_count());
  EXPECT_EQ(t, c.triangle_count());
  EXPECT_EQ(c.meshes.size(), 9u);
}

TEST(BuiltinCharacter, EveryPieceIsClosedOrientedAndOutward) {
  const RawCharacter& c = test::BuiltinCharacter();
  for (const auto& m : c.meshes) {
    // Every directed edge once and its reverse once: closed (2 triangles per edge), consistent.
    std::map<std::pair<int, int>, int> directed;
    double volume = 0;
    for (uint32_t i = m.first_triangle; i < m.first_triangle + m.triangle_count; ++i) {
      const auto& tri = c.triangles[i];
      for (int k = 0; k < 3; ++k) ++directed[{tri[k], tri[(k + 1) % 3]}];
      volume += c.positions_rest[tri[0]].cast<double>().dot(
                    c.positions_rest[tri[1]].cast<double>().cross(c.positions_rest[tri[2]].cast<double>())) /
                6.0;
    }
    for (const auto& [e, n] : directed) {
      ASSERT_EQ(n, 1) << m.name << " edge " << e.first << "-" << e.second;
      ASSERT_EQ(directed.count({e.second, e.first}), 1u) << m.name << " open edge " << e.first << "-" << e.second;
    }
    EXPECT_GT(volume, 0.0) << m.name << " is not outward";
  }
}

TEST(BuiltinCharacter, NoDegenerateTriangles) {
  const RawCharacter& c = test::BuiltinCharacter();
  for (const auto& tri : c.triangles) {
    const Vector3f& a = c.positions_rest[tri[0]];
    const float area = 0.5f * (c.positions_rest[tri[1]] - a).cross(c.positions_rest[tri[2]] - a).norm();
    EXPECT_GT(area, 1e-7f);
  }
}

TEST(BuiltinCharacter, WeightsNormalisedAtMostFourInfluences) {
  const RawCharacter& c = test::BuiltinCharacter();
  const auto& s = c.skin;
  ASSERT_EQ(s.influence_offsets.size(), s.vertex_count() + 1);
  size_t multi = 0;
  for (size_t v = 0; v < s.vertex_count(); ++v) {
    const uint32_t n = s.influence_offsets[v + 1] - s.influence_offsets[v];
    EXPECT_GE(n, 1u);
    EXPECT_LE(n, 4u);
    multi += n > 1 ? 1 : 0;
    float sum = 0;
    for (uint32_t k = s.influence_offsets[v]; k < s.influence_offsets[v + 1]; ++k) {
      EXPECT_GT(s.influence_weights[k], 0.0f);
      ASSERT_LT(s.influence_binds[k], s.binds.size());
      sum += s.influence_weights[k];
    }
    EXPECT_NEAR(sum, 1.0f, 1e-5f);
  }
  EXPECT_GT(multi, s.vertex_count() / 10) << "expected smooth blending near joints";
}

TEST(BuiltinCharacter, RestPositionsEqualLbsAtRestAndBindEqualsRest) {
  const RawCharacter& c = test::BuiltinCharacter();
  std::vector<skinspheres::Mat4f> rest(c.skeleton.size());
  c.skeleton.RestWorld(rest);
  const auto skinned = test::Skin(c, rest);
  for (size_t v = 0; v < c.vertex_count(); ++v) {
    EXPECT_LT((skinned[v] - c.positions_rest[v]).norm(), 1e-5f);
    EXPECT_LT((c.skin.positions_bind[v] - c.positions_rest[v]).norm(), 1e-5f);
  }
  for (const auto& b : c.skin.binds) {
    EXPECT_TRUE((rest[b.joint] * b.inverse_bind).isIdentity(1e-5f));
  }
}

TEST(BuiltinCharacter, HumanSizedYUpAndEllipticTorso) {
  const RawCharacter& c = test::BuiltinCharacter();
  Eigen::AlignedBox3f box;
  for (const auto& p : c.positions_rest) box.extend(p);
  EXPECT_NEAR(box.min().y(), 0.0f, 0.02f);
  EXPECT_GT(box.max().y(), 1.7f);
  EXPECT_LT(box.max().y(), 1.9f);
  // Torso section at chest height: width (X) / depth (Z) > 1.3.
  const MeshRange& torso = Piece(c, "TorsoMesh");
  Eigen::AlignedBox3f chest;
  for (uint32_t v = torso.first_vertex; v < torso.first_vertex + torso.vertex_count; ++v) {
    const Vector3f& p = c.positions_rest[v];
    if (p.y() > 1.30f && p.y() < 1.40f) chest.extend(p);
  }
  ASSERT_FALSE(chest.isEmpty());
  const float ratio = chest.sizes().x() / chest.sizes().z();
  EXPECT_GT(ratio, 1.3f);
  EXPECT_LT(ratio, 2.0f);
}

TEST(BuiltinCharacter, ArmsAreClearOfTheTorsoAtRest) {
  const RawCharacter& c = test::BuiltinCharacter();
  const MeshRange& torso = Piece(c, "TorsoMesh");
  for (const char* arm : {"LeftArmMesh", "RightArmMesh"}) {
    const MeshRange& a = Piece(c, arm);
    float best = 1e9f;
    for (uint32_t i = a.first_vertex; i < a.first_vertex + a.vertex_count; ++i) {
      for (uint32_t j = torso.first_vertex; j < torso.first_vertex + torso.vertex_count; ++j) {
        best = std::min(best, (c.positions_rest[i] - c.positions_rest[j]).norm());
      }
    }
    EXPECT_GT(best, 0.01f) << arm;
  }
}

TEST(BuiltinCharacter, ClipsAreWellFormed) {
  const RawCharacter& c = test::BuiltinCharacter();
  ASSERT_NE(Clip(c, "walk"), nullptr);
  ASSERT_NE(Clip(c, "touch"), nullptr);
  EXPECT_FLOAT_EQ(Clip(c, "walk")->duration_s, kWalkDuration_s);
  EXPECT_FLOAT_EQ(Clip(c, "touch")->duration_s, kTouchDuration_s);
  std::set<skinning::Interpolation> seen;
  for (const auto& clip : c.clips) {
    for (const auto& tr : clip.tracks) {
      ASSERT_GE(tr.joint, 0);
      ASSERT_LT(static_cast<size_t>(tr.joint), c.skeleton.size());
      auto check = [&](const auto& track) {
        if (track.empty()) return;
        seen.insert(track.interpolation);
        const size_t per = track.interpolation == skinning::Interpolation::kCubicSpline ? 3 : 1;
        EXPECT_EQ(track.values.size(), per * track.times_s.size());
        for (size_t k = 1; k < track.times_s.size(); ++k) EXPECT_LT(track.times_s[k - 1], track.times_s[k]);
        EXPECT_GE(track.times_s.front(), 0.0f);
        EXPECT_LE(track.times_s.back(), clip.duration_s + 1e-6f);
      };
      check(tr.translation);
      check(tr.rotation);
      check(tr.scale);
    }
  }
  EXPECT_TRUE(seen.count(skinning::Interpolation::kLinear));
  EXPECT_TRUE(seen.count(skinning::Interpolation::kStep));
  EXPECT_TRUE(seen.count(skinning::Interpolation::kCubicSpline));
}

TEST(BuiltinCharacter, WalkLoopsAndMovesLimbs) {
  const RawCharacter& c = test::BuiltinCharacter();
  const auto& walk = *Clip(c, "walk");
  const auto p0 = test::PoseAt(c, walk, 0.0f);
  const auto p1 = test::PoseAt(c, walk, kWalkDuration_s);
  for (size_t v = 0; v < p0.size(); ++v) ASSERT_LT((p0[v] - p1[v]).norm(), 1e-4f);
  // Left foot forward at 0.25 s, back at 0.75 s; left hand the other way.
  const auto a = test::WorldOf(c, test::SampleLocal(c, walk, 0.25f));
  const auto b = test::WorldOf(c, test::SampleLocal(c, walk, 0.75f));
  const int32_t foot = c.skeleton.Find("LeftFoot"), hand = c.skeleton.Find("LeftHand");
  EXPECT_GT(a[foot](2, 3) - b[foot](2, 3), 0.2f);
  EXPECT_LT(a[hand](2, 3) - b[hand](2, 3), -0.1f);
}

struct Contact {
  size_t inside = 0;
  float min_distance = 1e9f;
};

Contact HandAgainst(const RawCharacter& c, const std::vector<Vector3f>& pos, const std::string& arm,
                    const std::string& hand, const std::string& piece) {
  Contact out;
  const MeshRange& target = Piece(c, piece);
  for (uint32_t v : DominatedBy(c, arm, hand)) {
    if (InsidePiece(c, pos, target, pos[v])) ++out.inside;
    for (uint32_t w = target.first_vertex; w < target.first_vertex + target.vertex_count; ++w) {
      out.min_distance = std::min(out.min_distance, (pos[v] - pos[w]).norm());
    }
  }
  return out;
}

TEST(BuiltinCharacter, TouchClipHandsReachChestThenHead) {
  const RawCharacter& c = test::BuiltinCharacter();
  const auto& touch = *Clip(c, "touch");
  ASSERT_GT(DominatedBy(c, "LeftArmMesh", "LeftHand").size(), 20u);
  const auto rest = test::PoseAt(c, touch, 0.0f);
  for (const char* side : {"Left", "Right"}) {
    const std::string arm = std::string(side) + "ArmMesh", hand = std::string(side) + "Hand";
    for (const char* piece : {"TorsoMesh", "HeadMesh"}) {
      const Contact k = HandAgainst(c, rest, arm, hand, piece);
      EXPECT_EQ(k.inside, 0u) << side << " " << piece << " at rest";
      EXPECT_GT(k.min_distance, 0.3f) << side << " " << piece << " at rest";
    }
    for (int i = 0; i <= 4; ++i) {
      const float tc = kTouchChestBegin_s + (kTouchChestEnd_s - kTouchChestBegin_s) * static_cast<float>(i) / 4;
      const Contact chest = HandAgainst(c, test::PoseAt(c, touch, tc), arm, hand, "TorsoMesh");
      EXPECT_GE(chest.inside, 3u) << side << " hand not in the chest at t=" << tc;
      const float th = kTouchHeadBegin_s + (kTouchHeadEnd_s - kTouchHeadBegin_s) * static_cast<float>(i) / 4;
      const Contact head = HandAgainst(c, test::PoseAt(c, touch, th), arm, hand, "HeadMesh");
      EXPECT_GE(head.inside, 3u) << side << " hand not in the head at t=" << th;
      if (i == 2) {
        std::printf("[touch] %s hand: %zu vertices inside the chest at %.2f s, %zu inside the head at %.2f s\n", side,
                    chest.inside, tc, head.inside, th);
      }
    }
    // Back to rest at the end.
    const Contact end = HandAgainst(c, test::PoseAt(c, touch, kTouchDuration_s), arm, hand, "TorsoMesh");
    EXPECT_GT(end.min_distance, 0.3f);
  }
}

// Every pair of triangles of two different pieces that intersect (exact test) in `pos`, for the
// pieces that are apart at rest. Pieces joined at rest (neck in torso, head on neck, thighs in
// the hips, feet in the shins) are joints of the body, whose spheres the fitter excludes.
struct PieceHit {
  std::string a, b;
  uint32_t t, u;
};
std::vector<PieceHit> PieceIntersections(const RawCharacter& c, const std::vector<Vector3f>& pos) {
  std::vector<PieceHit> hits;
  auto box = [&](const std::vector<Vector3f>& p, uint32_t t) {
    Eigen::AlignedBox3f b;
    for (int k = 0; k < 3; ++k) b.extend(p[c.triangles[t][k]]);
    return b;
  };
  auto meet = [&](const std::vector<Vector3f>& p, uint32_t t, uint32_t u) {
    const auto& x = c.triangles[t];
    const auto& y = c.triangles[u];
    return runtime::TrianglesIntersect(p[x[0]], p[x[1]], p[x[2]], p[y[0]], p[y[1]], p[y[2]]);
  };
  auto each_pair = [&](const std::vector<Vector3f>& p, const MeshRange& a, const MeshRange& b, auto&& fn) {
    std::vector<Eigen::AlignedBox3f> boxes_b;
    for (uint32_t u = b.first_triangle; u < b.first_triangle + b.triangle_count; ++u) boxes_b.push_back(box(p, u));
    for (uint32_t t = a.first_triangle; t < a.first_triangle + a.triangle_count; ++t) {
      const Eigen::AlignedBox3f bt = box(p, t);
      for (uint32_t u = b.first_triangle; u < b.first_triangle + b.triangle_count; ++u) {
        if (bt.intersects(boxes_b[u - b.first_triangle]) && meet(p, t, u)) fn(t, u);
      }
    }
  };
  static std::set<std::pair<size_t, size_t>> joined;  // computed once: the character never changes
  static bool found = false;
  if (!found) {
    for (size_t m = 0; m < c.meshes.size(); ++m) {
      for (size_t n = m + 1; n < c.meshes.size(); ++n) {
        each_pair(c.positions_rest, c.meshes[m], c.meshes[n], [&](uint32_t, uint32_t) { joined.insert({m, n}); });
      }
    }
    found = true;
  }
  for (size_t m = 0; m < c.meshes.size(); ++m) {
    for (size_t n = m + 1; n < c.meshes.size(); ++n) {
      if (joined.count({m, n})) continue;
      each_pair(pos, c.meshes[m], c.meshes[n], [&](uint32_t t, uint32_t u) {
        hits.push_back({c.meshes[m].name, c.meshes[n].name, t, u});
      });
    }
  }
  return hits;
}

// The largest weight of triangle t's vertices is on `joint` for at least one vertex.
bool TouchesJoint(const RawCharacter& c, uint32_t t, const std::string& joint) {
  const int32_t j = c.skeleton.Find(joint);
  for (int k = 0; k < 3; ++k) {
    const int v = c.triangles[t][k];
    float best = 0;
    int32_t best_joint = -1;
    for (uint32_t i = c.skin.influence_offsets[v]; i < c.skin.influence_offsets[v + 1]; ++i) {
      if (c.skin.influence_weights[i] > best)
        best = c.skin.influence_weights[i], best_joint = c.skin.binds[c.skin.influence_binds[i]].joint;
    }
    if (best_joint == j) return true;
  }
  return false;
}

TEST(BuiltinCharacter, TheWalkTouchesNothing) {
  const RawCharacter& c = test::BuiltinCharacter();
  // The arms are among the pieces checked: apart at rest.
  ASSERT_TRUE(PieceIntersections(c, c.positions_rest).empty());
  const auto& walk = *Clip(c, "walk");
  for (int f = 0; f <= 30; ++f) {
    const float t = kWalkDuration_s * float(f) / 30.0f;
    const auto hits = PieceIntersections(c, test::PoseAt(c, walk, t));
    ASSERT_TRUE(hits.empty()) << "t=" << t << ": " << hits.size() << " intersecting pairs, first " << hits[0].a
                              << " triangle " << hits[0].t << " with " << hits[0].b << " triangle " << hits[0].u;
  }
}

TEST(BuiltinCharacter, TheTouchClipTouchesOnlyWithTheHands) {
  const RawCharacter& c = test::BuiltinCharacter();
  const auto& touch = *Clip(c, "touch");
  int chest_frames = 0, head_frames = 0;
  for (int f = 0; f <= 60; ++f) {  // 15 frames per second
    const float t = kTouchDuration_s * float(f) / 60.0f;
    const auto hits = PieceIntersections(c, test::PoseAt(c, touch, t));
    bool chest = false, head = false;
    for (const PieceHit& h : hits) {
      // Only an arm piece's hand against the torso or the head.
      const bool arm_first = h.a.find("ArmMesh") != std::string::npos;
      const std::string arm = arm_first ? h.a : h.b, other = arm_first ? h.b : h.a;
      const uint32_t arm_t = arm_first ? h.t : h.u;
      ASSERT_NE(arm.find("ArmMesh"), std::string::npos) << "t=" << t << ": " << h.a << " against " << h.b;
      const std::string hand = arm.substr(0, arm.find("ArmMesh")) + "Hand";
      ASSERT_TRUE(TouchesJoint(c, arm_t, hand))
          << "t=" << t << ": " << arm << " triangle " << arm_t << " is not the hand's";
      ASSERT_TRUE(other == "TorsoMesh" || other == "HeadMesh") << "t=" << t << ": hand against " << other;
      chest |= other == "TorsoMesh";
      head |= other == "HeadMesh";
      // Contacts stay near their windows (the hands arrive and leave within 0.1 s of them).
      const bool near_chest = t >= kTouchChestBegin_s - 0.1f && t <= kTouchChestEnd_s + 0.1f;
      const bool near_head = t >= kTouchHeadBegin_s - 0.1f && t <= kTouchHeadEnd_s + 0.1f;
      ASSERT_TRUE(other == "TorsoMesh" ? near_chest : near_head)
          << "t=" << t << ": hand on " << other << " outside its window";
    }
    const bool in_chest = t >= kTouchChestBegin_s && t <= kTouchChestEnd_s;
    const bool in_head = t >= kTouchHeadBegin_s && t <= kTouchHeadEnd_s;
    if (in_chest) {
      EXPECT_TRUE(chest) << "no hand on the chest at t=" << t;
    }
    if (in_head) {
      EXPECT_TRUE(head) << "no hand on the head at t=" << t;
    }
    chest_frames += chest;
    head_frames += head;
  }
  std::printf("[touch] hands on the chest in %d of 61 frames, on the head in %d\n", chest_frames, head_frames);
}

TEST(BuiltinCharacter, Deterministic) {
  const RawCharacter a = MakeBuiltinCharacter(), b = MakeBuiltinCharacter();
  ASSERT_EQ(a.positions_rest.size(), b.positions_rest.size());
  for (size_t v = 0; v < a.positions_rest.size(); ++v) EXPECT_EQ(a.positions_rest[v], b.positions_rest[v]);
  EXPECT_EQ(a.triangles, b.triangles);
}

}  // namespace
}  // namespace skinspheres::lib
