// `skinspheres fix`, callable in-process (the Python module's fix() runs this same code): the clips
// of a character (its own, or other files' retargeted onto it) changed as little as possible so
// that no part pair penetrates deeper than --max-depth, smoothly, each verified on the exact
// contacts, written as glTF animations (ClipFixer, clip_fixer.h).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "check.h"
#include "clip_files.h"
#include "commands.h"

namespace skinspheres::tool {

struct FixArgs {
  std::string input, output, report, html, spheres, clip = "all";
  std::vector<std::string> allow;  // "PART_A:PART_B": part pairs left alone (intended contacts)
  ClipFileOptions clip_files;
  float fps = 30.0f;
  float max_depth = kDefaultTouchTolerance;  // share of the body height
  float ease_s = 0.2f;
  float max_rotation_deg = 60.0f;
  float max_jerk_ratio = 1.5f;  // a fix that raises the moved joints' RMS jerk more than this is refused
  int jobs = 0;
  FitOptions fit;
};

struct FixOutcome {
  // 0: every clip holds at max_depth (fixed or already clean), written; 1: some clip could not be
  // fixed within the limits (it is not written; the others are); 2: bad input (error says why).
  int exit_code = 0;
  std::string error;
  ErrorCode error_code = ErrorCode::kOk;
  nlohmann::json report;  // what --report writes ("format": "skinspheres.fix"); null on bad input
};

// The whole command. quiet: nothing on stdout or stderr (the report and error say it all).
FixOutcome RunFix(FixArgs& a, bool quiet);

void AddFixCommand(CLI::App& app, int* exit_code);

}  // namespace skinspheres::tool
