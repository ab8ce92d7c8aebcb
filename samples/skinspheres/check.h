// `skinspheres check`, callable in-process (the Python module's check() runs this same code): an
// animation library played on one character, each clip judged against a penetration limit.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "clip_files.h"
#include "commands.h"
#include "playback.h"

namespace skinspheres::tool {

inline constexpr float kDefaultMaxDepth = 0.01f;  // share of the body height

struct CheckArgs {
  std::string input, spheres, clip = "all", mode = "exact", report, csv, html;
  ClipFileOptions clip_files;
  float fps = 30.0f;
  float max_depth = kDefaultMaxDepth;
  float touch_tolerance = kDefaultTouchTolerance;
  int jobs = 0;
  bool compare_source = false;
  FitOptions fit;
};

struct CheckOutcome {
  // 0: no clip penetrates deeper than max_depth; 1: some do; 2: bad input (error says why when
  // nothing could be checked; a clip file that could not be read is in report["errors"]).
  int exit_code = 0;
  std::string error;  // one line; set when nothing was checked
  ErrorCode error_code = ErrorCode::kOk;
  nlohmann::json report;  // what --report writes ("format": "skinspheres.check"); null when nothing was checked
};

// The whole command. quiet: nothing on stdout or stderr (the report and error say it all).
CheckOutcome RunCheck(CheckArgs& a, bool quiet);

}  // namespace skinspheres::tool
