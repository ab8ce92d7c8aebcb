#include "playback.h"

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>

#include "skinspheres/runtime/character.h"
#include "skinspheres/skinning/local_to_model_job.h"
#include "skinspheres/skinning/prepared_influences.h"
#include "skinspheres/skinning/sampling_job.h"
#include "skinspheres/skinning/skinning_job.h"
#include "skinspheres/skinning/skinning_matrices_job.h"

namespace skinspheres::tool {
namespace {

using Clock = std::chrono::steady_clock;
double Seconds(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); }

std::span<const float> Floats(const std::vector<Eigen::Vector3f>& v) {
  return {reinterpret_cast<const float*>(v.data()), v.size() * 3};
}
std::span<float> Floats(std::vector<Eigen::Vector3f>& v) { return {reinterpret_cast<float*>(v.data()), v.size() * 3}; }

double Percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(std::floor(q * (v.size() - 1) + 0.5)));
  return v[k];
}

}  // namespace

Result<size_t> FindClip(const lib::RawCharacter& ch, const std::string& key) {
  std::string names;
  for (size_t k = 0; k < ch.clips.size(); ++k) {
    if (ch.clips[k].name == key) return k;
    names += (k ? ", " : "") + std::to_string(k) + ":" + ch.clips[k].name;
  }
  size_t k = 0;
  const auto [end, ec] = std::from_chars(key.data(), key.data() + key.size(), k);
  if (!key.empty() && ec == std::errc() && end == key.data() + key.size() && k < ch.clips.size()) return k;
  const std::string file = ch.source_file.empty() ? "built-in character" : ch.source_file;
  if (ch.clips.empty()) return MakeError(ErrorCode::kNotFound, file + ": has no animation clips");
  return MakeError(ErrorCode::kNotFound, file + ": no clip \"" + key + "\"; clips: " + names);
}

