// Playback: for each frame of a clip, sample, skin, refit, query (what `play` and `demo` run).
#pragma once

#include <string>
#include <vector>

#include "commands.h"
#include "skinspheres/runtime/broad_phase.h"
#include "skinspheres/runtime/sphere_set.h"

namespace skinspheres::tool {

struct PlayOptions {
  float fps = 30.0f;
  int frames = 0;              // 0: the whole clip
  bool fast = false;           // refit mode: fast (joint transforms only) or exact (skinned vertices)
  bool verify = false;         // skin every vertex and check every triangle inside its sphere
  bool progress = false;       // a progress line on the terminal
  bool keep_spheres = false;   // keep per-frame spheres (for --dump / --export-glb)
};

struct FramePairs {
  float time_s = 0.0f;
  std::vector<runtime::Contact> contacts;
  std::vector<skinspheres::Vec4f> spheres;  // only with keep_spheres
};

struct StageTimes {
  std::vector<double> sample, skin, refit, query, verify;  // seconds per frame
};

struct PlayResult {
  std::string clip;
  std::vector<FramePairs> frames;
  StageTimes times;
  size_t triangles_outside = 0;   // --verify: summed over frames (must be 0)
  int first_bad_frame = -1;
};

Result<PlayResult> PlayClip(const LoadedCharacter& loaded, const runtime::SphereSet& set, size_t clip,
                            const PlayOptions& options);

// Clip by name or index; the error lists the clips there are.
Result<size_t> FindClip(const lib::RawCharacter& character, const std::string& name_or_index);

// The summary: frames, pairs per frame, body-part pairs touched over frame ranges, stage times.
void PrintPlaySummary(const PlayResult& result, const runtime::SphereSet& set, float fps);

void AddPlayCommand(CLI::App& app, int* exit_code);

}  // namespace skinspheres::tool
