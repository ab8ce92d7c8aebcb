// The glTF reader's animations (glTF 2.0 §3.11): every animation's channels on skeleton joints
// into clips, keeping the samplers' STEP/LINEAR/CUBICSPLINE interpolation (animation.sampler.schema.json).
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "importer_gltf_stages.h"

namespace skinspheres::lib::detail {
namespace {

using nlohmann::json;

// glTF 2.0 §3.11 (animation.sampler.schema.json): key times are >= 0 and strictly increasing;
// a CUBICSPLINE sampler has at least two keys. A sampler that breaks either refuses the file.
template <typename Value>
std::string FillTrack(skinning::Interpolation interpolation, const std::vector<float>& times,
                      const std::vector<Value>& values, skinning::Track<Value>* track) {
  const size_t per_key = interpolation == skinning::Interpolation::kCubicSpline ? 3 : 1;
  if (values.size() != times.size() * per_key) {
    return "a sampler has " + std::to_string(values.size()) + " output values for " + std::to_string(times.size()) +
           " key times";
  }
  if (per_key == 3 && times.size() < 2) return "a CUBICSPLINE sampler has fewer than two keys";
  for (size_t k = 0; k < times.size(); ++k) {
    if (!std::isfinite(times[k])) return "a sampler has a non-finite key time";
    if (k == 0 && times[k] < 0.0f) return "a sampler's first key time is negative (" + std::to_string(times[k]) + ")";
    if (k > 0 && !(times[k] > times[k - 1])) {
      return "a sampler's key times are not strictly increasing (key " + std::to_string(k) + ": " +
             std::to_string(times[k]) + " after " + std::to_string(times[k - 1]) + ")";
    }
  }
  track->interpolation = interpolation;
  track->times_s = times;
  track->values = values;
  return {};
}

}  // namespace

std::string ReadClips(const GltfDocument& doc, const std::vector<GltfNode>& nodes,
                      const std::vector<int32_t>& joint_of_node, std::vector<skinning::AnimationClip>* clips) {
  const json& anims = ArrayOrEmpty(doc.json, "animations");
  uint64_t keys = 0;  // over every clip and track, against kMaxAnimationKeys
  for (size_t a = 0; a < anims.size(); ++a) {
    const json& ja = anims[a];
    skinning::AnimationClip clip;
    clip.name = ja.value("name", std::string());
    if (clip.name.empty()) clip.name = "animation_" + std::to_string(a);
    const std::string where = "animation " + std::to_string(a) + " '" + clip.name + "'";
    const json& samplers = ArrayOrEmpty(ja, "samplers");
    std::map<int32_t, size_t> track_of_joint;
    std::set<std::pair<int64_t, std::string>> targets;
    for (const json& ch : ArrayOrEmpty(ja, "channels")) {
      if (!ch.contains("target")) continue;
      const json& target = ch["target"];
      const int64_t node = Integer(target, "node", -1);
      const std::string path = target.value("path", std::string());
      // glTF 2.0 §3.11: within one animation a target (node and path) MUST NOT appear twice, and
      // a node animated in translation, rotation or scale MUST NOT have a matrix.
      if (target.contains("node") && !targets.emplace(node, path).second) {
        return where + " animates node " + std::to_string(node) + " " + path + " twice";
      }
      if (node >= 0 && node < static_cast<int64_t>(nodes.size()) && nodes[static_cast<size_t>(node)].has_matrix &&
          (path == "translation" || path == "rotation" || path == "scale")) {
        return where + " animates the " + path + " of node " + std::to_string(node) + ", which has a matrix";
      }
      // Tracks on nodes outside the skeleton (cameras, props not carrying a mesh, nodes not on a
      // path to a joint) cannot move the character and are dropped, as are morph "weights".
      if (node < 0 || node >= static_cast<int64_t>(joint_of_node.size())) continue;
      const int32_t joint = joint_of_node[static_cast<size_t>(node)];
      if (joint < 0 || (path != "translation" && path != "rotation" && path != "scale")) continue;
      const int64_t s = Integer(ch, "sampler", -1);
      if (s < 0 || s >= static_cast<int64_t>(samplers.size())) return where + " has a channel with a bad sampler index";
      const json& js = samplers[static_cast<size_t>(s)];
      const std::string interp_name = js.value("interpolation", std::string("LINEAR"));
      skinning::Interpolation interpolation;
      if (interp_name == "LINEAR")
        interpolation = skinning::Interpolation::kLinear;
      else if (interp_name == "STEP")
        interpolation = skinning::Interpolation::kStep;
      else if (interp_name == "CUBICSPLINE")
        interpolation = skinning::Interpolation::kCubicSpline;
      else
        return where + " has an unknown interpolation \"" + interp_name + "\"";
      std::vector<float> times, out;
      if (std::string p = ReadAccessorFloats(doc, Integer(js, "input", -1), 1, &times); !p.empty())
        return where + ": " + p;
      const int components = path == "rotation" ? 4 : 3;
      if (std::string p = ReadAccessorFloats(doc, Integer(js, "output", -1), components, &out); !p.empty())
        return where + ": " + p;
      for (float v : out) {
        if (!std::isfinite(v)) return where + " has a non-finite " + path + " value";
      }
      keys += times.size();
      if (keys > kMaxAnimationKeys) {
        return "the animations hold more than " + std::to_string(kMaxAnimationKeys) +
               " keys (at most that many are read)";
      }
      auto [it, inserted] = track_of_joint.emplace(joint, clip.tracks.size());
      if (inserted) {
        clip.tracks.emplace_back();
        clip.tracks.back().joint = joint;
      }
      skinning::JointTrack& track = clip.tracks[it->second];
      std::string problem;
      if (path == "rotation") {
        std::vector<Quatf> q(out.size() / 4);
        for (size_t k = 0; k < q.size(); ++k) q[k] = Quatf(out[4 * k + 3], out[4 * k], out[4 * k + 1], out[4 * k + 2]);
        // A key of zero length is no rotation (the sampler would have to guess one); one too small
        // or too large for float normalisation is normalised in double (UsableRotation).
        // CUBICSPLINE tangents (the first and last of each triple) may be zero and stay as they are.
        const size_t per_key = interpolation == skinning::Interpolation::kCubicSpline ? 3 : 1;
        for (size_t k = per_key / 2; k < q.size(); k += per_key) {
          const auto unit = UsableRotation(q[k]);
          if (!unit) return where + " has a rotation key of zero length (key " + std::to_string(k / per_key) + ")";
          q[k] = *unit;
        }
        problem = FillTrack(interpolation, times, q, &track.rotation);
      } else {
        std::vector<Eigen::Vector3f> v(out.size() / 3);
        for (size_t k = 0; k < v.size(); ++k) v[k] = Eigen::Vector3f(out[3 * k], out[3 * k + 1], out[3 * k + 2]);
        problem = FillTrack(interpolation, times, v, path == "translation" ? &track.translation : &track.scale);
      }
      if (!problem.empty()) return where + ": " + problem;
      if (!times.empty()) clip.duration_s = std::max(clip.duration_s, times.back());
    }
    std::sort(clip.tracks.begin(), clip.tracks.end(),
              [](const skinning::JointTrack& x, const skinning::JointTrack& y) { return x.joint < y.joint; });
    clips->push_back(std::move(clip));
  }
  return {};
}

std::string ReadGltfClips(const GltfDocument& doc, const std::vector<int32_t>& joint_of_node,
                          std::vector<skinning::AnimationClip>* clips) {
  std::vector<GltfNode> nodes;  // which nodes have a matrix (a TRS channel on one is refused)
  if (std::string p = ReadNodes(doc.json, &nodes); !p.empty()) return p;
  return ReadClips(doc, nodes, joint_of_node, clips);
}

}  // namespace skinspheres::lib::detail
