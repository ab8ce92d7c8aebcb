// skinspheres fit INPUT -o OUT.json|OUT.ssb [--fast-only] [--rays N] [--per-level 1|2|4] [--method m1|m2|m1a]
//   [--overlap PD] [--step delta] [--parts parts.json] [--hops H] [--no-bind-overlap]
//   [--refine N] [--no-tighten] [--split-gain G] [--target-standoff F] [--max-spheres N]
//   [--piece-edge F] [--compare] [--metrics] [--html V.html]
#include <algorithm>
#include <cstdio>
#include <memory>

#include "commands.h"
#include "html_page.h"
#include "skinspheres/lib/metrics/fit_metrics.h"
#include "skinspheres/runtime/format/sphere_set_io.h"

namespace skinspheres::tool {
namespace {

struct FitArgs {
  std::string input;
  std::string output;
  std::string html;
  bool compare = false;
  bool metrics = false;
  bool fast_only = false;
  FitOptions fit;
};

// The paper's comparison (§6): per part, F mean and max for M1, M2, M1-A at p = 1, 2, 4
// (p applied to every part), with sphere counts: the paper's spheres after ownership, without the
// tightening pass (which would re-cut them the same way whatever p was).
void PrintComparison(const LoadedCharacter& loaded, lib::FitSettings base) {
  std::printf("\ncomparison (F = |r - |c - v_i||, over the kept levels' contact points; p applied to every part)\n");
  std::printf("%-10s %2s %-4s %8s %10s %10s\n", "part", "p", "meth", "spheres", "F mean", "F max");
  std::vector<std::vector<std::string>> rows(loaded.parts.parts.size());
  for (int p : {1, 2, 4}) {
    for (auto method : {lib::SphereMethod::kM1, lib::SphereMethod::kM2, lib::SphereMethod::kM1A}) {
      lib::FitSettings s = base;
      s.per_level = p;
      s.per_level_all_parts = true;
      s.method = method;
      s.tighten = false;
      auto fit = lib::FitSpheres(loaded.character, loaded.parts, s);
      if (!fit.ok()) {
        std::printf("  p=%d %s: %s\n", p, lib::ToString(method), fit.error().message.c_str());
        continue;
      }
      for (size_t k = 0; k < fit->report.parts.size(); ++k) {
        const auto& pr = fit->report.parts[k];
        char line[160];
        std::snprintf(line, sizeof line, "%-10s %2d %-4s %8d %10.6f %10.6f", pr.name.c_str(), p, lib::ToString(method),
                      pr.spheres, pr.f_mean, pr.f_max);
        rows[k].push_back(line);
      }
    }
  }
  for (const auto& part_rows : rows) {
    for (const auto& line : part_rows) std::printf("%s\n", line.c_str());
  }
}

int PrintMetrics(const LoadedCharacter& loaded, const lib::FitResult& fit) {
  const auto& ch = loaded.character;
  const auto& set = fit.spheres;
  lib::FitMetricsInput in;
  in.positions = ch.positions_rest;
  in.triangles = ch.triangles;
  in.centers = set.centers_rest;
  in.radii = set.radii_rest;
  in.owner_offsets = set.triangle_offsets;
  in.owned_triangles = set.triangles;
  in.piece_offsets = set.piece_offsets;
  in.pieces = set.pieces;
  auto m = lib::MeasureFit(in);
  if (!m.ok()) return Fail(m.error().message);
  // The naive reference: one sphere per joint around the vertices it dominates.
  std::vector<uint32_t> dominant(ch.vertex_count(), 0);
  for (size_t v = 0; v < ch.vertex_count(); ++v) {
    float best = -1.0f;
    for (uint32_t k = ch.skin.influence_offsets[v]; k < ch.skin.influence_offsets[v + 1]; ++k) {
      if (ch.skin.influence_weights[k] > best) {
        best = ch.skin.influence_weights[k];
        dominant[v] = static_cast<uint32_t>(ch.skin.binds[ch.skin.influence_binds[k]].joint);
      }
    }
  }
  double naive_ratio = 0.0;
  size_t naive_count = 0;
  if (auto naive = lib::NaiveJointSpheres(ch.positions_rest, dominant); naive.ok()) {
    lib::FitMetricsInput nin;
    nin.positions = ch.positions_rest;
    nin.triangles = ch.triangles;
    nin.centers = naive->centers;
    nin.radii = naive->radii;
    if (auto nm = lib::MeasureFit(nin); nm.ok()) naive_ratio = nm->volume_ratio;
    naive_count = naive->centers.size();
  }
  std::printf(
      "tightness: %zu spheres; union volume / body volume = %.3f (naive one sphere per joint: %.3f with %zu spheres); "
      "boundary to surface: mean %.4f, p95 %.4f, max %.4f of body height; uncovered triangles %zu\n",
      set.size(), m->volume_ratio, naive_ratio, naive_count, m->boundary_distance_mean_rel,
      m->boundary_distance_p95_rel, m->boundary_distance_max_rel, m->uncovered_triangles);
  std::printf("  (voxel grid %dx%dx%d, body volume %.6g, body covered %.4f, ambiguous voxels %.4f)\n", m->grid_dims.x(),
              m->grid_dims.y(), m->grid_dims.z(), m->body_volume, m->body_covered_fraction, m->body_ambiguous_fraction);
  // Where the boundary stands off most: the spheres with the largest share of the mean distance.
  std::vector<size_t> order(set.size());
  for (size_t s = 0; s < order.size(); ++s) order[s] = s;
  const auto& share = m->sphere_boundary_distance;
  if (share.size() == set.size()) {
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return share[a] > share[b]; });
    std::printf("  largest shares of the boundary distance:");
    for (size_t k = 0; k < std::min<size_t>(5, order.size()); ++k) {
      const size_t s = order[k];
      std::printf(" #%zu %s/%s %.0f%%", s, set.parts[set.sphere_part[s]].name.c_str(),
                  set.joint_names[set.sphere_joint[s]].c_str(),
                  m->boundary_distance_mean > 0 ? 100.0 * share[s] / m->boundary_distance_mean : 0.0);
    }
    std::printf("\n");
  }
  return m->uncovered_triangles == 0 ? 0 : 1;
}

