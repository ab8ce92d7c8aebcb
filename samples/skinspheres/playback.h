// Playback: for each frame of a clip, sample, skin, refit, query the sphere pairs, find the
// triangle contacts (what `play`, `check` and `demo` run).
//
// Set-up is split from playing: a Playback (once per character and sphere set: the set checked
// against the mesh, the runtime asset, the joint mapping) is shared, read-only, by any number of
// ClipPlayers (one per thread: an instance and the skinning buffers), each playing clips one after
// another. PlayClip does both for one clip.
//
// The frame at t = duration samples the clip's end pose; frames past it loop (PlaybackTime).
//
// Touching and penetrating: a part pair's contact on a frame is *penetrating* when its triangles
// intersect deeper than the touch tolerance (a share of the body height, PlayOptions), else
// *touching* (surfaces within the margin, or intersecting by less than the tolerance): the
// runtime's classification (runtime::PartContact::kind), which engines and the C API read too.
//
// Memory stays flat whatever the clip length: each frame is handed to an optional FrameSink as it
// is played and then forgotten; the result keeps only bounded summaries (per part pair: frame
// ranges, at most kMaxRanges of them, counts and extremes; stage times as fixed histograms).
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "commands.h"
#include "skinspheres/runtime/api/character.h"
#include "skinspheres/runtime/api/joint_mapping.h"
#include "skinspheres/runtime/broad_phase/broad_phase.h"
#include "skinspheres/runtime/format/sphere_set.h"
#include "skinspheres/runtime/narrow_phase/narrow_phase.h"
#include "skinspheres/skinning/prepared_influences.h"
#include "skinspheres/skinning/skeleton.h"

namespace skinspheres::tool {

// Intersections up to this share of the body height are touching, deeper ones penetrating.
inline constexpr float kDefaultTouchTolerance = runtime::kDefaultTouchToleranceShare;

// The clip time a playback time samples: t itself up to the clip's end (the frame at t = duration
// samples the end pose), then looping (t - k * duration); 0 for a clip without duration.
float PlaybackTime(float time_s, float duration_s);

struct PlayOptions {
  float fps = 30.0f;
  int frames = 0;         // 0: the whole clip
  bool fast = false;      // refit mode: fast (joint transforms only) or exact (skinned vertices)
  bool verify = false;    // skin every vertex: every triangle inside its sphere, narrow phase == oracle
  bool progress = false;  // a progress line on the terminal
  float margin = 0.0f;    // narrow phase: also report triangle pairs nearer than this (model units)
  float touch_tolerance = kDefaultTouchTolerance;  // share of body height: deeper intersections penetrate
};

// One played frame, valid during the FrameSink call only.
struct FrameView {
  int index = 0;
  float time_s = 0.0f;                                // frame / fps: keeps counting past the clip's end
  float clip_time_s = 0.0f;                           // the time sampled in the clip (the pose loops)
  std::span<const runtime::SpherePair> sphere_pairs;  // broad phase
  const runtime::FrameContacts* contacts = nullptr;   // narrow phase
  std::span<const skinspheres::Vec4f> spheres;        // refitted: xyz centre, w radius
  std::span<const skinspheres::Mat4f> joint_world;    // the character's joints, world space
  float body_height = 0.0f;                           // of the rest pose (for the touch tolerance)
  float touch_tolerance = 0.0f;                       // model units: deeper intersections penetrate
};

// --touch-tolerance (play, check): the option, and its check (a message when refused).
void AddTouchToleranceOption(CLI::App& app, float* share);
std::optional<std::string> CheckTouchTolerance(float share);

// The narrow phase's settings for these options: the margin, and the touch tolerance by which the
// runtime classifies each part pair (runtime::PartContact::kind).
runtime::NarrowPhaseSettings NarrowSettings(const PlayOptions& options);
using FrameSink = std::function<void(const FrameView&)>;

// One played frame kept for what needs every frame at the end (the viewer page, a GLB export):
// its times, refitted spheres, sphere pairs and intersecting triangle pairs (source-triangle
// indices, t of part_a then u of part_b).
struct FrameRecord {
  float time_s = 0.0f;
  float clip_time_s = 0.0f;
  std::vector<skinspheres::Vec4f> spheres;
  std::vector<runtime::SpherePair> sphere_pairs;  // the broad phase's: candidates, most owning no contact
  // The sphere pairs that own the frame's triangle contacts (the narrow phase's, i <= j).
  std::vector<runtime::SpherePairId> contact_sphere_pairs;
  std::vector<std::array<uint32_t, 2>> triangle_pairs;
  struct Part {
    uint16_t part_a = 0, part_b = 0;
    bool penetrating = false;
    float depth = 0.0f;
  };
  std::vector<Part> parts;  // part pairs with triangle contacts, touching or penetrating
};
// A sink that appends every frame to *out (memory grows with the clip: only for such outputs),
// then hands it to `next` when given.
FrameSink RecordFrames(std::vector<FrameRecord>* out, FrameSink next = {});

// Frame numbers collected as ranges "3-7, 12": at most kMaxRanges ranges are kept, later ones are
// only counted.
class FrameRanges {
 public:
  static constexpr size_t kMaxRanges = 8;
  void Add(int frame);
  size_t frames() const { return frames_; }
  int first() const { return first_; }
  int last() const { return last_; }
  std::string ToString() const;  // "0-30", "3-7, 12, ... (+4 ranges)"

