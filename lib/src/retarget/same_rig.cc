// The same rig or not (retarget_stages.h, FirstOffsetDifference): bone offsets compared below
// the root-motion joint, up to one unit factor.
#include <algorithm>
#include <cmath>

#include "retarget_stages.h"

namespace skinspheres::lib::retarget {
namespace {

bool IsBelow(const skinning::Skeleton& s, size_t j, int32_t root) {
  for (int32_t a = s.parents[j]; a >= 0; a = s.parents[static_cast<size_t>(a)]) {
    if (a == root) return true;
  }
  return false;
}

}  // namespace

int32_t FirstOffsetDifference(const SourceRig& source, const skinning::Skeleton& target, const Correspondence& c,
                              int32_t root_joint) {
  if (root_joint < 0) return -1;
  std::vector<size_t> below;
  float longest_target = 0.0f, longest_source = 0.0f;
  for (size_t j = 0; j < target.size(); ++j) {
    if (c.node_of[j] < 0 || !IsBelow(target, j, root_joint)) continue;
    below.push_back(j);
    longest_target = std::max(longest_target, target.rest_local[j].translation.norm());
    longest_source =
        std::max(longest_source, source.nodes.rest_local[static_cast<size_t>(c.node_of[j])].translation.norm());
  }
  // The unit factor: the median ratio of the offsets' lengths (a rig in centimetres against one in
  // metres is the same rig).
  std::vector<float> ratios;
  const float tiny_target = 1e-4f * longest_target, tiny_source = 1e-4f * longest_source;
  for (size_t j : below) {
    const float lt = target.rest_local[j].translation.norm();
    const float ls = source.nodes.rest_local[static_cast<size_t>(c.node_of[j])].translation.norm();
    if (lt > tiny_target && ls > tiny_source) ratios.push_back(lt / ls);
  }
  float unit = 1.0f;
  if (!ratios.empty()) {
    std::nth_element(ratios.begin(), ratios.begin() + static_cast<std::ptrdiff_t>(ratios.size() / 2), ratios.end());
    unit = ratios[ratios.size() / 2];
  }
  for (size_t j : below) {
    const Eigen::Vector3f t = target.rest_local[j].translation;
    const Eigen::Vector3f s = unit * source.nodes.rest_local[static_cast<size_t>(c.node_of[j])].translation;
    if (!((t - s).norm() <= 0.01f * std::max(t.norm(), s.norm()) + tiny_target)) return static_cast<int32_t>(j);
  }
  return -1;
}

}  // namespace skinspheres::lib::retarget
