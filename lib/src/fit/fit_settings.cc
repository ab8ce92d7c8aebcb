// FitSettings: validation and the "params" JSON of the sphere-set file. See sphere_fitter.h.
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>

#include "skinspheres/lib/fit/sphere_fitter.h"
#include "skinspheres/runtime/narrow_phase/contact_rules.h"

namespace skinspheres::lib {

const char* ToString(SphereMethod method) {
  switch (method) {
    case SphereMethod::kM1: return "m1";
    case SphereMethod::kM2: return "m2";
    case SphereMethod::kM1A: return "m1a";
  }
  return "?";
}

std::optional<Error> FitSettings::Validate() const {
  auto refuse = [](std::string why) { return MakeError(ErrorCode::kInvalidArgument, std::move(why)); };
  if (rays < 3 || rays > 65535) return refuse("--rays must be in 3..65535 (got " + std::to_string(rays) + ")");
  if (per_level != 1 && per_level != 2 && per_level != 4) {
    return refuse("--per-level must be 1, 2 or 4 (got " + std::to_string(per_level) + ")");
  }
  if (!(overlap >= 0.0f && overlap < 1.0f)) {
    return refuse("--overlap (PD) must be in [0, 1) (got " + std::to_string(overlap) + ")");
  }
  if (!(step >= 1e-4f && step <= 1.0f)) {
    return refuse("--step must be in [0.0001, 1], a fraction of each part's length (got " + std::to_string(step) + ")");
  }
  if (contact_hops < 0 || contact_hops > int(runtime::kMaxContactHops)) {
    return refuse("--hops (contact hops) must be 0, 1 or 2 (got " + std::to_string(contact_hops) + ")");
  }
  if (!(rest_gap >= 0.0f && rest_gap <= runtime::kMaxRestGapShare)) {
    return refuse("--rest-gap must be in [0, " + std::to_string(runtime::kMaxRestGapShare) +
                  "], a share of the rest height (got " + std::to_string(rest_gap) + ")");
  }
  if (refine_iterations < 0 || refine_iterations > 16) {
    return refuse("--refine (iterations) must be in 0..16 (got " + std::to_string(refine_iterations) + ")");
  }
  if (!(split_gain >= 0.0f && split_gain <= 1.0f)) {
    return refuse("--split-gain must be in [0, 1] (got " + std::to_string(split_gain) + ")");
  }
  if (split_rounds < 1 || split_rounds > 64) {
    return refuse("--split-rounds must be in 1..64 (got " + std::to_string(split_rounds) + ")");
  }
  if (!(target_standoff >= 0.0f && target_standoff <= 1.0f)) {
    return refuse("--target-standoff must be in [0, 1] (got " + std::to_string(target_standoff) + ")");
  }
  if (!(piece_edge >= 0.0f && piece_edge <= 1.0f)) {
    return refuse("--piece-edge must be in [0, 1], a share of the body height (got " + std::to_string(piece_edge) +
                  ")");
  }
  if (max_spheres < 1 || max_spheres > 8192) {
    return refuse("--max-spheres must be in 1..8192 (got " + std::to_string(max_spheres) + ")");
  }
  return std::nullopt;
}

std::string FitSettings::ToJson() const {
  nlohmann::json j = {{"rays", rays},
                      {"per_level", per_level},
                      {"per_level_all_parts", per_level_all_parts},
                      {"method", ToString(method)},
                      {"overlap", overlap},
                      {"step", step},
                      {"contact_hops", contact_hops},
                      {"rest_gap", rest_gap},
                      {"refine_iterations", refine_iterations},
                      {"tighten", tighten},
                      {"split_gain", split_gain},
                      {"split_rounds", split_rounds},
                      {"max_spheres", max_spheres},
                      {"target_standoff", target_standoff},
                      {"piece_edge", piece_edge},
                      {"group_blends", group_blends}};
  return j.dump();
}

}  // namespace skinspheres::lib
