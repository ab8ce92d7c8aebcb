// The viewer page: one self-contained HTML file that opens from file:// with no server and no
// network (scripts, the character, the spheres and the per-frame results are all inside it).
// It shows the character (GLB, lit) playing each clip, the spheres coloured by body part, the
// contacts of the current frame, a timeline of part-pair contacts, sphere picking, and a header
// with the file, the sphere count, the fit metrics and the run's timings. Without clips it shows
// the bind pose with the loosest spheres marked (`fit --html`).
//
// The page's source is viewer/ in the repository (index.html, viewer.css, viewer.js), compiled
// into the tool with three.js r111 from Debian's libjs-three (MIT; its licence is inside every
// page). The embedded data ("skinspheres.view", version 1) is described in docs/VIEWER.md.
#pragma once

#include <array>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "playback.h"
#include "skinspheres/runtime/format/sphere_set.h"

namespace skinspheres::tool {

struct ViewClip {
  const PlayResult* played = nullptr;                // the run's summary (stage times)
  const std::vector<FrameRecord>* frames = nullptr;  // every frame (RecordFrames): spheres, sphere pairs,
                                                     // intersecting triangle pairs (shown in the contact colour)
  size_t clip_index = 0;                             // into the character's clips
  float fps = 30.0f;
  bool fast = false;  // refit mode of the run
};

struct ViewerPageInput {
  const LoadedCharacter* loaded = nullptr;
  const runtime::SphereSet* set = nullptr;
  double fit_seconds = -1.0;       // < 0: the set was read from a file, not fitted in this run
  std::vector<ViewClip> clips;     // empty: the fit page (bind pose)
  std::vector<std::string> notes;  // extra header lines (e.g. where clips came from)
  // `colliders --html`: {"shapes": [...], "rest": [...], "clips": [[...] per frame] per clip} (the
  // viewer draws them; docs/VIEWER.md); null: none.
  nlohmann::json colliders;
};

// Measures the fit (lib::MeasureFit: union/body volume, boundary distance, each sphere's share of
// it), builds the page and writes it to `path`. Errors name `path` (kFileUnreadable when it
// cannot be written) or the input that is inconsistent (kInvalidArgument).
std::optional<Error> WriteViewerPage(const ViewerPageInput& input, const std::string& path);

}  // namespace skinspheres::tool