 private:
  std::vector<std::pair<int, int>> ranges_;
  size_t more_ = 0;  // ranges started after the kept ones
  size_t frames_ = 0;
  int first_ = -1, last_ = -1;
};

struct PartPairSummary {
  uint16_t part_a = 0, part_b = 0;
  FrameRanges frames;                // frames where the pair touched or penetrated
  FrameRanges penetrating;           // frames where it penetrated (deeper than the touch tolerance)
  int worst_frame = -1;              // the frame of max_depth
  bool intersecting = false;         // at least one intersecting triangle pair (else only within margin)
  uint32_t most_triangle_pairs = 0;  // largest number of triangle pairs in one frame
  float max_depth = 0.0f;            // largest penetration depth estimate
  float min_distance = 0.0f;         // closest within-margin distance (when never intersecting)
};

// Per-frame times as a fixed log-scale histogram (1% bins from 10 ns to 100 s): percentiles within 1%.
class StageTime {
 public:
  void Add(double seconds);
  double Percentile(double q) const;  // seconds
  size_t count() const { return count_; }

 private:
  static constexpr int kBinsPerDecade = 230;  // 10^(1/230) ~ 1.01
  static constexpr int kDecades = 10;         // 1e-8 .. 1e2 s
  std::array<uint32_t, kBinsPerDecade * kDecades + 2> bins_{};
  size_t count_ = 0;
};

struct StageTimes {
  StageTime sample, skin, refit, query, narrow, verify;
};

struct PlayResult {
  std::string clip;
  int frames = 0;
  float touch_tolerance = 0.0f;  // model units
  size_t sphere_pairs_total = 0, sphere_pairs_most = 0;
  size_t triangle_pairs_total = 0, triangle_pairs_most = 0;
  std::vector<PartPairSummary> contacts;      // narrow phase, by part pair (sorted)
  std::vector<PartPairSummary> sphere_pairs;  // broad phase, by part pair (sorted)
  StageTimes times;
  float body_height = 0.0f;
  // --verify
  size_t triangles_outside = 0;  // triangle-frames outside their sphere (must be 0)
  size_t triangles_unowned = 0;  // triangles of the mesh that no sphere owns (must be 0)
  int first_bad_frame = -1;
  // Σ over spheres and frames of the refitted radius / the smallest radius around the same centre
  // holding the sphere's skinned triangles (1 in exact mode up to its rounding margin; the fast
  // refit's looseness in fast mode), and how many terms.
  double radius_ratio_sum = 0.0;
  size_t radius_ratio_count = 0;
  size_t narrow_mismatches = 0;  // frames where the narrow phase differs from the brute-force oracle
  int first_mismatch_frame = -1;
  bool verified() const { return triangles_outside == 0 && triangles_unowned == 0 && narrow_mismatches == 0; }
};

// The skin's joints, each once, in the order of its bind entries (what --dump lists).
std::vector<int32_t> SkinJoints(const lib::RawCharacter& character);

// Once per character and sphere set, shared read-only by ClipPlayers on any thread. Refused (one
// line naming the file): a fast-only set, a set without mesh, a set fitted on other joints or
// another mesh, a sphere that owns a triangle without its vertices.
class Playback {
 public:
  static Result<std::shared_ptr<const Playback>> Create(const LoadedCharacter& loaded, const runtime::SphereSet& set,
                                                        const runtime::NarrowPhaseSettings& narrow);
  const LoadedCharacter& loaded() const { return loaded_; }
  const runtime::SphereSet& set() const { return set_; }
  const std::shared_ptr<const runtime::CharacterAsset>& asset() const { return asset_; }
  const runtime::JointMapping& mapping() const { return mapping_; }
  std::span<const uint32_t> source_vertices() const { return sources_; }  // sorted: what the exact refit reads
  float body_height() const { return body_height_; }
  std::string file() const;  // the character's name in messages
  // The source vertices' influences laid out for the exact refit's skinning (immutable).
  const skinning::PreparedInfluences& prepared() const { return prepared_; }

