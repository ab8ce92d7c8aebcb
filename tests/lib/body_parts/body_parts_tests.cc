// Tests for SplitBodyParts / LoadPartOverrides (lib/body_parts/body_parts.h).
//
// Synthetic characters first: a humanoid built from boxes around its bones, with joints stored in
// a shuffled (parents-first) order under meaningless names, so only topology and geometry can
// decide; mirrored, turned around, with IK feet under the root, with feet that give no facing
// (names must break the tie); a snake and a spider that are not humanoid. A brute-force dominant
// joint per triangle is the oracle for the triangle assignment. Then the shared characters.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <set>

#include "skinspheres/lib/body_parts/body_parts.h"
#include "skinspheres/lib/io/importer.h"
#include "test_support.h"

namespace skinspheres::lib {
namespace {

using Eigen::Vector3f;

// A joint of the model before shuffling: role name, parent role index, model-space position,
// whether it carries skin (a box from it to `tip`).
struct ModelJoint {
  std::string role;
  int parent = -1;
  Vector3f pos;
  bool weighted = true;
  int tip = -1;  // box from pos to joints[tip].pos (model order), -1: no box
};

struct Model {
  std::vector<ModelJoint> joints;
  int Add(const std::string& role, int parent, Vector3f pos, bool weighted = true) {
    joints.push_back({role, parent, pos, weighted, -1});
    return static_cast<int>(joints.size()) - 1;
  }
  int Find(const std::string& role) const {
    for (size_t i = 0; i < joints.size(); ++i) {
      if (joints[i].role == role) return static_cast<int>(i);
    }
    return -1;
  }
};

struct HumanoidOptions {
  bool feet_forward = true;  // feet boxes reach forward (+Z in model space) from the ankles
  bool ik_feet = false;      // feet hang under the root, not under the shins (RobotExpressive)
};

// Y up, facing +Z, the character's left on +X. Roles ending in _l are on +X.
Model MakeHumanoid(const HumanoidOptions& opt = {}) {
  Model m;
  const int root = m.Add("armature", -1, {0, 0, 0}, false);
  const int hips = m.Add("hips", root, {0, 1.0f, 0});
  const int spine = m.Add("spine", hips, {0, 1.2f, 0});
  const int chest = m.Add("chest", spine, {0, 1.4f, 0});
  const int neck = m.Add("neck", chest, {0, 1.55f, 0});
  const int head = m.Add("head", neck, {0, 1.65f, 0});
  m.Add("head_end", head, {0, 1.9f, 0}, false);
  for (int side = 0; side < 2; ++side) {
    const float s = side == 0 ? 1.0f : -1.0f;
    const std::string x = side == 0 ? "_l" : "_r";
    const int clav = m.Add("clavicle" + x, chest, {s * 0.05f, 1.5f, 0});
    const int upper = m.Add("upperarm" + x, clav, {s * 0.2f, 1.5f, 0});
    const int fore = m.Add("forearm" + x, upper, {s * 0.5f, 1.5f, 0});
    const int hand = m.Add("hand" + x, fore, {s * 0.75f, 1.5f, 0});
    const int thumb = m.Add("thumb" + x, hand, {s * 0.78f, 1.5f, 0.04f});
    m.Add("thumb_end" + x, thumb, {s * 0.82f, 1.5f, 0.07f}, false);
    const int index = m.Add("index" + x, hand, {s * 0.83f, 1.5f, 0.02f});
    m.Add("index_end" + x, index, {s * 0.9f, 1.5f, 0.02f}, false);
    const int middle = m.Add("middle" + x, hand, {s * 0.84f, 1.5f, 0});
    m.Add("middle_end" + x, middle, {s * 0.94f, 1.5f, 0}, false);
    const int thigh = m.Add("thigh" + x, hips, {s * 0.1f, 0.95f, 0});
    const int shin = m.Add("shin" + x, thigh, {s * 0.1f, 0.5f, 0});
    m.Add("shin_end" + x, shin, {s * 0.1f, 0.08f, 0}, false);
    const int foot = m.Add("foot" + x, opt.ik_feet ? root : shin, {s * 0.1f, 0.08f, 0});
    const Vector3f toe_pos = opt.feet_forward ? Vector3f(s * 0.1f, 0.02f, 0.15f) : Vector3f(s * 0.1f, 0.0f, 0.0f);
    const int toe = m.Add("toe" + x, foot, toe_pos);
    m.Add("toe_end" + x, toe, toe_pos + (opt.feet_forward ? Vector3f(0, 0, 0.07f) : Vector3f(0, -0.01f, 0)), false);
  }
  // Boxes: each weighted joint to its first child (or a fixed tip).
  for (size_t i = 0; i < m.joints.size(); ++i) {
    if (!m.joints[i].weighted) continue;
    for (size_t k = i + 1; k < m.joints.size(); ++k) {
      if (m.joints[k].parent == static_cast<int>(i)) {
        m.joints[i].tip = static_cast<int>(k);
        break;
      }
    }
  }
  // The chest's box goes up to the neck, the hips' to the spine, the hand's to the middle finger.
  m.joints[chest].tip = neck;
  m.joints[hips].tip = spine;
  for (const char* x : {"_l", "_r"}) m.joints[m.Find(std::string("hand") + x)].tip = m.Find(std::string("middle") + x);
  (void)head;
  return m;
}

Model MakeSnake(int n) {
  Model m;
  int prev = m.Add("root", -1, {0, 0, 0}, false);
  for (int i = 0; i < n; ++i) prev = m.Add("seg" + std::to_string(i), prev, {0.3f * i, 0.1f, 0});
  m.Add("tail_end", prev, {0.3f * n, 0.1f, 0}, false);
  for (int i = 1; i <= n; ++i) m.joints[i].tip = i + 1;
  return m;
}

Model MakeSpider() {
  Model m;
  const int body = m.Add("body", -1, {0, 0.5f, 0});
  const int abdomen = m.Add("abdomen", body, {0, 0.5f, -0.4f});
  m.joints[body].tip = abdomen;
  m.joints[abdomen].tip = m.Add("abdomen_end", abdomen, {0, 0.5f, -0.8f}, false);
  for (int k = 0; k < 8; ++k) {
    const float a = 0.3f + 0.8f * k;
    const Vector3f dir(std::cos(a), 0, std::sin(a));
    const int l1 = m.Add("leg" + std::to_string(k) + "a", body, Vector3f(0, 0.5f, 0) + 0.1f * dir);
    const int l2 = m.Add("leg" + std::to_string(k) + "b", l1, Vector3f(0, 0.7f, 0) + 0.4f * dir);
    const int l3 = m.Add("leg" + std::to_string(k) + "c", l2, Vector3f(0, 0.0f, 0) + 0.7f * dir);
    m.joints[l1].tip = l2;
    m.joints[l2].tip = l3;
    m.joints[l3].tip = m.Add("leg" + std::to_string(k) + "end", l3, Vector3f(0, -0.05f, 0) + 0.75f * dir, false);
  }
  return m;
}

struct Built {
  RawCharacter character;
  std::vector<int32_t> joint_of_role;  // model index -> skeleton index
  Model model;
  int32_t J(const std::string& role) const { return joint_of_role.at(model.Find(role)); }
};

// Stores the model in a random parents-first order under names "n<k>" (or the role names), with
// `world_from_model` on the root. Each box's near end is blended 70/30 with the parent joint.
Built Build(const Model& model, uint32_t seed, const Eigen::Affine3f& world_from_model = Eigen::Affine3f::Identity(),
            bool role_names = false) {
  Built b;
  b.model = model;
  const int n = static_cast<int>(model.joints.size());
  std::mt19937 rng(seed);
  std::vector<int> order;
  std::vector<bool> placed(n, false);
  while (static_cast<int>(order.size()) < n) {
    std::vector<int> ready;
    for (int i = 0; i < n; ++i) {
      if (!placed[i] && (model.joints[i].parent < 0 || placed[model.joints[i].parent])) ready.push_back(i);
    }
    const int pick = ready[std::uniform_int_distribution<int>(0, static_cast<int>(ready.size()) - 1)(rng)];
    placed[pick] = true;
    order.push_back(pick);
  }
  b.joint_of_role.assign(n, -1);
  for (int k = 0; k < n; ++k) b.joint_of_role[order[k]] = k;
  RawCharacter& c = b.character;
  c.source_file = "synthetic.glb";
  auto& sk = c.skeleton;
  for (int k = 0; k < n; ++k) {
    const ModelJoint& mj = model.joints[order[k]];
    sk.joint_names.push_back(role_names ? mj.role : "n" + std::to_string(k * 7 % 13) + "_" + std::to_string(k));
    sk.parents.push_back(mj.parent < 0 ? -1 : b.joint_of_role[mj.parent]);
    skinning::Transform t;
    if (mj.parent < 0) {
      t = skinning::Transform::FromMatrix(world_from_model.matrix());
      t.translation = world_from_model * mj.pos;
    } else {
      t.translation = mj.pos - model.joints[mj.parent].pos;
    }
    sk.rest_local.push_back(t);
  }
  std::vector<skinspheres::Mat4f> world(n);
  sk.RestWorld(world);
  for (int k = 0; k < n; ++k) {
    skinning::BindEntry e;
    e.joint = k;
    e.inverse_bind = world[k].inverse();
    c.skin.binds.push_back(e);
  }
  c.skin.influence_offsets.push_back(0);
  auto add_vertex = [&](const Vector3f& model_pos, int joint, int blend_with) {
    const Vector3f p = world_from_model * model_pos;
    c.positions_rest.push_back(p);
    c.skin.positions_bind.push_back(p);
    if (blend_with >= 0) {
      c.skin.influence_binds.push_back(static_cast<uint16_t>(joint));
      c.skin.influence_weights.push_back(0.7f);
      c.skin.influence_binds.push_back(static_cast<uint16_t>(blend_with));
      c.skin.influence_weights.push_back(0.3f);
    } else {
      c.skin.influence_binds.push_back(static_cast<uint16_t>(joint));
      c.skin.influence_weights.push_back(1.0f);
    }
    c.skin.influence_offsets.push_back(static_cast<uint32_t>(c.skin.influence_binds.size()));
  };
  for (int i = 0; i < n; ++i) {
    const ModelJoint& mj = model.joints[i];
    if (!mj.weighted || mj.tip < 0) continue;
    const Vector3f a = mj.pos, bpos = model.joints[mj.tip].pos;
    Vector3f axis = bpos - a;
    const float len = axis.norm();
    axis /= len;
    Vector3f side = std::abs(axis.y()) < 0.9f ? axis.cross(Vector3f::UnitY()) : axis.cross(Vector3f::UnitX());
    side.normalize();
    const Vector3f up = axis.cross(side);
    const float r = std::max(0.02f, 0.15f * len);
    const int first = static_cast<int>(c.positions_rest.size());
    const int joint = b.joint_of_role[i];
    const int parent_joint = mj.parent >= 0 && model.joints[mj.parent].weighted ? b.joint_of_role[mj.parent] : -1;
    for (int end = 0; end < 2; ++end) {
      for (int q = 0; q < 4; ++q) {
        const float sx = (q & 1) ? r : -r, sy = (q & 2) ? r : -r;
        add_vertex((end ? bpos : a) + sx * side + sy * up, joint, end == 0 ? parent_joint : -1);
      }
    }
    static const int kFaces[12][3] = {{0, 1, 3}, {0, 3, 2}, {4, 7, 5}, {4, 6, 7}, {0, 4, 5}, {0, 5, 1},
                                      {2, 3, 7}, {2, 7, 6}, {0, 2, 6}, {0, 6, 4}, {1, 5, 7}, {1, 7, 3}};
    MeshRange range;
    range.name = "box_" + mj.role;
    range.first_vertex = static_cast<uint32_t>(first);
    range.vertex_count = 8;
    range.first_triangle = static_cast<uint32_t>(c.triangles.size());
    range.triangle_count = 12;
    range.skinned = true;
    for (const auto& f : kFaces) c.triangles.emplace_back(first + f[0], first + f[1], first + f[2]);
    c.meshes.push_back(range);
  }
  return b;
}

// Brute-force dominant joint: sum weights per joint over all joints, largest wins, ties -> smallest.
std::vector<int32_t> DominantOracle(const RawCharacter& c) {
  std::vector<int32_t> out;
  for (const auto& tri : c.triangles) {
    std::vector<double> w(c.skeleton.size(), 0.0);
    for (int k = 0; k < 3; ++k) {
      const int v = tri[k];
      for (uint32_t i = c.skin.influence_offsets[v]; i < c.skin.influence_offsets[v + 1]; ++i) {
        w[c.skin.binds[c.skin.influence_binds[i]].joint] += c.skin.influence_weights[i];
      }
    }
    out.push_back(static_cast<int32_t>(std::max_element(w.begin(), w.end()) - w.begin()));
  }
  return out;
}

// Every triangle in exactly one part, the part of its dominant joint (checked against the oracle).
void ExpectConsistent(const RawCharacter& c, const BodyParts& bp) {
  ASSERT_EQ(bp.triangle_part.size(), c.triangle_count());
  ASSERT_EQ(bp.triangle_joint.size(), c.triangle_count());
  ASSERT_EQ(bp.joint_part.size(), c.skeleton.size());
  std::vector<int> seen(c.triangle_count(), 0);
  for (size_t p = 0; p < bp.parts.size(); ++p) {
    EXPECT_TRUE(std::is_sorted(bp.parts[p].triangles.begin(), bp.parts[p].triangles.end()));
    for (uint32_t t : bp.parts[p].triangles) {
      ASSERT_LT(t, c.triangle_count());
      ++seen[t];
      EXPECT_EQ(bp.triangle_part[t], static_cast<int32_t>(p));
    }
    for (int32_t j : bp.parts[p].joints) EXPECT_EQ(bp.joint_part[j], static_cast<int32_t>(p)) << "joint " << j;
    // The chain is a subset of the joints, each a descendant of the previous one.
    for (size_t i = 0; i < bp.parts[p].chain.size(); ++i) {
      const int32_t j = bp.parts[p].chain[i];
      EXPECT_NE(std::find(bp.parts[p].joints.begin(), bp.parts[p].joints.end(), j), bp.parts[p].joints.end());
    }
  }
  for (size_t t = 0; t < c.triangle_count(); ++t) EXPECT_EQ(seen[t], 1) << "triangle " << t;
  // Each joint listed by exactly the part joint_part names.
  for (size_t j = 0; j < c.skeleton.size(); ++j) {
    int listed = 0;
    for (const BodyPart& p : bp.parts) listed += static_cast<int>(std::count(p.joints.begin(), p.joints.end(), j));
    EXPECT_EQ(listed, bp.joint_part[j] >= 0 ? 1 : 0) << "joint " << j;
  }
  if (c.skin.vertex_count() > 0) {
    const auto oracle = DominantOracle(c);
    for (size_t t = 0; t < c.triangle_count(); ++t) {
      EXPECT_EQ(bp.triangle_joint[t], oracle[t]) << "triangle " << t;
      EXPECT_EQ(bp.triangle_part[t], bp.joint_part[bp.triangle_joint[t]]) << "triangle " << t;
    }
  }
}

std::vector<std::string> Roles(const Built& b, const BodyParts& bp, const std::string& part) {
  std::vector<std::string> out;
  const int32_t p = bp.Find(part);
  if (p < 0) return out;
  for (int32_t j : bp.parts[p].chain) {
    for (size_t i = 0; i < b.joint_of_role.size(); ++i) {
      if (b.joint_of_role[i] == j) out.push_back(b.model.joints[i].role);
    }
  }
  return out;
}

std::string PartOfRole(const Built& b, const BodyParts& bp, const std::string& role) {
  const int32_t p = bp.joint_part[b.J(role)];
  return p < 0 ? "none" : bp.parts[p].name;
}

void ExpectHumanoidRoles(const Built& b, const BodyParts& bp, bool flip_sides) {
  ASSERT_TRUE(bp.humanoid);
  ASSERT_EQ(bp.parts.size(), 6u);
  const std::string L = flip_sides ? "_r" : "_l", R = flip_sides ? "_l" : "_r";
  using V = std::vector<std::string>;
  EXPECT_EQ(Roles(b, bp, "torso"), (V{"hips", "spine", "chest"}));
  EXPECT_EQ(Roles(b, bp, "head"), (V{"neck", "head", "head_end"}));
  EXPECT_EQ(Roles(b, bp, "arm_l"),
            (V{"clavicle" + L, "upperarm" + L, "forearm" + L, "hand" + L, "middle" + L, "middle_end" + L}));
  EXPECT_EQ(Roles(b, bp, "arm_r"),
            (V{"clavicle" + R, "upperarm" + R, "forearm" + R, "hand" + R, "middle" + R, "middle_end" + R}));
  EXPECT_EQ(PartOfRole(b, bp, "armature"), "none");
  EXPECT_EQ(PartOfRole(b, bp, "thumb" + L), "arm_l");
  EXPECT_EQ(PartOfRole(b, bp, "thumb_end" + R), "arm_r");
  EXPECT_EQ(PartOfRole(b, bp, "foot" + L), "leg_l");
  EXPECT_EQ(PartOfRole(b, bp, "toe_end" + R), "leg_r");
  EXPECT_EQ(PartOfRole(b, bp, "thigh" + L), "leg_l");
  for (const BodyPart& p : bp.parts) EXPECT_FALSE(p.triangles.empty()) << p.name;
}

TEST(BodyPartsTest, ShuffledHumanoidWithMeaninglessNames) {
  for (uint32_t seed = 1; seed <= 6; ++seed) {
    SCOPED_TRACE(seed);
    const Built b = Build(MakeHumanoid(), seed);
    auto r = SplitBodyParts(b.character);
    ASSERT_TRUE(r.ok()) << r.error().message;
    ExpectConsistent(b.character, *r);
    ExpectHumanoidRoles(b, *r, false);
    using V = std::vector<std::string>;
    EXPECT_EQ(Roles(b, *r, "leg_l"), (V{"thigh_l", "shin_l", "foot_l", "toe_l", "toe_end_l"}));
    // Same input, same answer.
    auto again = SplitBodyParts(b.character);
    ASSERT_TRUE(again.ok());
    EXPECT_EQ(again->triangle_part, r->triangle_part);
    EXPECT_EQ(again->joint_part, r->joint_part);
  }
}

TEST(BodyPartsTest, PartsFollowGeometryNotJointOrder) {
  // Triangles are not shuffled, only joints: every shuffle gives the same triangle -> part name.
  std::vector<std::string> first;
  for (uint32_t seed = 10; seed < 15; ++seed) {
    const Built b = Build(MakeHumanoid(), seed);
    auto r = SplitBodyParts(b.character);
    ASSERT_TRUE(r.ok());
    std::vector<std::string> names;
    for (int32_t p : r->triangle_part) names.push_back(r->parts[p].name);
    if (first.empty()) first = names;
    EXPECT_EQ(names, first) << "seed " << seed;
  }
}

TEST(BodyPartsTest, MirroredHumanoidSwapsSidesEvenAgainstNames) {
  // Mirror x: the joints named *_l now stand on the character's right (feet still point +Z).
  const Eigen::Affine3f mirror(Eigen::Scaling(-1.0f, 1.0f, 1.0f));
  const Built b = Build(MakeHumanoid(), 3, mirror, /*role_names=*/true);
  auto r = SplitBodyParts(b.character);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ExpectConsistent(b.character, *r);
  ExpectHumanoidRoles(b, *r, true);
}

TEST(BodyPartsTest, TurnedAroundAndLyingCharacters) {
  // Facing -Z (turned 180° about Y): the character's left is world -X, still the *_l joints.
  const Eigen::Affine3f turn(Eigen::AngleAxisf(3.14159265f, Vector3f::UnitY()));
  // Z-up source under a rotated root (CesiumMan-like), shifted and scaled by 0.1.
  const Eigen::Affine3f zup =
      Eigen::Translation3f(5, -2, 3) * Eigen::AngleAxisf(1.5707963f, Vector3f::UnitX()) * Eigen::Scaling(0.1f);
  for (const auto& xf : {turn, zup}) {
    const Built b = Build(MakeHumanoid(), 4, xf);
    auto r = SplitBodyParts(b.character);
    ASSERT_TRUE(r.ok()) << r.error().message;
    ExpectConsistent(b.character, *r);
    ExpectHumanoidRoles(b, *r, false);
  }
}

TEST(BodyPartsTest, IkFeetUnderTheRootJoinTheirLegs) {
  HumanoidOptions opt;
  opt.ik_feet = true;
  const Built b = Build(MakeHumanoid(opt), 5);
  auto r = SplitBodyParts(b.character);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ExpectConsistent(b.character, *r);
  ExpectHumanoidRoles(b, *r, false);
  using V = std::vector<std::string>;
  EXPECT_EQ(Roles(b, *r, "leg_l"), (V{"thigh_l", "shin_l", "shin_end_l", "foot_l", "toe_l", "toe_end_l"}));
  EXPECT_EQ(Roles(b, *r, "leg_r"), (V{"thigh_r", "shin_r", "shin_end_r", "foot_r", "toe_r", "toe_end_r"}));
}

TEST(BodyPartsTest, NamesBreakTheTieWhenFeetGiveNoFacing) {
  HumanoidOptions opt;
  opt.feet_forward = false;
  const Eigen::Affine3f turn(Eigen::AngleAxisf(3.14159265f, Vector3f::UnitY()));
  // With side names, the names decide: *_l is left even though it stands on world -X.
  {
    const Built b = Build(MakeHumanoid(opt), 6, turn, /*role_names=*/true);
    auto r = SplitBodyParts(b.character);
    ASSERT_TRUE(r.ok());
    ExpectConsistent(b.character, *r);
    ExpectHumanoidRoles(b, *r, false);
  }
  // Without names: the glTF convention (facing +Z, left = +X) -> the *_l joints (now on -X) are right.
  {
    const Built b = Build(MakeHumanoid(opt), 6, turn, /*role_names=*/false);
    auto r = SplitBodyParts(b.character);
    ASSERT_TRUE(r.ok());
    ExpectConsistent(b.character, *r);
    ExpectHumanoidRoles(b, *r, true);
  }
}

TEST(BodyPartsTest, SnakeIsOneChain) {
  const Built b = Build(MakeSnake(10), 7);
  auto r = SplitBodyParts(b.character);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ExpectConsistent(b.character, *r);
  EXPECT_FALSE(r->humanoid);
  ASSERT_EQ(r->parts.size(), 1u);
  EXPECT_EQ(r->parts[0].name, "chain_0");
  EXPECT_EQ(r->parts[0].kind, PartKind::kChain);
  std::vector<std::string> expect;
  for (int i = 0; i < 10; ++i) expect.push_back("seg" + std::to_string(i));
  expect.push_back("tail_end");
  EXPECT_EQ(Roles(b, *r, "chain_0"), expect);
  EXPECT_EQ(PartOfRole(b, *r, "root"), "none");
}

TEST(BodyPartsTest, SpiderIsOneChainPerLeg) {
  const Built b = Build(MakeSpider(), 8);
  auto r = SplitBodyParts(b.character);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ExpectConsistent(b.character, *r);
  EXPECT_FALSE(r->humanoid);
  // body (ends at the branch) + abdomen + 8 legs.
  ASSERT_EQ(r->parts.size(), 10u);
  std::set<std::string> names;
  for (const BodyPart& p : r->parts) {
    names.insert(p.name);
    EXPECT_FALSE(p.triangles.empty()) << p.name;
  }
  EXPECT_EQ(names.size(), 10u);
  EXPECT_EQ(PartOfRole(b, *r, "body"), "chain_0");
  EXPECT_EQ(Roles(b, *r, "chain_0"), std::vector<std::string>{"body"});
  for (int k = 0; k < 8; ++k) {
    const std::string l = "leg" + std::to_string(k);
    const std::string part = PartOfRole(b, *r, l + "a");
    EXPECT_EQ(Roles(b, *r, part), (std::vector<std::string>{l + "a", l + "b", l + "c", l + "end"}));
  }
}

std::filesystem::path WriteFile(const std::string& dir, const std::string& name, const std::string& text) {
  const auto path = test::TempDir(dir) / name;
  std::ofstream(path) << text;
  return path;
}

TEST(BodyPartsTest, OverridesMoveJointsAndTheirTriangles) {
  const Built b = Build(MakeHumanoid(), 9, Eigen::Affine3f::Identity(), /*role_names=*/true);
  const auto path = WriteFile("body_parts_override", "parts.json", R"({"hand_l": "torso", "neck": "torso"})");
  auto ov = LoadPartOverrides(path, &b.character.skeleton);
  ASSERT_TRUE(ov.ok()) << ov.error().message;
  EXPECT_EQ(ov->joint_to_part.size(), 2u);
  auto plain = SplitBodyParts(b.character);
  auto r = SplitBodyParts(b.character, &*ov);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ExpectConsistent(b.character, *r);
  EXPECT_EQ(PartOfRole(b, *r, "hand_l"), "torso");
  EXPECT_EQ(PartOfRole(b, *r, "neck"), "torso");
  EXPECT_EQ(PartOfRole(b, *r, "middle_l"), "arm_l");  // only the named joint moves
  const int32_t hand = b.J("hand_l");
  size_t moved = 0;
  for (size_t t = 0; t < r->triangle_part.size(); ++t) {
    if (r->triangle_joint[t] == hand || r->triangle_joint[t] == b.J("neck")) {
      EXPECT_EQ(r->parts[r->triangle_part[t]].name, "torso");
      ++moved;
    } else {
      EXPECT_EQ(r->triangle_part[t], plain->triangle_part[t]);
    }
  }
  EXPECT_GT(moved, 0u);
}

TEST(BodyPartsTest, BadOverridesGiveClearErrors) {
  const Built b = Build(MakeHumanoid(), 9, Eigen::Affine3f::Identity(), /*role_names=*/true);
  struct Case {
    std::string text;
    ErrorCode code;
    std::string says;
  };
  const std::vector<Case> cases = {
      {R"({"hand_l": "torso",)", ErrorCode::kFormatRejected, "malformed JSON"},
      {R"(["hand_l", "torso"])", ErrorCode::kFormatRejected, "expected a JSON object"},
      {R"({"hand_l": 3})", ErrorCode::kFormatRejected, "hand_l"},
      {R"({"hand_l": "wing"})", ErrorCode::kInvalidArgument, "unknown part 'wing'"},
      {R"({"tentacle": "torso"})", ErrorCode::kNotFound, "unknown joint 'tentacle'"},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    const auto path = WriteFile("body_parts_bad_override", "bad" + std::to_string(i) + ".json", cases[i].text);
    auto ov = LoadPartOverrides(path, &b.character.skeleton);
    ASSERT_FALSE(ov.ok()) << cases[i].text;
    EXPECT_EQ(ov.error().code, cases[i].code) << ov.error().message;
    EXPECT_NE(ov.error().message.find(path.string()), std::string::npos) << ov.error().message;
    EXPECT_NE(ov.error().message.find(cases[i].says), std::string::npos) << ov.error().message;
  }
  auto missing = LoadPartOverrides(test::TempDir("body_parts_missing") / "nope.json");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, ErrorCode::kFileNotFound);
  EXPECT_NE(missing.error().message.find("nope.json"), std::string::npos);

