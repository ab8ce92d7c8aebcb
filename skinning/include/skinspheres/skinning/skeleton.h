// Skeleton: a joint hierarchy with rest (node-tree) transforms.
//
// Joints are stored parents-first: parents[i] < i for every joint but the roots (parent -1),
// so a single forward pass computes model-space (world) transforms. The skeleton holds every
// node of the file's scene on a path from the scene root to a joint, so the world transforms it
// computes are the file's world space (a Z-up source rotated by an ancestor node stays rotated).
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "skinspheres/skinning/math_types.h"

namespace skinspheres::skinning {

// A decomposed local transform: M = T * R * S (glTF's node TRS order).
struct Transform {
  Eigen::Vector3f translation = Eigen::Vector3f::Zero();
  Quatf rotation = Quatf::Identity();
  Eigen::Vector3f scale = Eigen::Vector3f::Ones();

  Mat4f ToMatrix() const;
  // Decomposes an affine matrix (no shear expected; shear is folded into the scale/rotation
  // by a polar decomposition).
  static Transform FromMatrix(const Mat4f& m);
};

struct Skeleton {
  std::vector<std::string> joint_names;
  std::vector<int32_t> parents;       // -1 for a root; parents[i] < i
  std::vector<Transform> rest_local;  // each joint's own node transform at rest

  size_t size() const { return joint_names.size(); }
  // Index of the joint with this exact name, or -1.
  int32_t Find(std::string_view name) const;
  // True when the arrays agree in size and parents are ordered (parents[i] < i).
  bool Validate() const;
  // World (model) transforms of the rest pose: out.size() >= size().
  void RestWorld(std::span<Mat4f> out) const;
};

}  // namespace skinspheres::skinning