int RunFit(FitArgs& args) {
  if (auto why = args.fit.Resolve()) return Fail(*why);
  if (!args.output.empty() && !runtime::SphereSetFormatForPath(args.output)) {  // before a long fit
    return Fail(args.output + ": unknown sphere-set extension (use .json for JSON or .ssb for binary)");
  }
  if (args.fast_only && args.output.empty()) {
    return Fail("--fast-only needs a binary output (-o OUT.ssb): it says what the written set leaves out");
  }
  auto loaded = LoadCharacter(args.input, args.fit.parts_file);
  if (!loaded.ok()) return Fail(loaded.error().message);
  auto fit = lib::FitSpheres(loaded->character, loaded->parts, args.fit.settings);
  if (!fit.ok()) {
    const int code = Fail(fit.error().message);
    return fit.error().code == ErrorCode::kCheckFailed ? 1 : code;
  }
  std::printf("%s: %zu vertices, %zu triangles, %zu joints, %zu clips\n",
              args.input.empty() ? "built-in character" : args.input.c_str(), loaded->character.vertex_count(),
              loaded->character.triangle_count(), loaded->character.skeleton.size(), loaded->character.clips.size());
  PrintFitSummary(*fit, loaded->import_seconds);
  if (!args.output.empty()) {
    if (auto why = SaveSetFile(fit->spheres, args.output, args.fast_only)) return Fail(*why);
    std::printf("wrote %s\n", args.output.c_str());
  }
  if (!args.html.empty()) {
    if (auto err = WriteViewerPage(ViewerPageInput{&*loaded, &fit->spheres, fit->report.seconds, {}, {}, nullptr},
                                   args.html)) {
      return Fail(err->message);
    }
    std::printf("wrote %s\n", args.html.c_str());
  }
  int code = 0;
  if (args.metrics) code = PrintMetrics(*loaded, *fit);
  if (args.compare) PrintComparison(*loaded, args.fit.settings);
  return code;
}

}  // namespace

void AddFitCommand(CLI::App& app, int* exit_code) {
  auto args = std::make_shared<FitArgs>();
  CLI::App* cmd = app.add_subcommand("fit", "fit a sphere set to a skinned character file");
  cmd->add_option("input", args->input, "character file (glTF/GLB, FBX, ... as Assimp reads)")->required();
  cmd->add_option("-o,--output", args->output, "sphere set to write: .json (JSON) or .ssb (binary)");
  cmd->add_flag("--fast-only", args->fast_only,
                "with -o X.ssb: leave out what only exact mode and triangle tests read (smaller; exact mode refused)");
  cmd->add_flag("--compare", args->compare, "print the paper's comparison: F for M1, M2, M1-A at p = 1, 2, 4");
  cmd->add_flag("--metrics", args->metrics, "measure tightness: union volume / body volume, boundary distance");
  cmd->add_option("--html", args->html, "write the viewer page: the bind pose, spheres by part, the loosest marked");
  args->fit.AddTo(*cmd);
  cmd->callback([args, exit_code] { *exit_code = RunFit(*args); });
}

}  // namespace skinspheres::tool