  // Checked again at split time: a joint the character lacks, a part it does not have.
  PartOverrides ov;
  ov.source_file = "mine.json";
  ov.joint_to_part["tentacle"] = "torso";
  auto r = SplitBodyParts(b.character, &ov);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kNotFound);
  EXPECT_NE(r.error().message.find("mine.json"), std::string::npos);
  ov.joint_to_part = {{"hand_l", "chain_3"}};
  r = SplitBodyParts(b.character, &ov);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(r.error().message.find("chain_3"), std::string::npos) << r.error().message;
}

TEST(BodyPartsTest, InvalidCharactersAreRefused) {
  Built b = Build(MakeSnake(3), 1);
  RawCharacter bad_tri = b.character;
  bad_tri.triangles[0][1] = 100000;
  auto r = SplitBodyParts(bad_tri);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kInvalidData);
  EXPECT_NE(r.error().message.find("synthetic.glb"), std::string::npos);
  RawCharacter bad_bind = b.character;
  bad_bind.skin.binds[0].joint = 99;
  EXPECT_EQ(SplitBodyParts(bad_bind).error().code, ErrorCode::kInvalidData);
  RawCharacter bad_skel = b.character;
  bad_skel.skeleton.parents.pop_back();
  EXPECT_EQ(SplitBodyParts(bad_skel).error().code, ErrorCode::kInvalidData);
  RawCharacter bad_infl = b.character;
  bad_infl.skin.influence_binds[0] = 999;
  EXPECT_EQ(SplitBodyParts(bad_infl).error().code, ErrorCode::kInvalidData);
}

