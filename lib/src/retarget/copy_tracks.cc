// The same rig (retarget_stages.h, CopyTracks): tracks copied as local transforms, translation
// tracks scaled per joint when the two files' units differ.
#include <algorithm>
#include <cmath>
#include <set>

#include "retarget_stages.h"

namespace skinspheres::lib::retarget {

std::vector<skinning::AnimationClip> CopyTracks(const SourceRig& source, const skinning::Skeleton& target,
                                                const Correspondence& c, RetargetReport* report) {
  // Per matched joint, the factor its translation tracks are scaled by (units of the two files).
  std::vector<float> translation_scale(target.size(), 1.0f);
  for (size_t j = 0; j < target.size(); ++j) {
    if (c.node_of[j] < 0) continue;
    const float from = source.nodes.rest_local[static_cast<size_t>(c.node_of[j])].translation.norm();
    const float to = target.rest_local[j].translation.norm();
    if (from > 0.0f && to > 0.0f && std::isfinite(to / from) && std::abs(to / from - 1.0f) > 1e-3f)
      translation_scale[j] = to / from;
  }
  std::set<std::string> rescaled;
  std::vector<skinning::AnimationClip> clips;
  for (const auto& in : source.clips) {
    skinning::AnimationClip clip;
    clip.name = in.name;
    clip.duration_s = in.duration_s;
    for (const auto& tr : in.tracks) {
      const size_t node = static_cast<size_t>(tr.joint);
      if (tr.joint < 0 || node >= source.nodes.size()) continue;
      const int32_t j = c.joint_of[node];
      if (j < 0) continue;
      skinning::JointTrack out = tr;
      out.joint = j;
      if (translation_scale[static_cast<size_t>(j)] != 1.0f && !out.translation.empty()) {
        for (auto& v : out.translation.values) v *= translation_scale[static_cast<size_t>(j)];
        rescaled.insert(target.joint_names[static_cast<size_t>(j)]);
      }
      clip.tracks.push_back(std::move(out));
    }
    std::sort(clip.tracks.begin(), clip.tracks.end(),
              [](const skinning::JointTrack& x, const skinning::JointTrack& y) { return x.joint < y.joint; });
    clips.push_back(std::move(clip));
  }
  report->rescaled_joints.assign(rescaled.begin(), rescaled.end());
  return clips;
}

}  // namespace skinspheres::lib::retarget