Result<PlayResult> PlayClip(const LoadedCharacter& loaded, const runtime::SphereSet& set, size_t clip_index,
                            const PlayOptions& options) {
  const lib::RawCharacter& ch = loaded.character;
  const std::string file = ch.source_file.empty() ? "built-in character" : ch.source_file;
  if (set.fast_only && (!options.fast || options.verify)) {  // no triangle lists to skin or check
    return MakeError(ErrorCode::kInvalidArgument, set.loaded_from + ": a fast-only sphere set plays in fast mode only, "
                                                                    "without --verify (convert the full set instead)");
  }
  auto asset = runtime::CharacterAsset::Create(set);
  if (!asset.ok()) return asset.error();
  if (auto err = (*asset)->Matches(ch.skeleton.joint_names, ch.vertex_count())) {
    return MakeError(err->code, file + ": " + err->message);
  }
  // The character's joints by name: a set fitted on the same joints in another order still plays.
  auto mapping = runtime::MapJoints(set, ch.skeleton.joint_names);
  if (!mapping.ok()) return MakeError(mapping.error().code, file + ": " + mapping.error().message);
  // A set read from a file is checked once against this mesh: same triangle count, and every
  // vertex of every owned triangle among its sphere's source vertices (what exact refit reads).
  if (set.source_triangle_count != ch.triangle_count()) {
    return MakeError(ErrorCode::kMismatchedAsset, file + ": the sphere set was fitted on " + std::to_string(set.source_triangle_count) +
                                                      " triangles, this character has " + std::to_string(ch.triangle_count()));
  }
  for (size_t s = 0; s < set.size(); ++s) {
    const auto first = set.vertices.begin() + set.vertex_offsets[s], last = set.vertices.begin() + set.vertex_offsets[s + 1];
    const bool sorted = std::is_sorted(first, last);
    for (uint32_t k = set.triangle_offsets[s]; k < set.triangle_offsets[s + 1]; ++k) {
      for (int v = 0; v < 3; ++v) {
        const uint32_t vi = static_cast<uint32_t>(ch.triangles[set.triangles[k]][v]);
        const bool listed = sorted ? std::binary_search(first, last, vi) : std::find(first, last, vi) != last;
        if (!listed) {
          return MakeError(ErrorCode::kInvalidData, file + ": sphere " + std::to_string(s) + " owns triangle " +
                                                        std::to_string(set.triangles[k]) + " but not its vertex " + std::to_string(vi));
        }
      }
    }
  }
  auto created = runtime::CharacterInstance::Create(*asset, *mapping);
  if (!created.ok()) return created.error();
  runtime::CharacterInstance& instance = *created;
  const skinning::AnimationClip& clip = ch.clips.at(clip_index);
  const size_t joints = ch.skeleton.size();
  std::vector<skinning::Transform> locals(joints);
  std::vector<skinspheres::Mat4f> joint_world(joints), bind_matrices(ch.skin.binds.size());
  std::vector<Eigen::Vector3f> skinned(ch.vertex_count(), Eigen::Vector3f::Zero());

  // The vertices the exact refit reads: every sphere's source vertices.
  std::vector<uint32_t> sources(set.vertices.begin(), set.vertices.end());
  std::sort(sources.begin(), sources.end());
  sources.erase(std::unique(sources.begin(), sources.end()), sources.end());

  // Every frame skins only the source vertices, through the prepared (SIMD) layout built once;
  // --verify skins every vertex from the plain influence lists.
  skinning::SkinningJob skin_all;
  skin_all.joint_matrices = bind_matrices;
  skin_all.vertex_count = ch.vertex_count();
  skin_all.in_positions = Floats(ch.skin.positions_bind);
  skin_all.out_positions = Floats(skinned);
  skin_all.influence_offsets = ch.skin.influence_offsets;
  skin_all.influence_binds = ch.skin.influence_binds;
  skin_all.influence_weights = ch.skin.influence_weights;
  skinning::PreparedInfluences prepared;
  std::string why;
  if (!prepared.Build(ch.vertex_count(), ch.skin.influence_offsets, ch.skin.influence_binds, ch.skin.influence_weights,
                      sources, &why)) {
    return MakeError(ErrorCode::kInvalidData, file + ": " + why);
  }
  skinning::SkinningJob skin;
  skin.joint_matrices = bind_matrices;
  skin.vertex_count = ch.vertex_count();
  skin.in_positions = skin_all.in_positions;
  skin.out_positions = skin_all.out_positions;
  skin.prepared = &prepared;

  PlayResult result;
  result.clip = clip.name;
  // Frame count in double, capped: a clip of a million seconds must not overflow or exhaust memory.
  constexpr double kMaxFrames = 1e6;
  const double wanted = options.frames > 0 ? options.frames : std::floor(double(clip.duration_s) * options.fps + 1e-3) + 1.0;
  if (!(wanted <= kMaxFrames)) {
    return MakeError(ErrorCode::kInvalidArgument, file + ": clip \"" + clip.name + "\" would play " + std::to_string(wanted) +
                                                      " frames (at most 1000000)");
  }
  const int frames = std::max(1, static_cast<int>(wanted));
  result.frames.resize(frames);
  for (int f = 0; f < frames; ++f) {
    const float t = f / options.fps;
    FramePairs& frame = result.frames[f];
    frame.time_s = t;
    auto t0 = Clock::now();
    skinning::SamplingJob sampling{&clip, &ch.skeleton, skinning::LoopTime(t, clip.duration_s), locals};
    skinning::LocalToModelJob l2m;
    l2m.skeleton = &ch.skeleton;
    l2m.input = locals;
    l2m.output = joint_world;
    skinning::SkinningMatricesJob mats{ch.skin.binds, joint_world, bind_matrices};
    if (!sampling.Run() || !l2m.Run() || !mats.Run()) {
      return MakeError(ErrorCode::kInvalidData, file + ": clip \"" + clip.name + "\" cannot be sampled at t=" + std::to_string(t));
    }
    auto t1 = Clock::now();
    if (!options.fast && !skinning::SkinParallel(skin)) {
      return MakeError(ErrorCode::kInvalidData, file + ": skinning failed (influences do not fit the skeleton)");
    }
    auto t2 = Clock::now();
    const auto status = options.fast ? instance.UpdateFast(joint_world) : instance.UpdateExact(skinned, joint_world);
    if (status.code != ErrorCode::kOk) {
      return MakeError(status.code, file + ": frame " + std::to_string(f) + ": " + status.message);
    }
    auto t3 = Clock::now();
    const auto contacts = instance.Query();
    auto t4 = Clock::now();
    frame.contacts.assign(contacts.begin(), contacts.end());
    result.times.sample.push_back(Seconds(t0, t1));
    result.times.skin.push_back(Seconds(t1, t2));
    result.times.refit.push_back(Seconds(t2, t3));
    result.times.query.push_back(Seconds(t3, t4));
    const auto spheres = instance.spheres();
    if (options.keep_spheres) frame.spheres.assign(spheres.begin(), spheres.end());
    if (options.verify) {
      auto v0 = Clock::now();
      skinning::SkinParallel(skin_all);
      size_t outside = 0;
      for (size_t s = 0; s < set.size(); ++s) {
        const Eigen::Vector3d c = spheres[s].head<3>().cast<double>();
        const double r = spheres[s].w() * (1.0 + 1e-5);
        for (uint32_t k = set.triangle_offsets[s]; k < set.triangle_offsets[s + 1]; ++k) {
          const auto& tri = ch.triangles[set.triangles[k]];
          for (int v = 0; v < 3; ++v) {
            if ((skinned[tri[v]].cast<double>() - c).norm() > r) {
              ++outside;
              break;
            }
          }
        }
      }
      if (outside && result.first_bad_frame < 0) result.first_bad_frame = f;
      result.triangles_outside += outside;
      result.times.verify.push_back(Seconds(v0, Clock::now()));
    }
    if (options.progress) {
      std::fprintf(stderr, "\r%s: frame %d/%d, %zu pairs   ", clip.name.c_str(), f + 1, frames, frame.contacts.size());
    }
  }
  if (options.progress) std::fprintf(stderr, "\n");
  return result;
}

