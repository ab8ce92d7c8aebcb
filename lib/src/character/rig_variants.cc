// RotateJointFrames and ScaleBones (rig_variants.h).
#include "skinspheres/lib/character/rig_variants.h"

#include <Eigen/Geometry>
#include <cmath>
#include <random>

namespace skinspheres::lib {
namespace {

// A rotation of 30-150° about a random axis; the generator's raw output only (the standard
// distributions may differ between standard libraries).
Quatf RandomTurn(std::mt19937& rng) {
  auto unit = [&rng]() { return static_cast<float>(rng()) / 4294967296.0f; };
  Eigen::Vector3f axis;
  do {
    axis = Eigen::Vector3f(unit(), unit(), unit()) * 2.0f - Eigen::Vector3f::Ones();
  } while (!(axis.norm() > 0.1f) || axis.norm() > 1.0f);
  const float degrees = 30.0f + 120.0f * unit();
  return Quatf(Eigen::AngleAxisf(degrees * static_cast<float>(M_PI) / 180.0f, axis.normalized()));
}

bool Uniform(const Eigen::Vector3f& s) {
  return std::abs(s.x() - s.y()) <= 1e-5f * std::abs(s.x()) && std::abs(s.x() - s.z()) <= 1e-5f * std::abs(s.x());
}

}  // namespace

std::optional<Error> RotateJointFrames(RawCharacter& ch, uint32_t seed) {
  skinning::Skeleton& sk = ch.skeleton;
  for (const auto& t : sk.rest_local) {
    if (!Uniform(t.scale))
      return MakeError(ErrorCode::kInvalidArgument, ch.Name() + ": a joint has a non-uniform scale");
  }
  for (const auto& clip : ch.clips) {
    for (const auto& tr : clip.tracks) {
      for (const auto& s : tr.scale.values) {
        if (!Uniform(s))
          return MakeError(ErrorCode::kInvalidArgument,
                           ch.Name() + ": clip \"" + clip.name + "\" scales non-uniformly");
      }
    }
  }
  std::mt19937 rng(seed);
  std::vector<Quatf> turn(sk.size());
  for (auto& r : turn) r = RandomTurn(rng);
  auto parent_turn = [&](size_t j) {
    return sk.parents[j] < 0 ? Quatf(Quatf::Identity()) : turn[static_cast<size_t>(sk.parents[j])];
  };
  for (size_t j = 0; j < sk.size(); ++j) {
    const Quatf back = parent_turn(j).inverse();
    sk.rest_local[j].translation = back * sk.rest_local[j].translation;
    sk.rest_local[j].rotation = (back * sk.rest_local[j].rotation * turn[j]).normalized();
  }
  for (auto& clip : ch.clips) {
    for (auto& tr : clip.tracks) {
      if (tr.joint < 0 || static_cast<size_t>(tr.joint) >= sk.size()) continue;
      const size_t j = static_cast<size_t>(tr.joint);
      const Quatf back = parent_turn(j).inverse();
      for (auto& v : tr.translation.values) v = back * v;
      // q -> back · q · turn is linear in q's coefficients: keys and cubic tangents alike.
      for (auto& q : tr.rotation.values) q = Quatf(back * q * turn[j]);
    }
  }
  for (auto& b : ch.skin.binds) {
    if (b.joint < 0 || static_cast<size_t>(b.joint) >= sk.size()) continue;
    Mat4f undo = Mat4f::Identity();
    undo.topLeftCorner<3, 3>() = turn[static_cast<size_t>(b.joint)].inverse().toRotationMatrix();
    b.inverse_bind = undo * b.inverse_bind;
  }
  return std::nullopt;
}

void ScaleBones(RawCharacter& ch, float s) {
  for (auto& t : ch.skeleton.rest_local) t.translation *= s;
  for (auto& clip : ch.clips) {
    for (auto& tr : clip.tracks) {
      for (auto& v : tr.translation.values) v *= s;
    }
  }
  for (auto& p : ch.skin.positions_bind) p *= s;
  for (auto& p : ch.positions_rest) p *= s;
  for (auto& b : ch.skin.binds) b.inverse_bind.topRightCorner<3, 1>() *= s;
}

}  // namespace skinspheres::lib
