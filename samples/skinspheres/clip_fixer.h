// ClipFixer: the poses of a clip changed as little as possible so that no part pair penetrates
// deeper than a limit, smoothly over time (what `skinspheres fix` runs on each clip).
//
// Method (docs/TOOL.md, "fix"):
// - A frame fails when a part pair that is not allowed penetrates deeper than the limit, by the
//   exact triangle contacts (runtime::PartContact: kind penetrating, depth > limit).
// - Per failing frame, a damped least-squares step on the local rotations of the joints on the two
//   chains between the pair's parts (each side's most frequent joint among its intersecting
//   triangles, up to their common ancestor): the contact centre is to move along the contact normal
//   by the depth minus half the limit, each joint's rotation weighted 2^k by its k hops from the
//   contact (distal joints change first). Repeated on the exact contacts until the frame holds.
// - The frames' corrections (rotation vectors, applied before each joint's local rotation) are
//   spread over neighbouring frames by a normalised Gaussian (sigma = ease seconds) whose weights
//   are capped at 1, so a run of equal corrections keeps its value and eases in and out around it;
//   the whole clip is re-evaluated and the frames that still fail are solved again, for a few rounds.
// - Every joint's correction is limited to max_rotation; a clip with frames that still fail is
//   reported unfixed.
//
// Threads: one ClipFixer per thread (it owns a ClipPlayer); the Playback is shared read-only.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "playback.h"
#include "skinspheres/runtime/fix/pose_solver.h"
#include "skinspheres/skinning/skeleton.h"

namespace skinspheres::tool {

struct FixSettings {
  float max_depth = 0.0f;          // model units: a part pair deeper than this fails the frame
  float ease_s = 0.2f;             // seconds: how far corrections are eased in and out (Gaussian sigma)
  float max_rotation_deg = 60.0f;  // largest change of any joint's rotation
  int rounds = 12;                 // solve-and-spread rounds over the clip
  int iterations = 8;              // damped least-squares steps per failing frame
  std::vector<std::pair<uint16_t, uint16_t>> allow;  // part pairs left alone (part_a <= part_b)
};

// A clip's frames as poses: per frame, every joint's local transform.
using Poses = std::vector<std::vector<skinning::Transform>>;

// Measures of one clip, before and after.
struct FixMeasures {
  int frames_failing = 0;    // frames with a part pair (not allowed) deeper than max_depth
  float worst_depth = 0.0f;  // deepest penetration of such a pair (model units), 0 when none
  int worst_frame = -1;
  std::vector<std::pair<uint16_t, uint16_t>> failing_pairs;  // part pairs that fail some frame
};

struct FixResult {
  Poses poses;  // fixed (equal to the source's where nothing changed)
  FixMeasures before, after;
  std::vector<int32_t> joints_changed;  // skeleton joints whose rotation changed on some frame
  // Over (frame, joint) with a change: the angle of the change, degrees.
  float rotation_median_deg = 0.0f, rotation_max_deg = 0.0f;
  // How far each bone's world direction (from its parent joint to its joint) turned, degrees, over
  // every (frame, bone); and over those that turned by more than 0.01 degree (bone_moved of them).
  float bone_median_deg = 0.0f, bone_p95_deg = 0.0f, bone_max_deg = 0.0f, bone_moved_median_deg = 0.0f;
  size_t bone_moved = 0, bone_total = 0;
  // RMS over frames of the joints' world-space jerk (third difference of position times fps^3),
  // over the joints whose position the fix moved; source and fixed.
  double jerk_source = 0.0, jerk_fixed = 0.0;
  int rounds = 0;              // rounds run
  size_t solves = 0;           // frame solves (each a few poses evaluated)
  size_t poses_evaluated = 0;  // poses skinned and checked in all
  bool fixed() const { return after.frames_failing == 0; }
};

class ClipFixer {
 public:
  static Result<ClipFixer> Create(std::shared_ptr<const Playback> playback);
  // The clip's frames at fps (as play samples them: frame f at f / fps, the end pose last).
  Result<Poses> Sample(const skinning::AnimationClip& clip, float fps) const;
  Result<FixResult> Fix(const Poses& source, float fps, const FixSettings& settings);

 private:
  ClipFixer() = default;
  Result<std::vector<runtime::PoseViolation>> Evaluate(std::span<const skinning::Transform> pose, int frame,
                                                       float limit, const FixSettings& settings);
  Result<int> SolveFrame(const std::vector<skinning::Transform>& source, int frame, const FixSettings& settings,
                         std::vector<Eigen::Vector3f>* correction);
  void Measure(const Poses& poses, const FixSettings& settings, FixMeasures* out);

  std::shared_ptr<const Playback> playback_;
  std::optional<ClipPlayer> player_;
  std::optional<runtime::PoseSolver> solver_;
  size_t poses_ = 0;
};

// The change's measures (FixResult's rotation, bone and jerk fields) from the source and fixed
// poses and the corrections; height: the body height (model units) for the thresholds.
void MeasureMotion(const skinning::Skeleton& skeleton, const Poses& source, const FixResult& fixed,
                   const std::vector<std::vector<Eigen::Vector3f>>& corrections, float fps, float height,
                   FixResult* out);

}  // namespace skinspheres::tool