void PrintPlaySummary(const PlayResult& r, const runtime::SphereSet& set, float fps) {
  size_t total = 0, most = 0;
  for (const auto& f : r.frames) {
    total += f.contacts.size();
    most = std::max(most, f.contacts.size());
  }
  std::printf("clip \"%s\": %zu frames at %.0f fps; pairs per frame: mean %.2f, max %zu\n", r.clip.c_str(), r.frames.size(), fps,
              r.frames.empty() ? 0.0 : static_cast<double>(total) / r.frames.size(), most);
  // Body-part pairs and the frame ranges where they touched.
  std::map<std::pair<uint16_t, uint16_t>, std::vector<int>> touched;
  for (size_t f = 0; f < r.frames.size(); ++f) {
    std::map<std::pair<uint16_t, uint16_t>, bool> seen;
    for (const auto& c : r.frames[f].contacts) {
      auto key = std::minmax(c.part_i, c.part_j);
      if (!seen[key]) {
        seen[key] = true;
        touched[key].push_back(static_cast<int>(f));
      }
    }
  }
  if (touched.empty()) std::printf("  no body parts touched\n");
  for (const auto& [key, frames] : touched) {
    std::string ranges;
    for (size_t k = 0; k < frames.size();) {
      size_t e = k;
      while (e + 1 < frames.size() && frames[e + 1] == frames[e] + 1) ++e;
      ranges += (ranges.empty() ? "" : ", ") + std::to_string(frames[k]) + (e > k ? "-" + std::to_string(frames[e]) : "");
      k = e + 1;
    }
    std::printf("  %s - %s: frames %s\n", set.parts[key.first].name.c_str(), set.parts[key.second].name.c_str(), ranges.c_str());
  }
  auto stage = [](const char* name, const std::vector<double>& v) {
    if (!v.empty()) std::printf("  %-7s median %9.1f us   p95 %9.1f us\n", name, Percentile(v, 0.5) * 1e6, Percentile(v, 0.95) * 1e6);
  };
  std::printf("time per frame:\n");
  stage("sample", r.times.sample);
  stage("skin", r.times.skin);
  stage("refit", r.times.refit);
  stage("query", r.times.query);
  stage("verify", r.times.verify);
}

}  // namespace skinspheres::tool
