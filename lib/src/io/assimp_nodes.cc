// The Assimp node tree shared by the Assimp readers (assimp_nodes.h).
#include "assimp_nodes.h"

#include <cmath>

#include "importer_internal.h"

namespace skinspheres::lib::detail {

Mat4f ToMat4f(const aiMatrix4x4& m) {
  Mat4f e;
  e << m.a1, m.a2, m.a3, m.a4, m.b1, m.b2, m.b3, m.b4, m.c1, m.c2, m.c3, m.c4, m.d1, m.d2, m.d3, m.d4;
  return e;
}

int32_t AssimpNodeTree::Find(const aiString& name) const {
  const auto it = node_of_name.find(name.C_Str());
  return it == node_of_name.end() ? -1 : it->second;
}

Result<AssimpNodeTree> ReadAssimpNodeTree(const aiScene& scene, const std::filesystem::path& file) {
  AssimpNodeTree tree;
  std::map<const aiNode*, int32_t> index_of;
  std::vector<std::pair<const aiNode*, int32_t>> stack = {{scene.mRootNode, -1}};
  while (!stack.empty()) {
    auto [n, p] = stack.back();
    stack.pop_back();
    if (n == nullptr || index_of.count(n)) continue;
    const Mat4f m = ToMat4f(n->mTransformation);
    if (!m.allFinite()) {
      return ImportError(ErrorCode::kInvalidData, file,
                         "node '" + std::string(n->mName.C_Str()) + "' has a non-finite transform");
    }
    const int32_t index = static_cast<int32_t>(tree.nodes.size());
    index_of[n] = index;
    tree.nodes.push_back(n);
    tree.parent.push_back(p);
    tree.local.push_back(skinning::Transform::FromMatrix(m));
    tree.node_of_name.emplace(n->mName.C_Str(), index);
    for (unsigned c = n->mNumChildren; c-- > 0;) stack.push_back({n->mChildren[c], index});
  }
  return tree;
}

Result<ClipHeader> ReadClipHeader(const aiAnimation& anim, unsigned index, const std::filesystem::path& file) {
  ClipHeader h;
  h.clip.name = anim.mName.length > 0 ? anim.mName.C_Str() : "animation_" + std::to_string(index);
  const auto bad = [&](const std::string& what) {
    return ImportError(ErrorCode::kInvalidData, file, "animation \"" + h.clip.name + "\" has a bad " + what);
  };
  if (anim.mTicksPerSecond != 0.0) {  // 0: not given (Assimp's convention), the default stays
    if (!(anim.mTicksPerSecond > 0.0) || !std::isfinite(anim.mTicksPerSecond)) return bad("tick rate");
    h.ticks_per_second = anim.mTicksPerSecond;
  }
  h.clip.duration_s = static_cast<float>(anim.mDuration / h.ticks_per_second);
  if (!std::isfinite(h.clip.duration_s) || h.clip.duration_s < 0.0f) return bad("duration");
  return h;
}

namespace {

// One key of AppendChannelKeys (its value finite).
template <typename V>
void AddKey(skinning::Track<V>& track, double seconds, const V& value) {
  const float t = static_cast<float>(seconds);
  if (!std::isfinite(t)) return;
  if (!track.times_s.empty() && t <= track.times_s.back()) {
    if (t < track.times_s.back()) return;
    track.times_s.pop_back();
    track.values.pop_back();
  }
  track.times_s.push_back(t);
  track.values.push_back(value);
}

// A finite rotation key as a unit quaternion, normalised in double (the float norm of components
// above ~1.8e19 overflows, and Eigen's normalized() then returns zeros); nullopt for a key of
// zero length, which is no rotation.
std::optional<Quatf> UnitRotation(const aiQuaternion& q) {
  const double n = std::sqrt(double(q.w) * q.w + double(q.x) * q.x + double(q.y) * q.y + double(q.z) * q.z);
  if (!(n > 0.0)) return std::nullopt;
  return Quatf(static_cast<float>(q.w / n), static_cast<float>(q.x / n), static_cast<float>(q.y / n),
               static_cast<float>(q.z / n));
}

}  // namespace

std::optional<Error> AppendChannelKeys(const aiNodeAnim& channel, const ClipHeader& header,
                                       const std::filesystem::path& file, skinning::JointTrack* track) {
  const double tps = header.ticks_per_second;
  const auto bad = [&](const std::string& what) {
    return ImportError(ErrorCode::kInvalidData, file,
                       "animation \"" + header.clip.name + "\" has " + what + " on node " + channel.mNodeName.C_Str());
  };
  const std::string not_finite = "a key value that is NaN or infinite";
  for (unsigned k = 0; k < channel.mNumPositionKeys; ++k) {
    const aiVector3D& v = channel.mPositionKeys[k].mValue;
    const Eigen::Vector3f p(v.x, v.y, v.z);
    if (!p.allFinite()) return bad(not_finite);
    AddKey(track->translation, channel.mPositionKeys[k].mTime / tps, p);
  }
  for (unsigned k = 0; k < channel.mNumRotationKeys; ++k) {
    const aiQuaternion& q = channel.mRotationKeys[k].mValue;
    if (!Quatf(q.w, q.x, q.y, q.z).coeffs().allFinite()) return bad(not_finite);
    const auto unit = UnitRotation(q);
    if (!unit) return bad("a rotation key of zero length");
    AddKey(track->rotation, channel.mRotationKeys[k].mTime / tps, *unit);
  }
  for (unsigned k = 0; k < channel.mNumScalingKeys; ++k) {
    const aiVector3D& v = channel.mScalingKeys[k].mValue;
    const Eigen::Vector3f s(v.x, v.y, v.z);
    if (!s.allFinite()) return bad(not_finite);
    AddKey(track->scale, channel.mScalingKeys[k].mTime / tps, s);
  }
  return std::nullopt;
}

}  // namespace skinspheres::lib::detail
