#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "commands.h"
#include "playback.h"
#include "skinspheres/lib/character/builtin_character.h"
#include "skinspheres/lib/io/importer.h"
#include "skinspheres/runtime/format/file_io.h"
#include "skinspheres/runtime/format/sphere_set_io.h"
#include "skinspheres/runtime/narrow_phase/contact_rules.h"

namespace skinspheres::tool {

int Fail(const std::string& message) {
  // One line whatever the message holds (a file name or a set's joint names may contain newlines).
  std::cerr << "skinspheres: " << runtime::OneLine(message) << std::endl;
  return kExitBadInput;
}

Result<LoadedCharacter> LoadCharacter(const std::string& input, const std::string& parts_file) {
  LoadedCharacter out;
  const auto start = std::chrono::steady_clock::now();
  if (input.empty()) {
    out.character = lib::MakeBuiltinCharacter();
  } else {
    auto imported = lib::ImportCharacter(input);
    if (!imported.ok()) return imported.error();
    out.character = std::move(imported).value();
  }
  out.import_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::optional<lib::PartOverrides> overrides;
  if (!parts_file.empty()) {
    auto loaded = lib::LoadPartOverrides(parts_file, &out.character.skeleton);
    if (!loaded.ok()) return loaded.error();
    overrides = std::move(loaded).value();
  }
  auto parts = lib::SplitBodyParts(out.character, overrides ? &*overrides : nullptr);
  if (!parts.ok()) return parts.error();
  out.parts = std::move(parts).value();
  return out;
}

Result<runtime::SphereSet> SphereSetFor(const LoadedCharacter& loaded, const std::string& spheres,
                                        const lib::FitSettings& settings, double* fit_seconds) {
  if (!spheres.empty()) {
    auto read = runtime::LoadSphereSet(spheres);
    if (!read.ok()) return read.error();
    runtime::SphereSet set = std::move(read).value();
    AttachMesh(loaded.character, &set);
    return set;
  }
  auto fit = lib::FitSpheres(loaded.character, loaded.parts, settings);
  if (!fit.ok()) return fit.error();
  *fit_seconds = fit->report.seconds;
  return std::move(fit->spheres);
}

void FitOptions::AddTo(CLI::App& app) {
  app.add_option("--rays", settings.rays, "rays per disk, Nr (alpha = 360/Nr)")->capture_default_str();
  app.add_option("--per-level", settings.per_level, "spheres per disk level for the torso: 1, 2 or 4")
      ->capture_default_str();
  app.add_option("--method", method, "sphere per group: m1 (centroid), m2 (Welzl minimum ball), m1a (M1 adjusted)")
      ->capture_default_str();
  app.add_option("--overlap", settings.overlap, "penetration depth PD between levels, in [0, 1)")
      ->capture_default_str();
  app.add_option("--step", settings.step, "disk step delta, as a fraction of each part's length")
      ->capture_default_str();
  app.add_option("--parts", parts_file, "JSON file mapping joint names to part names (overrides)");
  app.add_option(
         "--hops", settings.contact_hops,
         "contact rule 2: triangles whose joints are at most this many bones apart are never a contact: 0, 1, 2")
      ->capture_default_str();
  app.add_option("--rest-gap", settings.rest_gap,
                 "contact rule 3: triangles closer than this fraction of the rest height at rest are never a contact "
                 "(creases, layers), at most 0.05")
      ->capture_default_str();
  app.add_option("--refine", settings.refine_iterations,
                 "minimum-ball rounds after ownership (0: keep the paper's centres)")
      ->capture_default_str();
  app.add_flag("--no-tighten", no_tighten,
               "skip the tightening pass (centre search, hand-over, splitting): the paper's spheres after ownership");
  app.add_option(
         "--split-gain", settings.split_gain,
         "tightening: split a sphere when its halves expose at most this fraction of what it exposes (0: never)")
      ->capture_default_str();
  app.add_option("--split-rounds", settings.split_rounds,
                 "tightening: after a round of splitting that did not reach the target standoff, search, hand over, "
                 "merge and split again (kept when it lowers the estimated standoff by 1%), at most this many rounds "
                 "(1..64; 1: one greedy loop)")
      ->capture_default_str();
  app.add_option("--target-standoff", settings.target_standoff,
                 "tightening: stop splitting once the union stands off the body by this fraction of its height on "
                 "average (0: split while it pays)")
      ->capture_default_str();
  app.add_option("--max-spheres", settings.max_spheres,
                 "the budget: at most this many spheres (the cheapest pairs of a part are merged down to it, "
                 "splitting stops at it; at least the character's body parts)")
      ->capture_default_str();
  app.add_option("--piece-edge", settings.piece_edge,
                 "cut triangles longer than this fraction of the body height into pieces that spheres own apart "
                 "(docs/TRIANGLE_PIECES.md; 0: keep every triangle whole)")
      ->capture_default_str();
  app.add_flag("--no-group-blends", no_group_blends,
               "store no reach-group blends (by default they are stored where they make the fast spheres "
               "0.75% tighter or more): a faster fast refit, looser fast spheres (docs/FIT_REPORT.md)");
}

std::optional<std::string> FitOptions::Resolve() {
  if (method == "m1") {
    settings.method = lib::SphereMethod::kM1;
  } else if (method == "m2") {
    settings.method = lib::SphereMethod::kM2;
  } else if (method == "m1a") {
    settings.method = lib::SphereMethod::kM1A;
  } else {
    return "--method must be m1, m2 or m1a (got " + method + ")";
  }
  settings.group_blends = !no_group_blends;
  settings.tighten = !no_tighten;
  if (auto refused = settings.Validate()) return refused->message;
  return std::nullopt;
}

std::string ContactRulesSummary(const runtime::SphereSet& set) {
  const size_t pairs = set.size() * (set.size() - (set.size() > 0)) / 2;
  size_t excluded[3] = {0, 0, 0};
  for (const auto& p : set.excluded_pairs) ++excluded[static_cast<int>(p.reason)];
  char text[400];
  if (set.contact_rules == runtime::ContactRules::kSpherePairs) {
    std::snprintf(text, sizeof text,
                  "contact rules on sphere pairs (written before the rules on triangles: what it reports depends on "
                  "its fit; fit the character again): %zu of %zu sphere pairs excluded (same joint %zu, adjacent "
                  "joints %zu, overlapping at rest %zu)",
                  set.excluded_pairs.size(), pairs, excluded[0], excluded[1], excluded[2]);
    return text;
  }
  std::string share;
  std::vector<Eigen::Vector3f> rest;
  if (set.has_mesh() && runtime::RestPositions(set, &rest)) {
    const float height = runtime::RestHeight(rest);
    if (height > 0.0f) {
      char s[48];
      std::snprintf(s, sizeof s, " (%.2f%% of the rest height)", 100.0 * set.rest_gap / height);
      share = s;
    }
  }
  std::snprintf(text, sizeof text,
                "contact rules on triangles: not joints %u bone%s apart or nearer, nor closer than %.4g at rest%s; "
                "%zu of %zu sphere pairs excluded (every joint pair within the hops)",
                set.contact_hops, set.contact_hops == 1 ? "" : "s", double(set.rest_gap), share.c_str(),
                set.excluded_pairs.size(), pairs);
  return text;
}

nlohmann::json ContactRulesJson(const runtime::SphereSet& set) {
  return {{"on", runtime::ToString(set.contact_rules)}, {"hops", set.contact_hops}, {"rest_gap", set.rest_gap}};
}

void PrintFitSummary(const lib::FitResult& fit, double import_seconds) {
  const auto& r = fit.report;
  const auto& set = fit.spheres;
  std::printf("parts:\n");
  std::printf("  %-10s %8s %8s %7s %9s %9s\n", "part", "triangles", "spheres", "levels", "F mean", "F max");
  for (const auto& p : r.parts) {
    std::printf("  %-10s %8d %8d %7d %9.5f %9.5f\n", p.name.c_str(), p.triangles, p.spheres, p.levels_kept, p.f_mean,
                p.f_max);
  }
  std::printf("spheres: %zu   %s\n", set.size(), ContactRulesSummary(set).c_str());
  std::printf("triangles covered: %d of %u (bind-pose check)\n", r.triangles_covered, set.source_triangle_count);
  std::printf(
      "growth: %d spheres grew to hold their triangles, by %.4f of body height on average, %.4f at most; %d shrank; %d "
      "dropped\n",
      r.spheres_grown, r.growth_mean, r.growth_max, r.spheres_shrunk, r.spheres_dropped);
  if (r.spheres_merged_for_budget > 0) {
    std::printf("budget: %d pairs merged to meet --max-spheres\n", r.spheres_merged_for_budget);
  }
  if (r.standoff_before > 0.0f) {
    std::printf(
        "tightening: mean standoff %.2f%% -> %.2f%% of body height (estimated); %d spheres added by splits, "
        "%d merged, %d triangles handed over to a sphere that already held them; %d split round%s\n",
        100.0 * r.standoff_before, 100.0 * r.standoff_after, r.spheres_split, r.spheres_merged, r.triangles_handed_over,
        r.split_rounds, r.split_rounds == 1 ? "" : "s");
  }
  if (!set.fast_reference_spheres.empty()) {
    std::printf("fast refit: the bind pose is its reference (the rest pose is not the bind pose, and bounds looser)\n");
  }
  std::printf("F (paper): mean %.6f, max %.6f (body height %.4f)\n", r.f_mean, r.f_max, r.body_height);
  std::printf("time: import %.1f ms, fit %.1f ms\n", import_seconds * 1e3, r.seconds * 1e3);
}

bool SameFile(const std::string& a, const std::string& b) {
  if (a.empty() || b.empty()) return false;
  std::error_code ec;
  if (std::filesystem::equivalent(a, b, ec)) return true;
  const auto x = std::filesystem::weakly_canonical(a, ec), y = std::filesystem::weakly_canonical(b, ec);
  return !ec && x == y;
}

std::optional<std::string> CheckOutputPaths(std::span<const std::pair<const char*, std::string>> outputs,
                                            const std::string& input, std::span<const std::string> clip_files) {
  for (size_t k = 0; k < outputs.size(); ++k) {
    const auto& [option, path] = outputs[k];
    if (path.empty()) continue;
    std::error_code ec;
    const auto parent = std::filesystem::path(path).parent_path();
    if (!parent.empty() && !std::filesystem::is_directory(parent, ec))
      return path + ": " + option + ": no folder " + parent.string();
    if (std::filesystem::is_directory(path, ec)) return path + ": " + option + ": is a folder";
    if (SameFile(path, input)) return path + ": " + option + " would overwrite the character file";
    for (const std::string& file : clip_files) {
      if (SameFile(path, file)) return path + ": " + option + " would overwrite a --clips file";
    }
    for (size_t i = 0; i < k; ++i) {
      if (SameFile(path, outputs[i].second))
        return path + ": " + option + " and " + outputs[i].first + " name the same file";
    }
  }
  return std::nullopt;
}

}  // namespace skinspheres::tool
