// RetargetClips (retarget.h): the stages of retarget_stages.h in order, and the report.
#include "skinspheres/lib/retarget/retarget.h"

#include <algorithm>
#include <set>

#include "retarget_stages.h"

namespace skinspheres::lib {
namespace {

using retarget::Correspondence;

// The target joints that move vertices: bind entries with a weight, rigid meshes' joints.
std::vector<char> DeformingJoints(const RawCharacter& c) {
  std::vector<char> deforming(c.skeleton.size(), 0);
  for (size_t k = 0; k < c.skin.influence_binds.size(); ++k) {
    if (c.skin.influence_weights[k] <= 0.0f || c.skin.influence_binds[k] >= c.skin.binds.size()) continue;
    const int32_t j = c.skin.binds[c.skin.influence_binds[k]].joint;
    if (j >= 0 && static_cast<size_t>(j) < deforming.size()) deforming[static_cast<size_t>(j)] = 1;
  }
  for (const auto& m : c.meshes) {
    if (!m.skinned && m.rigid_joint >= 0 && static_cast<size_t>(m.rigid_joint) < deforming.size()) {
      deforming[static_cast<size_t>(m.rigid_joint)] = 1;
    }
  }
  return deforming;
}

void ReportCorrespondence(const SourceRig& source, const RawCharacter& target, const Correspondence& c,
                          RetargetReport* report) {
  const std::vector<char> deforming = DeformingJoints(target);
  for (size_t j = 0; j < target.skeleton.size(); ++j) {
    if (c.node_of[j] >= 0) {
      report->mapped.emplace_back(static_cast<int32_t>(j), c.node_of[j]);
      continue;
    }
    ++report->unmapped_joints;
    if (deforming[j]) report->unmapped_deforming.push_back(target.skeleton.joint_names[j]);
  }
  std::set<std::string> dropped;
  for (const auto& clip : source.clips) {
    for (const auto& tr : clip.tracks) {
      const size_t node = static_cast<size_t>(tr.joint);
      if (tr.joint < 0 || node >= source.nodes.size() || c.joint_of[node] >= 0) continue;
      if (!tr.translation.empty() || !tr.rotation.empty() || !tr.scale.empty())
        dropped.insert(source.nodes.joint_names[node]);
    }
  }
  report->dropped_nodes.assign(dropped.begin(), dropped.end());
}

Error NoRestPose(const SourceRig& source, const RawCharacter& target, const std::string& differs_at) {
  return MakeError(ErrorCode::kInvalidArgument,
                   source.source_file + ": made for another rig than " + target.Name() + " (the bone offset of " +
                       differs_at + " differs) and the file has no rest pose of its own (no skin): give " +
                       "--source-rest RIG (a skinned file of the rig the clip was made for), --source-rest FRAME (a " +
                       "frame of the clip in that rig's rest pose), --source-rest nodes (the file's node " +
                       "transforms are its rest pose) or --source-rest identity (its joints' rest rotations are " +
                       "the identity)");
}

}  // namespace

const char* ToString(RetargetMode mode) {
  switch (mode) {
    case RetargetMode::kAuto: return "auto";
    case RetargetMode::kCopy: return "copy";
    case RetargetMode::kWorld: return "world";
  }
  return "?";
}

Result<std::vector<skinning::AnimationClip>> RetargetClips(const SourceRig& source, const RawCharacter& target,
                                                           const RetargetOptions& options, RetargetReport* report) {
  RetargetReport local;
  RetargetReport& rep = report != nullptr ? *report : local;
  rep = RetargetReport{};
  if (source.clips.empty()) return MakeError(ErrorCode::kNotFound, source.source_file + ": has no animations");
  auto c = retarget::MatchJoints(source, target, options.joint_map);
  if (!c.ok()) return c.error();
  const retarget::CoreJoints core = retarget::FindCoreJoints(target, options.target_parts);
  if (auto refused = retarget::CheckCoreJoints(core, *c, source, target)) return *refused;
  ReportCorrespondence(source, target, *c, &rep);
  const int32_t root = retarget::RootMotionJoint(core, *c, target.skeleton);
  const int32_t differs = retarget::FirstOffsetDifference(source, target.skeleton, *c, root);
  if (differs >= 0) rep.offsets_differ_at = target.skeleton.joint_names[static_cast<size_t>(differs)];
  if (options.mode == RetargetMode::kCopy || (options.mode == RetargetMode::kAuto && differs < 0)) {
    return retarget::CopyTracks(source, target.skeleton, *c, &rep);
  }
  if (options.source_rest.kind == SourceRest::Kind::kNone) {
    return NoRestPose(source, target, differs >= 0 ? rep.offsets_differ_at : std::string("no joint"));
  }
  rep.transferred = true;
  rep.rest_directions_matched = options.match_rest_directions;
  rep.rest_from = options.source_rest.label;
  rep.root_joint = root >= 0 ? target.skeleton.joint_names[static_cast<size_t>(root)] : "";
  const retarget::WorldPose target_rest = retarget::TargetReference(target);
  retarget::AlignmentSettings settings;
  settings.parts = options.target_parts;
  settings.aligning = retarget::AligningJoints(target, options.target_parts, core);
  settings.root_joint = root;
  settings.match_directions = options.match_rest_directions;
  std::vector<skinning::AnimationClip> clips;
  for (size_t k = 0; k < source.clips.size(); ++k) {
    auto source_rest = retarget::SourceReference(source, options.source_rest, *c, k);
    if (!source_rest.ok()) return source_rest.error();
    const retarget::Alignment alignment =
        retarget::AlignRestPoses(*source_rest, target_rest, *c, target, settings, &rep);
    auto clip = retarget::TransferClip(source, k, target, *c, *source_rest, target_rest, alignment, root);
    if (!clip.ok()) return clip.error();
    clips.push_back(std::move(*clip));
  }
  return clips;
}

}  // namespace skinspheres::lib
