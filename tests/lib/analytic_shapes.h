// Analytic test shapes as RawCharacters with a straight two-joint skeleton along +Y, and the
// matching one-part BodyParts, for fitter tests.
#pragma once

#include <cmath>
#include <numbers>

#include "shapes/uv_sphere.h"
#include "skinspheres/lib/body_parts/body_parts.h"
#include "skinspheres/lib/character/raw_character.h"
#include "skinspheres/skinning/math_types.h"

namespace skinspheres::test {

// A closed tube along +Y from y0 to y1 whose section at angle φ is (a cos φ, b sin φ) (a = b: a
// cylinder), capped with fans; `rings` sections, `segments` around.
inline lib::RawCharacter EllipticPrism(float a, float b, float y0, float y1, int rings = 24, int segments = 48) {
  lib::RawCharacter ch;
  ch.source_file = "prism";
  for (int r = 0; r < rings; ++r) {
    const float y = y0 + (y1 - y0) * r / static_cast<float>(rings - 1);
    for (int s = 0; s < segments; ++s) {
      const float phi = 2.0f * std::numbers::pi_v<float> * s / segments;
      ch.positions_rest.emplace_back(a * std::cos(phi), y, b * std::sin(phi));
    }
  }
  const int bottom = static_cast<int>(ch.positions_rest.size());
  ch.positions_rest.emplace_back(0.0f, y0, 0.0f);
  ch.positions_rest.emplace_back(0.0f, y1, 0.0f);
  for (int r = 0; r + 1 < rings; ++r) {
    for (int s = 0; s < segments; ++s) {
      const int i0 = r * segments + s, i1 = r * segments + (s + 1) % segments;
      ch.triangles.emplace_back(i0, i1 + segments, i1);
      ch.triangles.emplace_back(i0, i0 + segments, i1 + segments);
    }
  }
  for (int s = 0; s < segments; ++s) {
    ch.triangles.emplace_back(bottom, s, (s + 1) % segments);
    const int top = (rings - 1) * segments;
    ch.triangles.emplace_back(bottom + 1, top + (s + 1) % segments, top + s);
  }
  return ch;
}

// A UV sphere of radius r around c, poles on the Y axis, each pole a ring of coincident vertices
// (so each polar band has `slices` degenerate triangles, on purpose).
inline lib::RawCharacter SphereMesh(float r, const Eigen::Vector3f& c, int stacks = 24, int slices = 48) {
  const TriangleMesh m = UvSphere(c, r, stacks, slices, /*pole_axis=*/1, Poles::kRingOfCopies);
  lib::RawCharacter ch;
  ch.source_file = "sphere";
  ch.positions_rest = m.positions;
  ch.triangles = m.triangles;
  return ch;
}

// Gives a shape a two-joint skeleton (y0 -> y1 on the Y axis), rigid skin on joint 0, and one
// part of the given kind holding every triangle.
inline lib::BodyParts MakeSinglePart(lib::RawCharacter& ch, float y0, float y1, lib::PartKind kind) {
  ch.skeleton.joint_names = {"a", "b"};
  ch.skeleton.parents = {-1, 0};
  ch.skeleton.rest_local.resize(2);
  ch.skeleton.rest_local[0].translation = Eigen::Vector3f(0, y0, 0);
  ch.skeleton.rest_local[1].translation = Eigen::Vector3f(0, y1 - y0, 0);
  ch.skin.positions_bind = ch.positions_rest;
  ch.skin.binds = {{0, skinspheres::Mat4f::Identity()}};  // rest world of joint 0: a translation by y0
  ch.skin.binds[0].inverse_bind(1, 3) = -y0;
  ch.skin.influence_offsets.clear();
  for (size_t v = 0; v <= ch.positions_rest.size(); ++v) ch.skin.influence_offsets.push_back(static_cast<uint32_t>(v));
  ch.skin.influence_binds.assign(ch.positions_rest.size(), 0);
  ch.skin.influence_weights.assign(ch.positions_rest.size(), 1.0f);
  lib::BodyParts parts;
  lib::BodyPart part;
  part.name = kind == lib::PartKind::kTorso ? "torso" : "chain_0";
  part.kind = kind;
  part.joints = {0, 1};
  part.chain = {0, 1};
  for (uint32_t t = 0; t < ch.triangles.size(); ++t) part.triangles.push_back(t);
  parts.parts = {part};
  parts.joint_part = {0, 0};
  parts.triangle_part.assign(ch.triangles.size(), 0);
  parts.triangle_joint.assign(ch.triangles.size(), 0);
  parts.humanoid = false;
  return parts;
}

}  // namespace skinspheres::test
