// NaiveJointSpheres: the baseline the fit's tightness is compared with (metrics/fit_metrics.h), one
// bounding sphere per joint around the vertices it dominates.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <span>
#include <vector>

#include "skinspheres/lib/character/raw_character.h"
#include "skinspheres/runtime/error.h"

namespace skinspheres::lib {

// Each sphere is centred on the centre of the bounding box of the vertices its joint dominates, its
// radius reaching the farthest of them. Joints that dominate no vertex get no sphere. Errors
// (kInvalidArgument, "fit metrics: ..."): sizes that disagree, no or non-finite vertices, influence
// indices out of range.
struct JointSpheres {
  std::vector<Eigen::Vector3f> centers;
  std::vector<float> radii;
  std::vector<uint32_t> joints;  // the joint of each sphere, ascending
};
// dominant_joint: one entry per position (e.g. the joint with the largest skin weight).
Result<JointSpheres> NaiveJointSpheres(std::span<const Eigen::Vector3f> positions,
                                       std::span<const uint32_t> dominant_joint);
// The same on a character's rest pose, each vertex's dominant joint being the skeleton joint of
// its largest skin weight (first one on ties; vertices without influences go to joint 0).
Result<JointSpheres> NaiveJointSpheres(const RawCharacter& character);

}  // namespace skinspheres::lib