 private:
  Playback(const LoadedCharacter& loaded, const runtime::SphereSet& set) : loaded_(loaded), set_(set) {}
  const LoadedCharacter& loaded_;
  const runtime::SphereSet& set_;
  std::shared_ptr<const runtime::CharacterAsset> asset_;
  runtime::JointMapping mapping_;
  std::vector<uint32_t> sources_;
  skinning::PreparedInfluences prepared_;
  float body_height_ = 0.0f;
};

// Plays clips of the Playback's character one after another (one per thread).
class ClipPlayer {
 public:
  static Result<ClipPlayer> Create(std::shared_ptr<const Playback> playback, const PlayOptions& options);
  Result<PlayResult> Play(size_t clip, const FrameSink& sink = {});
  // One pose, given as every joint's local transform (skeleton order): skinned (exact mode), refit,
  // queried and through the narrow phase, as a played frame is; contacts() and joint_world() then
  // hold its results. `frame` only names it in errors.
  std::optional<Error> PlayPose(std::span<const skinning::Transform> locals, int frame);
  const runtime::FrameContacts& contacts() const { return instance_->contacts(); }
  std::span<const skinspheres::Mat4f> joint_world() const { return joint_world_; }

 private:
  ClipPlayer() = default;
  Result<size_t> FrameCount(const skinning::AnimationClip& clip) const;
  std::optional<Error> Step(const skinning::AnimationClip& clip, int frame, float clip_time, StageTimes* times);
  // From locals_ on: local to model, skinning, refit, query, narrow phase (times from t0).
  std::optional<Error> Pose(int frame, std::chrono::steady_clock::time_point t0, StageTimes* times);
  void Summarise(int frame, PlayResult* result) const;
  void Verify(int frame, PlayResult* result);

  std::shared_ptr<const Playback> playback_;
  PlayOptions options_;
  std::optional<runtime::CharacterInstance> instance_;
  std::vector<skinning::Transform> locals_;
  std::vector<skinspheres::Mat4f> joint_world_, bind_matrices_;
  std::vector<Eigen::Vector3f> skinned_;
  std::span<const runtime::SpherePair> pairs_;
  runtime::FrameContacts oracle_;
};

// One clip: Playback::Create, ClipPlayer::Create and Play.
Result<PlayResult> PlayClip(const LoadedCharacter& loaded, const runtime::SphereSet& set, size_t clip,
                            const PlayOptions& options, const FrameSink& sink = {});

// Clip by name or index; the error lists the clips there are.
Result<size_t> FindClip(const lib::RawCharacter& character, const std::string& name_or_index);

// A set read from a version-1 file has no mesh: the character it was fitted on provides it (same
// vertices and triangles, checked by PlayClip). Returns true when it added one.
bool AttachMesh(const lib::RawCharacter& character, runtime::SphereSet* set);

// The summary: frames, contacts by part pair (frames, triangle pairs, depth), optionally the
// broad phase's sphere pairs by part pair, stage times, and --verify's outcome when it ran.
void PrintPlaySummary(const PlayResult& result, const runtime::SphereSet& set, float fps, bool sphere_pairs,
                      bool verify);

// Peak resident memory of this process so far, in KiB (0 where the system does not tell).
long PeakRssKiB();

void AddPlayCommand(CLI::App& app, int* exit_code);

}  // namespace skinspheres::tool
