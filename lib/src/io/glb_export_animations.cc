// The GLB exporter's animations (glb_export_stages.h): every clip baked to LINEAR keys (the only
// interpolation Assimp's glTF writer emits), and the extras' spheres' channels.
#include <Eigen/Geometry>
#include <algorithm>
#include <map>
#include <type_traits>
#include <utility>

#include "glb_export_stages.h"

namespace skinspheres::lib::detail {
namespace {

using Eigen::Vector3f;
using skinning::Interpolation;

template <typename V>
V CubicValue(const skinning::Track<V>& tr, size_t i, float u) {
  const float dt = tr.times_s[i + 1] - tr.times_s[i];
  const float u2 = u * u, u3 = u2 * u;
  const float h00 = 2 * u3 - 3 * u2 + 1, h10 = u3 - 2 * u2 + u, h01 = -2 * u3 + 3 * u2, h11 = u3 - u2;
  if constexpr (std::is_same_v<V, Quatf>) {
    const Vec4f c = h00 * tr.values[3 * i + 1].coeffs() + h10 * dt * tr.values[3 * i + 2].coeffs() +
                    h01 * tr.values[3 * (i + 1) + 1].coeffs() + h11 * dt * tr.values[3 * (i + 1)].coeffs();
    return Quatf(c.normalized());
  } else {
    return h00 * tr.values[3 * i + 1] + h10 * dt * tr.values[3 * i + 2] + h01 * tr.values[3 * (i + 1) + 1] +
           h11 * dt * tr.values[3 * (i + 1)];
  }
}

template <typename V>
std::vector<std::pair<float, V>> BakeLinear(const skinning::Track<V>& tr) {
  std::vector<std::pair<float, V>> keys;
  const size_t n = tr.times_s.size();
  switch (tr.interpolation) {
    case Interpolation::kLinear:
      for (size_t i = 0; i < n; ++i) keys.emplace_back(tr.times_s[i], tr.values[i]);
      break;
    case Interpolation::kStep:
      for (size_t i = 0; i < n; ++i) {
        keys.emplace_back(tr.times_s[i], tr.values[i]);
        if (i + 1 < n) {
          const float hold = tr.times_s[i + 1] - kStepBakeEpsilon_s;
          if (hold > tr.times_s[i]) keys.emplace_back(hold, tr.values[i]);
        }
      }
      break;
    case Interpolation::kCubicSpline:
      for (size_t i = 0; i < n; ++i) {
        keys.emplace_back(tr.times_s[i], tr.values[3 * i + 1]);
        if (i + 1 < n) {
          for (int s = 1; s < kCubicBakeSubdivisions; ++s) {
            const float u = static_cast<float>(s) / kCubicBakeSubdivisions;
            keys.emplace_back(tr.times_s[i] + u * (tr.times_s[i + 1] - tr.times_s[i]), CubicValue(tr, i, u));
          }
        }
      }
      break;
  }
  return keys;
}

template <typename Key, typename V>
Key* MakeKeys(const std::vector<std::pair<float, V>>& keys) {
  Key* out = new Key[keys.size()];
  for (size_t i = 0; i < keys.size(); ++i) {
    out[i].mTime = static_cast<double>(keys[i].first);  // ticks, with mTicksPerSecond = 1
    out[i].mValue = ToAi(keys[i].second);
  }
  return out;
}

aiNodeAnim* MakeChannel(const std::string& node, const std::vector<std::pair<float, Vector3f>>& t,
                        const std::vector<std::pair<float, Quatf>>& r,
                        const std::vector<std::pair<float, Vector3f>>& s) {
  auto* ch = new aiNodeAnim();
  ch->mNodeName = aiString(node);
  ch->mNumPositionKeys = static_cast<unsigned>(t.size());
  ch->mPositionKeys = MakeKeys<aiVectorKey>(t);
  ch->mNumRotationKeys = static_cast<unsigned>(r.size());
  ch->mRotationKeys = MakeKeys<aiQuatKey>(r);
  ch->mNumScalingKeys = static_cast<unsigned>(s.size());
  ch->mScalingKeys = MakeKeys<aiVectorKey>(s);
  return ch;
}

// One clip: later tracks of the same joint override earlier ones channel by channel.
aiAnimation* MakeClipAnimation(const skinning::AnimationClip& clip, const skinning::Skeleton& sk,
                               const std::vector<std::string>& joint_names) {
  std::map<int32_t, skinning::JointTrack> by_joint;
  for (const auto& tr : clip.tracks) {
    auto& dst = by_joint[tr.joint];
    dst.joint = tr.joint;
    if (!tr.translation.empty()) dst.translation = tr.translation;
    if (!tr.rotation.empty()) dst.rotation = tr.rotation;
    if (!tr.scale.empty()) dst.scale = tr.scale;
  }
  std::vector<aiNodeAnim*> channels;
  for (const auto& [joint, tr] : by_joint) {
    if (tr.translation.empty() && tr.rotation.empty() && tr.scale.empty()) continue;
    const auto& rest = sk.rest_local[joint];
    auto t = tr.translation.empty() ? std::vector<std::pair<float, Vector3f>>{{0.0f, rest.translation}}
                                    : BakeLinear(tr.translation);
    auto r =
        tr.rotation.empty() ? std::vector<std::pair<float, Quatf>>{{0.0f, rest.rotation}} : BakeLinear(tr.rotation);
    auto s = tr.scale.empty() ? std::vector<std::pair<float, Vector3f>>{{0.0f, rest.scale}} : BakeLinear(tr.scale);
    channels.push_back(MakeChannel(joint_names[joint], t, r, s));
  }
  auto* anim = new aiAnimation();
  anim->mName = aiString(clip.name);
  anim->mTicksPerSecond = 1.0;
  anim->mDuration = clip.duration_s;
  anim->mNumChannels = static_cast<unsigned>(channels.size());
  anim->mChannels = new aiNodeAnim*[std::max<size_t>(channels.size(), 1)];
  std::copy(channels.begin(), channels.end(), anim->mChannels);
  return anim;
}

}  // namespace

std::vector<aiAnimation*> MakeClipAnimations(const RawCharacter& c, const std::vector<std::string>& joint_names) {
  std::vector<aiAnimation*> anims;
  for (const auto& clip : c.clips) anims.push_back(MakeClipAnimation(clip, c.skeleton, joint_names));
  return anims;
}

void AddSphereAnimation(const GlbExtras& extras, const std::vector<std::string>& sphere_nodes,
                        std::vector<aiAnimation*>* anims) {
  if (extras.spheres.empty()) return;
  std::vector<aiNodeAnim*> channels;
  // The character's clip of that name, if any, also moves the spheres.
  aiAnimation* host = nullptr;
  for (aiAnimation* a : *anims) {
    if (!host && extras.clip_name == a->mName.C_Str()) host = a;
  }
  for (size_t i = 0; i < extras.spheres.size(); ++i) {
    std::vector<std::pair<float, Vector3f>> t, s;
    for (size_t f = 0; f < extras.frame_times_s.size(); ++f) {
      const Vec4f& xyzr = extras.spheres[i].per_frame_xyzr[f];
      t.emplace_back(extras.frame_times_s[f], xyzr.head<3>());
      s.emplace_back(extras.frame_times_s[f], Vector3f::Constant(xyzr.w()));
    }
    channels.push_back(MakeChannel(sphere_nodes[i], t, {{extras.frame_times_s.front(), Quatf::Identity()}}, s));
  }
  if (host != nullptr) {
    auto** merged = new aiNodeAnim*[host->mNumChannels + channels.size()];
    std::copy(host->mChannels, host->mChannels + host->mNumChannels, merged);
    std::copy(channels.begin(), channels.end(), merged + host->mNumChannels);
    delete[] host->mChannels;
    host->mChannels = merged;
    host->mNumChannels += static_cast<unsigned>(channels.size());
    host->mDuration = std::max<double>(host->mDuration, extras.frame_times_s.back());
  } else {
    auto* anim = new aiAnimation();
    anim->mName = aiString(extras.clip_name);
    anim->mTicksPerSecond = 1.0;
    anim->mDuration = extras.frame_times_s.back();
    anim->mNumChannels = static_cast<unsigned>(channels.size());
    anim->mChannels = new aiNodeAnim*[channels.size()];
    std::copy(channels.begin(), channels.end(), anim->mChannels);
    anims->push_back(anim);
  }
}

}  // namespace skinspheres::lib::detail
