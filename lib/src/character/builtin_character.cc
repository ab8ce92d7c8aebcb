// The procedural humanoid of builtin_character.h: skeleton, nine closed pieces generated as
// stacks of elliptic rings with domed caps, chain-blended skin weights, and the "walk" and
// "touch" clips (the touch poses come from an analytic two-bone IK, checked by an independent
// forward-kinematics + skinning evaluation in tests/lib/character/builtin_character_tests.cc).
#include "skinspheres/lib/character/builtin_character.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

namespace skinspheres::lib {
namespace {

using Eigen::Matrix3f;
using Eigen::Vector3f;
using skinning::Interpolation;
using skinning::JointTrack;

constexpr float kPi = std::numbers::pi_v<float>;
// The shoulder joint (LeftArm) sits kArm from the body's axis; the arm piece starts just outside it
// (its dome reaches back to the joint), clear of the torso in every pose of the clips.
constexpr float kShoulderOffset = 0.05f;
constexpr float kUpperArmOffset = 0.19f;
constexpr float kArm = kShoulderOffset + kUpperArmOffset;
float Deg(float d) { return d * kPi / 180.0f; }

Quatf AxisAngle(float radians, const Vector3f& axis) { return Quatf(Eigen::AngleAxisf(radians, axis.normalized())); }
Quatf Rx(float deg) { return AxisAngle(Deg(deg), Vector3f::UnitX()); }
Quatf Ry(float deg) { return AxisAngle(Deg(deg), Vector3f::UnitY()); }
Quatf Rz(float deg) { return AxisAngle(Deg(deg), Vector3f::UnitZ()); }

// ---------------------------------------------------------------------------------------------
// Skeleton

struct JointDef {
  std::string name, parent;  // parent empty for the root
  Vector3f offset;           // rest local translation (rest rotations are identity)
};

std::vector<JointDef> JointDefs() {
  std::vector<JointDef> d = {
      {"Armature", "", {0, 0, 0}},        {"Hips", "Armature", {0, 1.00f, 0}},    {"Spine", "Hips", {0, 0.10f, 0}},
      {"Spine1", "Spine", {0, 0.12f, 0}}, {"Spine2", "Spine1", {0, 0.12f, 0}},    {"Neck", "Spine2", {0, 0.16f, 0}},
      {"Head", "Neck", {0, 0.10f, 0}},    {"HeadTop_End", "Head", {0, 0.20f, 0}},
  };
  for (const float side : {1.0f, -1.0f}) {
    const std::string s = side > 0 ? "Left" : "Right";
    d.push_back({s + "Shoulder", "Spine2", {side * kShoulderOffset, 0.10f, 0}});
    d.push_back({s + "Arm", s + "Shoulder", {side * kUpperArmOffset, 0, 0}});
    d.push_back({s + "ForeArm", s + "Arm", {side * 0.27f, 0, 0}});
    d.push_back({s + "Hand", s + "ForeArm", {side * 0.25f, 0, 0}});
  }
  for (const float side : {1.0f, -1.0f}) {
    const std::string s = side > 0 ? "Left" : "Right";
    d.push_back({s + "UpLeg", "Hips", {side * 0.10f, -0.05f, 0}});
    d.push_back({s + "Leg", s + "UpLeg", {0, -0.43f, 0}});
    d.push_back({s + "Foot", s + "Leg", {0, -0.42f, 0}});
    d.push_back({s + "ToeBase", s + "Foot", {0, -0.06f, 0.12f}});
    d.push_back({s + "Toe_End", s + "ToeBase", {0, 0, 0.08f}});
  }
  return d;
}

skinning::Skeleton MakeSkeleton() {
  skinning::Skeleton sk;
  for (const JointDef& j : JointDefs()) {
    sk.joint_names.emplace_back(j.name);
    sk.parents.push_back(j.parent.empty() ? -1 : sk.Find(j.parent));
    skinning::Transform t;
    t.translation = j.offset;
    sk.rest_local.push_back(t);
  }
  return sk;
}

// ---------------------------------------------------------------------------------------------
// Geometry: a piece is a straight stack of elliptic rings  c(s) + a(s)·cosθ·u + b(s)·sinθ·v
// along axis d (s = coordinate along d from `origin`), closed by elliptic domes at both ends.

struct ProfileKey {
  float s, a, b;
};

struct ChainLink {
  const char* joint;
  float s_begin;  // the joint owns s >= s_begin (until the next link), blended over ±h
};

struct PieceDef {
  const char* name;
  Vector3f origin, d, u, v;
  std::vector<ProfileKey> profile;  // increasing s; a along u, b along v
  int body_rings;                   // rings spread over [profile.front().s, profile.back().s]
  float cap_begin, cap_end;         // dome lengths beyond the profile ends
  int cap_rings;                    // rings per dome (plus the pole)
  int segments;                     // vertices per ring
  std::vector<ChainLink> chain;     // first link's s_begin is ignored (owns everything below)
  float blend_h;
};

ProfileKey ProfileAt(const std::vector<ProfileKey>& p, float s) {
  if (s <= p.front().s) return {s, p.front().a, p.front().b};
  for (size_t i = 1; i < p.size(); ++i) {
    if (s <= p[i].s) {
      const float t = (s - p[i - 1].s) / (p[i].s - p[i - 1].s);
      return {s, p[i - 1].a + t * (p[i].a - p[i - 1].a), p[i - 1].b + t * (p[i].b - p[i - 1].b)};
    }
  }
  return {s, p.back().a, p.back().b};
}

float SmoothStep(float x) {
  x = std::clamp(x, 0.0f, 1.0f);
  return x * x * (3.0f - 2.0f * x);
}

// Weights along a chain: ramp r_i(s) = smoothstep((s - s_i + h) / 2h) for link i >= 1, r_0 = 1;
// w_i = r_i - r_{i+1} (non-negative since links are ordered; the sum telescopes to 1).
void ChainWeights(const PieceDef& p, const skinning::Skeleton& sk, float s,
                  std::vector<std::pair<int32_t, float>>& out) {
  out.clear();
  const size_t n = p.chain.size();
  std::vector<float> r(n + 1, 0.0f);
  r[0] = 1.0f;
  for (size_t i = 1; i < n; ++i) r[i] = SmoothStep((s - p.chain[i].s_begin + p.blend_h) / (2 * p.blend_h));
  float sum = 0.0f;
  for (size_t i = 0; i < n; ++i) {
    const float w = r[i] - r[i + 1];
    if (w > 1e-4f) {
      out.emplace_back(sk.Find(p.chain[i].joint), w);
      sum += w;
    }
  }
  for (auto& [j, w] : out) w /= sum;
}

struct MeshBuilder {
  std::vector<Vector3f> positions;
  std::vector<Eigen::Vector3i> triangles;
  std::vector<std::vector<std::pair<int32_t, float>>> influences;  // joint, weight
  std::vector<MeshRange> meshes;
};

void AddPiece(const PieceDef& p, const skinning::Skeleton& sk, MeshBuilder& mb) {
  struct Ring {
    float s, a, b;
  };
  std::vector<Ring> rings;
  const float s0 = p.profile.front().s, s1 = p.profile.back().s;
  const ProfileKey k0 = ProfileAt(p.profile, s0), k1 = ProfileAt(p.profile, s1);
  // Dome at the start: φ from small to π/2, ring at s0 - c·cos φ scaled by sin φ (an ellipse
  // quadrant in the (s, radius) plane).
  for (int k = 1; k <= p.cap_rings; ++k) {
    const float phi = 0.5f * kPi * static_cast<float>(k) / static_cast<float>(p.cap_rings + 1);
    rings.push_back({s0 - p.cap_begin * std::cos(phi), k0.a * std::sin(phi), k0.b * std::sin(phi)});
  }
  for (int k = 0; k < p.body_rings; ++k) {
    const float t = p.body_rings == 1 ? 0.5f : static_cast<float>(k) / static_cast<float>(p.body_rings - 1);
    const float s = s0 + t * (s1 - s0);
    const ProfileKey key = ProfileAt(p.profile, s);
    rings.push_back({s, key.a, key.b});
  }
  for (int k = p.cap_rings; k >= 1; --k) {
    const float phi = 0.5f * kPi * static_cast<float>(k) / static_cast<float>(p.cap_rings + 1);
    rings.push_back({s1 + p.cap_end * std::cos(phi), k1.a * std::sin(phi), k1.b * std::sin(phi)});
  }

  MeshRange range;
  range.name = p.name;
  range.skinned = true;
  range.first_vertex = static_cast<uint32_t>(mb.positions.size());
  range.first_triangle = static_cast<uint32_t>(mb.triangles.size());
  const int base = static_cast<int>(mb.positions.size());
  const int m = p.segments;
  std::vector<std::pair<int32_t, float>> w;
  auto add_vertex = [&](float s, const Vector3f& pos) {
    mb.positions.push_back(pos);
    ChainWeights(p, sk, s, w);
    mb.influences.push_back(w);
  };
  const float s_pole0 = s0 - p.cap_begin, s_pole1 = s1 + p.cap_end;
  add_vertex(s_pole0, p.origin + s_pole0 * p.d);
  for (const Ring& r : rings) {
    for (int k = 0; k < m; ++k) {
      const float th = 2.0f * kPi * static_cast<float>(k) / static_cast<float>(m);
      add_vertex(r.s, p.origin + r.s * p.d + r.a * std::cos(th) * p.u + r.b * std::sin(th) * p.v);
    }
  }
  add_vertex(s_pole1, p.origin + s_pole1 * p.d);
  const int nr = static_cast<int>(rings.size());
  const int pole0 = base, pole1 = base + 1 + nr * m;
  auto ring_v = [&](int ring, int k) { return base + 1 + ring * m + (k % m); };
  std::vector<Eigen::Vector3i> tris;
  for (int k = 0; k < m; ++k) tris.emplace_back(pole0, ring_v(0, k + 1), ring_v(0, k));
  for (int r = 0; r + 1 < nr; ++r) {
    for (int k = 0; k < m; ++k) {
      tris.emplace_back(ring_v(r, k), ring_v(r, k + 1), ring_v(r + 1, k + 1));
      tris.emplace_back(ring_v(r, k), ring_v(r + 1, k + 1), ring_v(r + 1, k));
    }
  }
  for (int k = 0; k < m; ++k) tris.emplace_back(pole1, ring_v(nr - 1, k), ring_v(nr - 1, k + 1));
  // Orient outward: the signed volume Σ (a · (b × c)) / 6 of a closed outward surface is > 0.
  double vol = 0.0;
  for (const auto& t : tris) {
    vol += mb.positions[t[0]].cast<double>().dot(
        mb.positions[t[1]].cast<double>().cross(mb.positions[t[2]].cast<double>()));
  }
  if (vol < 0.0) {
    for (auto& t : tris) std::swap(t[1], t[2]);
  }
  mb.triangles.insert(mb.triangles.end(), tris.begin(), tris.end());
  range.vertex_count = static_cast<uint32_t>(mb.positions.size()) - range.first_vertex;
  range.triangle_count = static_cast<uint32_t>(mb.triangles.size()) - range.first_triangle;
  mb.meshes.push_back(range);
}

// Torso section profile (y, half-width along X, half-depth along Z): also used to place the
// touch targets on the chest surface.
const std::vector<ProfileKey>& TorsoProfile() {
  static const std::vector<ProfileKey> p = {{0.90f, 0.15f, 0.10f}, {1.00f, 0.16f, 0.105f}, {1.12f, 0.14f, 0.095f},
                                            {1.25f, 0.16f, 0.11f}, {1.38f, 0.17f, 0.11f},  {1.44f, 0.155f, 0.095f}};
  return p;
}
const Vector3f kHeadCenter(0.0f, 1.70f, 0.01f);
const Vector3f kHeadSemiAxes(0.085f, 0.11f, 0.10f);
constexpr float kHandCenterOffset = 0.085f;  // from the hand joint along the hand
constexpr float kHandHalfThickness = 0.019f;
constexpr float kTouchApproach = 0.4f;  // the hands' halfway spot: this far in front, at shoulder width

// The torso, the neck and the head.
void AddTrunkPieces(std::vector<PieceDef>& d) {
  const Vector3f X = Vector3f::UnitX(), Y = Vector3f::UnitY(), Z = Vector3f::UnitZ();
  d.push_back({"TorsoMesh",
               Vector3f::Zero(),
               Y,
               X,
               Z,
               TorsoProfile(),
               26,
               0.06f,
               0.05f,
               5,
               32,
               {{"Hips", 0}, {"Spine", 1.10f}, {"Spine1", 1.22f}, {"Spine2", 1.34f}},
               0.04f});
  d.push_back({"NeckMesh",
               Vector3f::Zero(),
               Y,
               X,
               Z,
               {{1.44f, 0.05f, 0.05f}, {1.62f, 0.045f, 0.045f}},
               8,
               0.02f,
               0.02f,
               2,
               16,
               {{"Spine2", 0}, {"Neck", 1.50f}, {"Head", 1.60f}},
               0.03f});
  d.push_back({"HeadMesh",
               Vector3f(kHeadCenter.x(), 0.0f, kHeadCenter.z()),
               Y,
               X,
               Z,
               {{kHeadCenter.y(), kHeadSemiAxes.x(), kHeadSemiAxes.z()}},
               1,
               kHeadSemiAxes.y(),
               kHeadSemiAxes.y(),
               9,
               24,
               {{"Head", 0}},
               0.02f});
}

// One arm, to +X (side 1) or -X (side -1), with its hand.
void AddArmPiece(float side, std::vector<PieceDef>& d) {
  const Vector3f X = Vector3f::UnitX(), Y = Vector3f::UnitY(), Z = Vector3f::UnitZ();
  const bool left = side > 0;
  // Arm tube along ±X: u = Z carries the hand's width, v = Y its thickness.
  d.push_back({left ? "LeftArmMesh" : "RightArmMesh",
               Vector3f(0, 1.44f, 0),
               side * X,
               Z,
               Y,
               {{kArm + 0.03f, 0.055f, 0.055f},
                {kArm + 0.14f, 0.05f, 0.05f},
                {kArm + 0.27f, 0.04f, 0.04f},
                {kArm + 0.40f, 0.037f, 0.037f},
                {kArm + 0.51f, 0.03f, 0.028f},
                {kArm + 0.55f, 0.045f, kHandHalfThickness},
                {kArm + 0.66f, 0.045f, kHandHalfThickness}},
               28,
               0.03f,
               0.04f,
               3,
               16,
               {{left ? "LeftShoulder" : "RightShoulder", 0},
                {left ? "LeftArm" : "RightArm", kArm + 0.04f},
                {left ? "LeftForeArm" : "RightForeArm", kArm + 0.27f},
                {left ? "LeftHand" : "RightHand", kArm + 0.52f}},
               0.03f});
}

// One leg and its foot, at +X (side 1) or -X (side -1).
void AddLegPieces(float side, std::vector<PieceDef>& d) {
  const Vector3f X = Vector3f::UnitX(), Y = Vector3f::UnitY(), Z = Vector3f::UnitZ();
  const bool left = side > 0;
  d.push_back({left ? "LeftLegMesh" : "RightLegMesh",
               Vector3f(side * 0.10f, 0, 0),
               -Y,
               X,
               Z,
               {{-0.97f, 0.075f, 0.075f},
                {-0.75f, 0.065f, 0.065f},
                {-0.52f, 0.047f, 0.047f},
                {-0.35f, 0.045f, 0.045f},
                {-0.10f, 0.035f, 0.035f}},
               28,
               0.04f,
               0.035f,
               3,
               16,
               {{"Hips", 0},
                {left ? "LeftUpLeg" : "RightUpLeg", -0.93f},
                {left ? "LeftLeg" : "RightLeg", -0.52f},
                {left ? "LeftFoot" : "RightFoot", -0.10f}},
               0.04f});
  d.push_back({left ? "LeftFootMesh" : "RightFootMesh",
               Vector3f(side * 0.10f, 0.045f, 0),
               Z,
               X,
               Y,
               {{-0.02f, 0.045f, 0.04f}, {0.08f, 0.045f, 0.035f}, {0.16f, 0.04f, 0.025f}},
               10,
               0.04f,
               0.05f,
               3,
               12,
               {{left ? "LeftFoot" : "RightFoot", 0}, {left ? "LeftToeBase" : "RightToeBase", 0.12f}},
               0.03f});
}

std::vector<PieceDef> PieceDefs() {
  std::vector<PieceDef> d;
  AddTrunkPieces(d);
  for (const float side : {1.0f, -1.0f}) AddArmPiece(side, d);
  for (const float side : {1.0f, -1.0f}) AddLegPieces(side, d);
  return d;
}

// ---------------------------------------------------------------------------------------------
// Clips

std::vector<Mat4f> RestWorld(const skinning::Skeleton& sk) {
  std::vector<Mat4f> w(sk.size());
  sk.RestWorld(w);
  return w;
}

JointTrack RotationTrack(int32_t joint, std::vector<float> times, std::vector<Quatf> values,
                         Interpolation interp = Interpolation::kLinear) {
  JointTrack t;
  t.joint = joint;
  t.rotation.interpolation = interp;
  t.rotation.times_s = std::move(times);
  t.rotation.values = std::move(values);
  return t;
}

skinning::AnimationClip MakeWalk(const skinning::Skeleton& sk) {
  skinning::AnimationClip clip;
  clip.name = "walk";
  clip.duration_s = kWalkDuration_s;
  constexpr int kKeys = 9;  // every 0.125 s, last = first
  std::vector<float> times;
  for (int k = 0; k < kKeys; ++k) times.push_back(kWalkDuration_s * static_cast<float>(k) / (kKeys - 1));
  auto track = [&](const char* joint, auto&& fn) {
    std::vector<Quatf> v;
    for (int k = 0; k < kKeys; ++k) {
      const float ph = 2.0f * kPi * static_cast<float>(k % (kKeys - 1)) / (kKeys - 1);  // exact loop
      v.push_back(fn(ph).normalized());
    }
    clip.tracks.push_back(RotationTrack(sk.Find(joint), times, v));
  };
  // Thighs: Rx(-) swings the leg forward (+Z). Left leg forward at phase π/2.
  track("LeftUpLeg", [](float ph) { return Rx(-25.0f * std::sin(ph)); });
  track("RightUpLeg", [](float ph) { return Rx(25.0f * std::sin(ph)); });
  // Knees bend (shin back, Rx(+)) while the leg swings forward.
  track("LeftLeg", [](float ph) { return Rx(5.0f + 40.0f * std::pow(std::max(0.0f, std::cos(ph)), 2.0f)); });
  track("RightLeg", [](float ph) { return Rx(5.0f + 40.0f * std::pow(std::max(0.0f, -std::cos(ph)), 2.0f)); });
  track("LeftFoot", [](float ph) { return Rx(10.0f * std::sin(ph)); });
  track("RightFoot", [](float ph) { return Rx(-10.0f * std::sin(ph)); });
  // Arms lowered 75° then swung about X opposite to the legs; elbows slightly bent forward.
  track("LeftArm", [](float ph) { return Rx(20.0f * std::sin(ph)) * Rz(-75.0f); });
  track("RightArm", [](float ph) { return Rx(-20.0f * std::sin(ph)) * Rz(75.0f); });
  track("LeftForeArm", [](float ph) { return Ry(-(20.0f + 10.0f * std::sin(ph))); });
  track("RightForeArm", [](float ph) { return Ry(20.0f - 10.0f * std::sin(ph)); });
  track("Spine", [](float ph) { return Ry(5.0f * std::sin(ph)); });
  track("Spine2", [](float ph) { return Ry(-3.0f * std::sin(ph)) * Rx(3.0f); });
  // Hips bob: y = 1 + 0.015 cos(2·phase), highest when the legs pass each other. CUBICSPLINE with
  // exact derivative tangents (units per second; glTF scales them by the key interval).
  JointTrack hips;
  hips.joint = sk.Find("Hips");
  hips.translation.interpolation = Interpolation::kCubicSpline;
  hips.translation.times_s = times;
  for (int k = 0; k < kKeys; ++k) {
    const float ph = 2.0f * kPi * static_cast<float>(k % (kKeys - 1)) / (kKeys - 1);
    const float omega = 2.0f * 2.0f * kPi / kWalkDuration_s;
    const Vector3f tangent(0.0f, -0.015f * omega * std::sin(2.0f * ph), 0.0f);
    hips.translation.values.push_back(tangent);  // in
    hips.translation.values.push_back(Vector3f(0.0f, 1.0f + 0.015f * std::cos(2.0f * ph), 0.0f));
    hips.translation.values.push_back(tangent);  // out
  }
  clip.tracks.push_back(hips);
  return clip;
}

// Analytic two-bone IK for one arm: local rotations of {Arm, ForeArm, Hand} (parents' world
// rotations are the rest ones, i.e. identity) so that the wrist lands on `wrist`, the elbow bends
// toward `pole`, the hand points along `hand_dir` and its thickness axis (local Y) along
// `palm_back` (the palm, local -Y, faces -palm_back).
std::array<Quatf, 3> SolveArm(const Vector3f& shoulder, float l1, float l2, float side, const Vector3f& wrist,
                              const Vector3f& pole, const Vector3f& hand_dir, const Vector3f& palm_back) {
  const Vector3f sw = wrist - shoulder;
  const float d = std::min(sw.norm(), 0.999f * (l1 + l2));
  const Vector3f n = sw.normalized();
  const float cos_a = std::clamp((l1 * l1 + d * d - l2 * l2) / (2.0f * l1 * d), -1.0f, 1.0f);
  const Vector3f p = (pole - pole.dot(n) * n).normalized();
  const Vector3f elbow = shoulder + l1 * (cos_a * n + std::sqrt(1.0f - cos_a * cos_a) * p);
  const Vector3f target = shoulder + d * n;
  // Frame columns: x along the bone (the rest bone points along side·X, so the rest frame's x is
  // side·X: we build frames for the rest direction side·X and express them relative to it).
  auto frame = [](const Vector3f& x, const Vector3f& z_hint) {
    Matrix3f f;
    const Vector3f z = (z_hint - z_hint.dot(x) * x).normalized();
    f.col(0) = x;
    f.col(1) = z.cross(x);
    f.col(2) = z;
    return f;
  };
  const Vector3f u1 = (elbow - shoulder).normalized(), u2 = (target - elbow).normalized();
  const Vector3f h = hand_dir.normalized();
  // World frames with x = bone direction. Upper arm and forearm share the bend axis (y).
  const Matrix3f f1 = frame(u1, u2);
  Matrix3f f2;
  f2.col(0) = u2;
  f2.col(1) = f1.col(1);
  f2.col(2) = u2.cross(f1.col(1));
  // Hand: y along palm_back; z completes.
  Matrix3f f3;
  f3.col(0) = h;
  f3.col(1) = (palm_back - palm_back.dot(h) * h).normalized();
  f3.col(2) = h.cross(f3.col(1));
  // Rest frame of a side's bones: x = side·X, y = Y, z = side·Z (a proper rotation of the world
  // axes by 180° about Y on the right side). World rotation R = F · Rest^-1.
  Matrix3f rest = Matrix3f::Identity();
  rest(0, 0) = side;
  rest(2, 2) = side;
  // For the right side the rest frame maps x->-X; its thickness axis is still +Y.
  const Matrix3f r1 = f1 * rest.transpose();
  const Matrix3f r2 = f2 * rest.transpose();
  const Matrix3f r3 = f3 * rest.transpose();
  // The bend-axis convention above can flip y; the bone direction is what matters for f1/f2,
  // but f3's y must be palm_back, which holds by construction.
  return {Quatf(r1).normalized(), Quatf(Matrix3f(r1.transpose() * r2)).normalized(),
          Quatf(Matrix3f(r2.transpose() * r3)).normalized()};
}

// Half-depth of the torso surface at (x, y): z of the front surface point.
float ChestFrontZ(float x, float y) {
  const ProfileKey k = ProfileAt(TorsoProfile(), y);
  const float q = x / k.a;
  return k.b * std::sqrt(std::max(0.0f, 1.0f - q * q));
}

skinning::AnimationClip MakeTouch(const skinning::Skeleton& sk) {
  const std::vector<Mat4f> world = RestWorld(sk);
  skinning::AnimationClip clip;
  clip.name = "touch";
  clip.duration_s = kTouchDuration_s;
  // The hands first come to a spot in front of the chest, so that on the way they pass in front of
  // the body, never through it.
  const std::vector<float> times = {0.0f,
                                    0.5f * kTouchChestBegin_s,
                                    kTouchChestBegin_s,
                                    kTouchChestEnd_s,
                                    kTouchHeadBegin_s,
                                    kTouchHeadEnd_s,
                                    kTouchDuration_s};
  for (const float side : {1.0f, -1.0f}) {
    const std::string s = side > 0 ? "Left" : "Right";
    const int32_t arm = sk.Find(s + "Arm"), fore = sk.Find(s + "ForeArm"), hand = sk.Find(s + "Hand");
    const Vector3f shoulder = world[arm].topRightCorner<3, 1>();
    const float l1 = sk.rest_local[fore].translation.norm(), l2 = sk.rest_local[hand].translation.norm();
    // Chest: palm centre a little inside the front surface; the two hands at different heights
    // so they do not overlap each other. Fingers point to the midline and slightly inward.
    const float y_chest = side > 0 ? 1.32f : 1.21f, x_chest = side * 0.085f;
    const Vector3f hand_dir_chest = Vector3f(-side, 0.0f, -0.2f).normalized();
    const float inside = 0.008f;
    const Vector3f chest_center(x_chest, y_chest, ChestFrontZ(x_chest, y_chest) + kHandHalfThickness - inside);
    const Vector3f chest_wrist = chest_center - kHandCenterOffset * hand_dir_chest;
    const auto chest = SolveArm(shoulder, l1, l2, side, chest_wrist, Vector3f(side * 0.6f, -1.0f, -0.3f),
                                hand_dir_chest, Vector3f::UnitZ());
    const auto approach = SolveArm(shoulder, l1, l2, side, Vector3f(side * kArm, y_chest, kTouchApproach),
                                   Vector3f(side * 0.6f, -1.0f, -0.3f), hand_dir_chest, Vector3f::UnitZ());
    // Head: palms on the sides of the head, fingers up.
    const Vector3f hand_dir_head = Vector3f(-side * 0.1f, 1.0f, 0.0f).normalized();
    const float y_head = kHeadCenter.y() + 0.01f, z_head = kHeadCenter.z() + 0.01f;
    const float ry = (y_head - kHeadCenter.y()) / kHeadSemiAxes.y(),
                rz = (z_head - kHeadCenter.z()) / kHeadSemiAxes.z();
    const float x_surface = kHeadSemiAxes.x() * std::sqrt(1.0f - ry * ry - rz * rz);
    const Vector3f head_center(side * (x_surface + kHandHalfThickness - inside), y_head, z_head);
    const Vector3f head_wrist = head_center - kHandCenterOffset * hand_dir_head;
    const auto head = SolveArm(shoulder, l1, l2, side, head_wrist, Vector3f(side * 1.0f, 0.0f, 0.6f), hand_dir_head,
                               Vector3f(side, 0.0f, 0.0f));
    const Quatf id = Quatf::Identity();
    const int32_t joints[3] = {arm, fore, hand};
    for (int b = 0; b < 3; ++b) {
      clip.tracks.push_back(
          RotationTrack(joints[b], times, {id, approach[b], chest[b], chest[b], head[b], head[b], id}));
    }
  }
  // A STEP track on a joint no vertex depends on (exercises STEP in readers and the exporter).
  clip.tracks.push_back(RotationTrack(sk.Find("HeadTop_End"), {0.0f, 2.0f, kTouchDuration_s},
                                      {Quatf::Identity(), Ry(10.0f), Ry(10.0f)}, Interpolation::kStep));
  return clip;
}

}  // namespace

RawCharacter MakeBuiltinCharacter() {
  RawCharacter c;
  c.source_file = "<builtin>";
  c.skeleton = MakeSkeleton();
  const std::vector<Mat4f> world = RestWorld(c.skeleton);

  MeshBuilder mb;
  for (const PieceDef& p : PieceDefs()) AddPiece(p, c.skeleton, mb);

  // Skin: one bind entry per joint, IBM = rest world^-1, so bind space = world rest space.
  skinning::SkinnedMesh& skin = c.skin;
  for (size_t j = 0; j < c.skeleton.size(); ++j) {
    skinning::BindEntry b;
    b.joint = static_cast<int32_t>(j);
    b.inverse_bind = world[j].inverse();
    skin.binds.push_back(b);
  }
  skin.positions_bind = mb.positions;
  skin.influence_offsets.push_back(0);
  for (const auto& inf : mb.influences) {
    for (const auto& [joint, w] : inf) {
      skin.influence_binds.push_back(static_cast<uint16_t>(joint));  // bind index == joint index
      skin.influence_weights.push_back(w);
    }
    skin.influence_offsets.push_back(static_cast<uint32_t>(skin.influence_binds.size()));
  }
  // positions_rest = LBS at rest: Σ w_k · G_j · IBM_k · p_bind.
  c.positions_rest.resize(mb.positions.size());
  for (size_t v = 0; v < mb.positions.size(); ++v) {
    Vec4f acc = Vec4f::Zero();
    const Vec4f p = mb.positions[v].homogeneous();
    for (uint32_t k = skin.influence_offsets[v]; k < skin.influence_offsets[v + 1]; ++k) {
      const skinning::BindEntry& b = skin.binds[skin.influence_binds[k]];
      acc += skin.influence_weights[k] * (world[b.joint] * b.inverse_bind * p);
    }
    c.positions_rest[v] = acc.head<3>();
  }
  c.triangles = mb.triangles;
  c.meshes = mb.meshes;
  c.clips.push_back(MakeWalk(c.skeleton));
  c.clips.push_back(MakeTouch(c.skeleton));
  return c;
}

}  // namespace skinspheres::lib
