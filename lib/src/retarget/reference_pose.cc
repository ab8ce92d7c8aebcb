// Reference poses (retarget_stages.h): the target's bind pose, the source's rest pose from the
// SourceRest the caller gives, and world poses of local transforms.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "retarget_stages.h"
#include "skinspheres/lib/retarget/bake_clip.h"
#include "skinspheres/skinning/sampling_job.h"

namespace skinspheres::lib {

namespace {

// The transform C that takes the skin's bind space to the world (C_j = G_j(rest) · IBM_j for
// every bound joint j that stands at rest as at bind): the value most bound joints share (within
// 1e-3 of its largest entry), when at least half of them share it; else the identity (a rest pose
// that is not the bind pose: the bind space is taken as the world). CesiumMan's skin is bound in
// its Z-up mesh space: C turns it to Y-up.
Mat4f BindSpaceToWorld(const std::vector<Mat4f>& c) {
  size_t best = 0, best_count = 0;
  for (size_t k = 0; k < c.size(); ++k) {
    const float tolerance = 1e-3f * std::max(1.0f, c[k].cwiseAbs().maxCoeff());
    size_t count = 0;
    for (const Mat4f& other : c) count += (other - c[k]).cwiseAbs().maxCoeff() <= tolerance ? 1 : 0;
    if (count > best_count) best = k, best_count = count;
  }
  if (best_count == 0 || 2 * best_count < c.size() || !c[best].allFinite()) return Mat4f::Identity();
  return c[best];
}

}  // namespace

std::vector<Mat4f> BindPoseWorld(const RawCharacter& character) {
  const skinning::Skeleton& s = character.skeleton;
  std::vector<Mat4f> rest(s.size()), world(s.size(), Mat4f::Identity());
  s.RestWorld(rest);
  std::vector<char> bound(s.size(), 0);
  std::vector<Mat4f> discrepancy;
  for (const skinning::BindEntry& b : character.skin.binds) {
    const size_t j = static_cast<size_t>(b.joint);
    if (b.joint < 0 || j >= s.size() || bound[j]) continue;
    const float det = b.inverse_bind.topLeftCorner<3, 3>().determinant();
    if (!(std::abs(det) > 0.0f) || !std::isfinite(det) || !b.inverse_bind.allFinite()) continue;
    world[j] = b.inverse_bind.inverse();
    discrepancy.push_back(rest[j] * b.inverse_bind);
    bound[j] = 1;
  }
  const Mat4f to_world = BindSpaceToWorld(discrepancy);
  for (size_t j = 0; j < s.size(); ++j) {
    if (bound[j]) {
      world[j] = to_world * world[j];
      continue;
    }
    const Mat4f local = s.rest_local[j].ToMatrix();
    world[j] = s.parents[j] < 0 ? local : Mat4f(world[static_cast<size_t>(s.parents[j])] * local);
  }
  return world;
}

namespace retarget {

void PoseOf(const skinning::Skeleton& skeleton, std::span<const skinning::Transform> locals, WorldPose* out,
            std::vector<Mat4f>* scratch) {
  const size_t n = skeleton.size();
  out->rotation.resize(n);
  out->position.resize(n);
  scratch->resize(n);
  std::vector<Mat4f>& world = *scratch;
  for (size_t j = 0; j < n; ++j) {
    const int32_t p = skeleton.parents[j];
    const Mat4f local = locals[j].ToMatrix();
    const Quatf q = locals[j].rotation.normalized();
    world[j] = p < 0 ? local : Mat4f(world[static_cast<size_t>(p)] * local);
    out->rotation[j] = p < 0 ? q : Quatf((out->rotation[static_cast<size_t>(p)] * q).normalized());
    out->position[j] = world[j].topRightCorner<3, 1>();
  }
}

WorldPose TargetReference(const RawCharacter& target) {
  const std::vector<Mat4f> world = BindPoseWorld(target);
  WorldPose pose;
  for (const Mat4f& w : world) {
    pose.rotation.push_back(skinning::Transform::FromMatrix(w).rotation);
    pose.position.push_back(w.topRightCorner<3, 1>());
  }
  return pose;
}

namespace {

// kRig: each matched node with a counterpart in the rig takes the rotation of that joint's bind pose
// relative to its parent in the rig; translations and scales stay the file's (its units).
std::optional<Error> RigRotations(const SourceRig& source, const RawCharacter& rig, const Correspondence& c,
                                  std::vector<skinning::Transform>* locals) {
  const std::vector<Mat4f> world = BindPoseWorld(rig);
  std::map<std::string, std::vector<int32_t>> by_key;
  for (size_t r = 0; r < rig.skeleton.size(); ++r)
    by_key[MatchKey(rig.skeleton.joint_names[r])].push_back(static_cast<int32_t>(r));
  size_t found = 0;
  for (size_t n = 0; n < source.nodes.size(); ++n) {
    if (c.joint_of[n] < 0) continue;  // unmatched nodes (an armature above the rig) keep the file's transform
    int32_t r = rig.skeleton.Find(source.nodes.joint_names[n]);
    if (r < 0) {
      const auto it = by_key.find(MatchKey(source.nodes.joint_names[n]));
      if (it == by_key.end() || it->second.size() != 1) continue;
      r = it->second.front();
    }
    const int32_t pr = rig.skeleton.parents[static_cast<size_t>(r)];
    const Mat4f relative = pr < 0 ? world[static_cast<size_t>(r)]
                                  : Mat4f(world[static_cast<size_t>(pr)].inverse() * world[static_cast<size_t>(r)]);
    (*locals)[n].rotation = skinning::Transform::FromMatrix(relative).rotation;
    ++found;
  }
  if (found == 0) {
    return MakeError(ErrorCode::kInvalidArgument, source.source_file + ": none of its joints is named as a joint of " +
                                                      rig.Name() + " (the rest pose given for it)");
  }
  return std::nullopt;
}

}  // namespace

Result<WorldPose> SourceReference(const SourceRig& source, const SourceRest& rest, const Correspondence& c,
                                  size_t clip) {
  std::vector<skinning::Transform> locals = source.nodes.rest_local;
  switch (rest.kind) {
    case SourceRest::Kind::kNone: return MakeError(ErrorCode::kInvalidArgument, source.source_file + ": no rest pose");
    case SourceRest::Kind::kNodes: break;
    case SourceRest::Kind::kIdentity:
      for (size_t n = 0; n < locals.size(); ++n) {
        if (c.joint_of[n] >= 0) locals[n].rotation = Quatf::Identity();
      }
      break;
    case SourceRest::Kind::kTime: {
      const skinning::AnimationClip& a = source.clips.at(clip);
      std::string why;
      if (!skinning::ValidateClip(a, source.nodes, &why)) {
        return MakeError(ErrorCode::kInvalidData, source.source_file + ": clip \"" + a.name + "\": " + why);
      }
      // Past the clip's end the sampler would hold its last key: a pose nobody chose (refused,
      // never a silent guess). A frame counts at rest.fps; a thousandth of one is float slack.
      const bool past_end = rest.fps > 0.0f ? double(rest.time_s) * rest.fps > double(a.duration_s) * rest.fps + 1e-3
                                            : rest.time_s > a.duration_s * (1.0f + 1e-6f) + 1e-6f;
      if (past_end) {
        char seconds[32];
        std::snprintf(seconds, sizeof seconds, "%.4g s long", static_cast<double>(a.duration_s));
        std::string end = seconds;
        if (rest.fps > 0.0f) {
          end += ", its last frame is " + std::to_string(static_cast<int64_t>(FramesAt(a.duration_s, rest.fps) - 1.0)) +
                 " at " + std::to_string(static_cast<int>(std::lround(rest.fps))) + " fps";
        }
        return MakeError(
            ErrorCode::kInvalidArgument,
            source.source_file + ": " + rest.label + " lies past the end of clip \"" + a.name + "\" (" + end + ")");
      }
      if (!skinning::SamplingJob{&a, &source.nodes, rest.time_s, locals}.Run()) {
        return MakeError(ErrorCode::kInvalidData, source.source_file + ": clip \"" + a.name +
                                                      "\" cannot be sampled at t=" + std::to_string(rest.time_s));
      }
      break;
    }
    case SourceRest::Kind::kRig:
      if (rest.rig == nullptr) return MakeError(ErrorCode::kInvalidArgument, source.source_file + ": no rest pose");
      if (auto bad = RigRotations(source, *rest.rig, c, &locals)) return *bad;
      break;
  }
  WorldPose pose;
  std::vector<Mat4f> scratch;
  PoseOf(source.nodes, locals, &pose, &scratch);
  return pose;
}

}  // namespace retarget
}  // namespace skinspheres::lib