TEST(BodyPartsTest, BareSkeletonUsesEveryJoint) {
  Built b = Build(MakeHumanoid(), 2);
  RawCharacter bare = b.character;
  bare.positions_rest.clear();
  bare.triangles.clear();
  bare.meshes.clear();
  bare.skin = {};
  auto r = SplitBodyParts(bare);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_TRUE(r->humanoid);
  EXPECT_EQ(PartOfRole(b, *r, "hand_l"), "arm_l");
  EXPECT_EQ(PartOfRole(b, *r, "foot_r"), "leg_r");
}

// The shared characters: who is where, by the artists' names (the test's oracle; the split
// itself does not read them unless the feet are ambiguous, which they are not here).
struct RealCase {
  std::string file;
  std::string pelvis, hips, head, left_shoulder, right_shoulder, left_thigh, right_thigh;
  std::string left_ankle, left_toe;  // forward = toe - ankle (horizontal); empty: faces +Z
};

const std::vector<RealCase>& RealCases() {
  static const std::vector<RealCase> cases = {
      {"Xbot.glb", "mixamorig:Hips", "mixamorig:Hips", "mixamorig:Head", "mixamorig:LeftShoulder",
       "mixamorig:RightShoulder", "mixamorig:LeftUpLeg", "mixamorig:RightUpLeg", "mixamorig:LeftFoot",
       "mixamorig:LeftToeBase"},
      {"Soldier.glb", "mixamorig:Hips", "mixamorig:Hips", "mixamorig:Head", "mixamorig:LeftShoulder",
       "mixamorig:RightShoulder", "mixamorig:LeftUpLeg", "mixamorig:RightUpLeg", "mixamorig:LeftFoot",
       "mixamorig:LeftToeBase"},
      {"CesiumMan.glb", "Skeleton_torso_joint_1", "Skeleton_torso_joint_1", "Skeleton_neck_joint_2",
       "Skeleton_arm_joint_L__4_", "Skeleton_arm_joint_R", "leg_joint_L_1", "leg_joint_R_1", "leg_joint_L_3",
       "leg_joint_L_5"},
      // RobotExpressive: the legs branch at "Body", the spine starts at "Hips"; its feet are
      // rigid blocks on IK joints under the root; it faces +Z.
      {"RobotExpressive.glb", "Body", "Hips", "Head", "Shoulder.L", "Shoulder.R", "UpperLeg.L", "UpperLeg.R", "", ""},
  };
  return cases;
}

