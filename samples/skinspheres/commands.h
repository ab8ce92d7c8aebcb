// The subcommands of the skinspheres tool. Each returns the process exit code:
// 0 success, 1 a failed check (a triangle outside its sphere), 2 bad input (one line on stderr
// naming the file and the problem).
#pragma once

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "skinspheres/lib/body_parts/body_parts.h"
#include "skinspheres/lib/character/raw_character.h"
#include "skinspheres/lib/fit/sphere_fitter.h"
#include "skinspheres/runtime/format/sphere_set.h"

namespace skinspheres::tool {

inline constexpr int kExitBadInput = 2;

// Prints "skinspheres: <message>" on stderr, on one line (newlines become spaces), and returns
// kExitBadInput.
int Fail(const std::string& message);

// A character to work on: a file (any format Assimp reads) or, with an empty path, the built-in one.
struct LoadedCharacter {
  lib::RawCharacter character;
  lib::BodyParts parts;
  double import_seconds = 0.0;
};
Result<LoadedCharacter> LoadCharacter(const std::string& input, const std::string& parts_file);

// The sphere set a command works with: read from `spheres` (a version-1 file gets the character's
// mesh, AttachMesh), or, when empty, fitted with `settings` (*fit_seconds: the fit's time).
Result<runtime::SphereSet> SphereSetFor(const LoadedCharacter& loaded, const std::string& spheres,
                                        const lib::FitSettings& settings, double* fit_seconds);

// Options shared by `fit`, `play` (fitting on the fly) and `demo`.
struct FitOptions {
  lib::FitSettings settings;
  std::string method = "m1a";
  std::string parts_file;
  bool no_group_blends = false;
  bool no_tighten = false;
  void AddTo(CLI::App& app);
  std::optional<std::string> Resolve();  // fills settings; an error message when refused
};

// One line of what the set's contact rules are (narrow_phase/contact_rules.h): on triangles, their
// hops, rest gap (and its share of the rest height), and the sphere pairs they
// exclude; or, for a set written before them, that its rules are on sphere pairs and depend on the fit.
std::string ContactRulesSummary(const runtime::SphereSet& set);
// The same for the reports: {"on": "triangles" | "sphere_pairs", "hops", "rest_gap"} (model units).
nlohmann::json ContactRulesJson(const runtime::SphereSet& set);

// Prints the fit summary (parts, spheres per part, triangles covered, growth, F, time).
void PrintFitSummary(const lib::FitResult& fit, double import_seconds);

// Writes a sphere set in the format of the path's extension (.json JSON, .ssb binary; fast_only:
// the binary fast-only variant, .ssb only). An error message (naming the path) when refused.
std::optional<std::string> SaveSetFile(const runtime::SphereSet& set, const std::string& path, bool fast_only);

// Two paths naming one file: the same existing file, or the same path once normalised.
bool SameFile(const std::string& a, const std::string& b);
// The outputs a command will write, checked before any work: each (option, path) with a path in an
// existing folder, not a folder itself, not the input or a clip file, and no two the same file.
// A message "<path>: <option> ..." when refused.
std::optional<std::string> CheckOutputPaths(std::span<const std::pair<const char*, std::string>> outputs,
                                            const std::string& input, std::span<const std::string> clip_files);

void AddFitCommand(CLI::App& app, int* exit_code);
void AddConvertCommand(CLI::App& app, int* exit_code);
void AddExportBuiltinCommand(CLI::App& app, int* exit_code);
void AddDemoCommand(CLI::App& app, int* exit_code);
void AddCheckCommand(CLI::App& app, int* exit_code);
void AddRetargetCommand(CLI::App& app, int* exit_code);

// `skinspheres retarget` (retarget_command.cc): the character at `input` with the clips of `files`
// retargeted onto it (those `clip` names: all, a name, or an index among them), each baked to one
// key per frame at fps (lib::BakeClip), written to `output` (.glb). Errors as the tool prints them.
struct RetargetWritten {
  std::vector<std::string> clips;  // the written animations' names
  std::vector<float> durations;    // seconds, per clip
  size_t frames = 0;               // keys per joint, summed over the clips
  size_t joints = 0;               // joints keyed per frame
  std::vector<std::string> notes;  // what retargeting did, per file (as play prints it)
};
struct ClipFileOptions;
Result<RetargetWritten> WriteRetargetedClips(const std::string& input, const ClipFileOptions& files,
                                             const std::string& clip, float fps, const std::string& output);

}  // namespace skinspheres::tool
