// `skinspheres colliders`, callable in-process (the Python module's colliders() runs this same
// code): a few spheres and capsules attached to joints, fitted to cover the body over the poses of
// the character's clips (lib/colliders/colliders.h), written for an engine (collider_writers.h).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "clip_files.h"
#include "commands.h"
#include "skinspheres/lib/colliders/colliders.h"

namespace skinspheres::tool {

struct CollidersArgs {
  std::string input, output, report, html, format = "json", shapes = "auto", clip = "all";
  ClipFileOptions clip_files;
  int budget = 32;
  float fps = 30.0f;        // frames of the clips measured (and fitted, up to --fit-poses of them)
  float tolerance = 0.01f;  // covered: inside or within this share of the body height
  int fit_poses = 64;
  bool compare = false;  // also measure the per-bone capsules at the same count (report "baseline")
  std::string parts_file;
};
struct CollidersOutcome {
  int exit_code = 0;  // 0 written; 2 bad input (error says why)
  std::string error;
  ErrorCode error_code = ErrorCode::kOk;
  nlohmann::json report;  // "format": "skinspheres.colliders"; null on bad input
  std::vector<lib::Collider> colliders;
  std::vector<std::string> joint_names;
  std::vector<Mat4f> joint_rest_world;
};
// The whole command; output empty: nothing written (the Python module's arrays). quiet: nothing on
// stdout or stderr.
CollidersOutcome RunColliders(CollidersArgs& a, bool quiet);
void AddCollidersCommand(CLI::App& app, int* exit_code);

// The formats and what they hold.
struct ColliderFormat {
  const char* name;
  bool spheres, capsules, tapered;
  const char* extension;  // expected output extension
};
const ColliderFormat* FindColliderFormat(const std::string& name);

// Writers (collider_writers.cc). `rest_world`: the joints' world matrices at rest (offsets are
// written in each joint's local space: its rest world matrix inverted, scale included). Each returns
// an error message naming the path when refused.
struct ColliderOutput {
  const lib::RawCharacter* character = nullptr;
  std::span<const lib::Collider> colliders;
  std::span<const Mat4f> rest_world;
  nlohmann::json report;  // for json: written beside the shapes
};
std::optional<std::string> WriteColliders(const std::string& format, const ColliderOutput& out,
                                          const std::string& path);

}  // namespace skinspheres::tool