Eigen::Vector3f PartCentroid(const RawCharacter& c, const BodyPart& p) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (uint32_t t : p.triangles) {
    for (int k = 0; k < 3; ++k) sum += c.positions_rest[c.triangles[t][k]].cast<double>();
  }
  return (sum / std::max<double>(1.0, 3.0 * p.triangles.size())).cast<float>();
}

TEST(BodyPartsRealTest, SharedCharactersSplitIntoSixParts) {
  for (const RealCase& rc : RealCases()) {
    SCOPED_TRACE(rc.file);
    SKINSPHERES_REQUIRE_ASSET(path, rc.file);
    ImportOptions io;
    io.read_clips = false;
    auto ch = ImportCharacter(path, io);
    ASSERT_TRUE(ch.ok()) << ch.error().message;
    auto r = SplitBodyParts(*ch);
    ASSERT_TRUE(r.ok()) << r.error().message;
    ExpectConsistent(*ch, *r);
    ASSERT_TRUE(r->humanoid);
    ASSERT_EQ(r->parts.size(), 6u);
    for (const BodyPart& p : r->parts) {
      EXPECT_FALSE(p.triangles.empty()) << p.name;
      EXPECT_FALSE(p.chain.empty()) << p.name;
    }
    const auto& sk = ch->skeleton;
    auto part_of = [&](const std::string& joint) {
      const int32_t j = sk.Find(joint);
      EXPECT_GE(j, 0) << joint;
      return j < 0 || r->joint_part[j] < 0 ? std::string("none") : r->parts[r->joint_part[j]].name;
    };
    EXPECT_EQ(part_of(rc.hips), "torso");
    EXPECT_EQ(r->parts[0].chain.front(), sk.Find(rc.pelvis)) << "the torso chain starts at the pelvis";
    EXPECT_EQ(part_of(rc.head), "head");
    EXPECT_EQ(part_of(rc.left_shoulder), "arm_l");
    EXPECT_EQ(part_of(rc.right_shoulder), "arm_r");
    EXPECT_EQ(part_of(rc.left_thigh), "leg_l");
    EXPECT_EQ(part_of(rc.right_thigh), "leg_r");
    // The left arm stands on the character's left: left = up x forward, forward from the toes.
    std::vector<skinspheres::Mat4f> world(sk.size());
    sk.RestWorld(world);
    Eigen::Vector3f forward = Eigen::Vector3f::UnitZ();
    if (!rc.left_toe.empty()) {
      forward =
          world[sk.Find(rc.left_toe)].topRightCorner<3, 1>() - world[sk.Find(rc.left_ankle)].topRightCorner<3, 1>();
      forward.y() = 0.0f;
      forward.normalize();
    }
    const Eigen::Vector3f left = Eigen::Vector3f::UnitY().cross(forward);
    const Eigen::Vector3f arm_l = PartCentroid(*ch, r->parts[r->Find("arm_l")]);
    const Eigen::Vector3f arm_r = PartCentroid(*ch, r->parts[r->Find("arm_r")]);
    const Eigen::Vector3f leg_l = PartCentroid(*ch, r->parts[r->Find("leg_l")]);
    const Eigen::Vector3f leg_r = PartCentroid(*ch, r->parts[r->Find("leg_r")]);
    EXPECT_GT((arm_l - arm_r).dot(left), 0.0f);
    EXPECT_GT((leg_l - leg_r).dot(left), 0.0f);
    EXPECT_GT(r->left.dot(left), 0.9f) << r->left.transpose();
    EXPECT_GT(r->up.y(), 0.9f) << r->up.transpose();
    EXPECT_EQ(r->facing_from, "feet");
    std::printf("  %-20s", rc.file.c_str());
    for (const BodyPart& p : r->parts)
      std::printf(" %s %zuj/%zut", p.name.c_str(), p.joints.size(), p.triangles.size());
    std::printf("\n");

    // Names cannot decide: with every joint renamed, the same split.
    RawCharacter anonymous = *ch;
    for (size_t j = 0; j < anonymous.skeleton.size(); ++j) {
      std::string name = std::to_string(j * 31 % 97);
      name.insert(name.begin(), 'x');
      anonymous.skeleton.joint_names[j] = name;
    }
    auto r2 = SplitBodyParts(anonymous);
    ASSERT_TRUE(r2.ok());
    EXPECT_EQ(r2->triangle_part, r->triangle_part);
    EXPECT_EQ(r2->joint_part, r->joint_part);
  }
}

TEST(BodyPartsRealTest, OverrideOnXbot) {
  SKINSPHERES_REQUIRE_ASSET(path, "Xbot.glb");
  ImportOptions io;
  io.read_clips = false;
  auto ch = ImportCharacter(path, io);
  ASSERT_TRUE(ch.ok()) << ch.error().message;
  const auto file = WriteFile("body_parts_xbot", "xbot_parts.json",
                              R"({"mixamorig:LeftShoulder": "torso", "mixamorig:Neck": "torso"})");
  auto ov = LoadPartOverrides(file, &ch->skeleton);
  ASSERT_TRUE(ov.ok()) << ov.error().message;
  auto r = SplitBodyParts(*ch, &*ov);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ExpectConsistent(*ch, *r);
  EXPECT_EQ(r->joint_part[ch->skeleton.Find("mixamorig:LeftShoulder")], r->Find("torso"));
  EXPECT_EQ(r->joint_part[ch->skeleton.Find("mixamorig:Neck")], r->Find("torso"));
  EXPECT_EQ(r->joint_part[ch->skeleton.Find("mixamorig:LeftArm")], r->Find("arm_l"));
}

}  // namespace
}  // namespace skinspheres::lib
