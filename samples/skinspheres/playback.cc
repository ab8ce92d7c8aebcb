#include "playback.h"

#include <sys/resource.h>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>

#include "skinspheres/runtime/api/character.h"
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

// The summary entry of a part pair (kept sorted by parts; at most parts^2 entries).
PartPairSummary& Entry(std::vector<PartPairSummary>& list, uint16_t a, uint16_t b) {
  auto it = std::lower_bound(list.begin(), list.end(), std::pair{a, b}, [](const PartPairSummary& e, const auto& key) {
    return std::pair{e.part_a, e.part_b} < key;
  });
  if (it == list.end() || it->part_a != a || it->part_b != b) {
    PartPairSummary e;
    e.part_a = a;
    e.part_b = b;
    it = list.insert(it, e);
  }
  return *it;
}

std::string PartName(const runtime::SphereSet& set, uint16_t p) {
  return p < set.parts.size() ? set.parts[p].name : "part " + std::to_string(p);
}

}  // namespace

void FrameRanges::Add(int frame) {
  ++frames_;
  if (first_ < 0) first_ = frame;
  if (last_ >= 0 && frame == last_ + 1) {
    if (more_ == 0) ranges_.back().second = frame;  // the last kept range goes on
  } else if (ranges_.size() < kMaxRanges) {
    ranges_.push_back({frame, frame});
  } else {
    ++more_;
  }
  last_ = frame;
}

std::string FrameRanges::ToString() const {
  std::string s;
  for (const auto& [a, b] : ranges_) {
    s += (s.empty() ? "" : ", ") + std::to_string(a) + (b > a ? "-" + std::to_string(b) : "");
  }
  if (more_ > 0) s += ", ... (+" + std::to_string(more_) + " ranges, last frame " + std::to_string(last_) + ")";
  return s;
}

void StageTime::Add(double seconds) {
  const double x = (std::log10(std::max(seconds, 1e-12)) + kDecades - 2) * kBinsPerDecade;  // 1e-8 s -> bin 0
  const int bin = std::clamp(static_cast<int>(std::floor(x)) + 1, 0, static_cast<int>(bins_.size()) - 1);
  ++bins_[bin];
  ++count_;
}

double StageTime::Percentile(double q) const {
  if (count_ == 0) return 0.0;
  const size_t rank = std::min(count_ - 1, static_cast<size_t>(std::floor(q * double(count_ - 1) + 0.5)));
  size_t seen = 0;
  for (size_t b = 0; b < bins_.size(); ++b) {
    seen += bins_[b];
    if (seen > rank) return std::pow(10.0, (double(b) - 0.5) / kBinsPerDecade - (kDecades - 2));
  }
  return 0.0;
}

FrameSink RecordFrames(std::vector<FrameRecord>* out, FrameSink next) {
  return [out, next = std::move(next)](const FrameView& fr) {
    FrameRecord r;
    r.time_s = fr.time_s;
    r.clip_time_s = fr.clip_time_s;
    r.spheres.assign(fr.spheres.begin(), fr.spheres.end());
    r.sphere_pairs.assign(fr.sphere_pairs.begin(), fr.sphere_pairs.end());
    for (const runtime::TrianglePairContact& c : fr.contacts->triangle_pairs) {
      if (c.kind == runtime::TriangleContactKind::kIntersecting) r.triangle_pairs.push_back({c.t, c.u});
    }
    out->push_back(std::move(r));
    if (next) next(fr);
  };
}

long PeakRssKiB() {
  rusage usage{};
  return getrusage(RUSAGE_SELF, &usage) == 0 ? usage.ru_maxrss : 0;
}

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

bool AttachMesh(const lib::RawCharacter& ch, runtime::SphereSet* set) {
  if (set->has_mesh() || set->fast_only || set->source_vertex_count != ch.vertex_count() || set->source_triangle_count != ch.triangle_count()) {
    return false;
  }
  // The skin's bind entries name the character's joints; the set's mesh names the set's (the same
  // names, perhaps in another order).
  skinning::SkinnedMesh mesh = ch.skin;
  for (skinning::BindEntry& b : mesh.binds) {
    if (b.joint < 0 || static_cast<size_t>(b.joint) >= ch.skeleton.joint_names.size()) return false;
    const auto at = std::find(set->joint_names.begin(), set->joint_names.end(), ch.skeleton.joint_names[b.joint]);
    if (at == set->joint_names.end()) return false;
    b.joint = static_cast<decltype(b.joint)>(at - set->joint_names.begin());
  }
  set->mesh = std::move(mesh);
  set->triangle_vertices.clear();
  set->triangle_vertices.reserve(3 * ch.triangle_count());
  for (const auto& t : ch.triangles) {
    for (int c = 0; c < 3; ++c) set->triangle_vertices.push_back(static_cast<uint32_t>(t[c]));
  }
  return true;
}

Result<PlayResult> PlayClip(const LoadedCharacter& loaded, const runtime::SphereSet& set, size_t clip_index,
                            const PlayOptions& options, const FrameSink& sink) {
  const lib::RawCharacter& ch = loaded.character;
  const std::string file = ch.source_file.empty() ? "built-in character" : ch.source_file;
  if (set.fast_only) {  // no triangle lists: nothing for the narrow phase (or --verify) to test
    return MakeError(ErrorCode::kInvalidArgument, set.loaded_from + ": a fast-only sphere set has no triangles, and play "
                                                                    "reports triangle contacts (play the full set)");
  }
  if (!set.has_mesh()) {
    return MakeError(ErrorCode::kVersionMismatch, file + ": the sphere set has no mesh (format version 1): fit it again");
  }
  auto asset = runtime::CharacterAsset::Create(set, runtime::NarrowPhaseSettings{options.margin});
  if (!asset.ok()) return asset.error();
  if (auto err = (*asset)->Matches(ch.skeleton.joint_names, ch.vertex_count())) {
    return MakeError(err->code, file + ": " + err->message);
  }
  // The character's joints by name: a set fitted on the same joints in another order still plays.
  auto mapping = runtime::MapJoints(set, ch.skeleton.joint_names);
  if (!mapping.ok()) return MakeError(mapping.error().code, file + ": " + mapping.error().message);
  // A set read from a file is checked once against this mesh: same triangles (the mesh it carries
  // is the one tested), and every vertex of every owned triangle among its sphere's source
  // vertices (what exact refit reads).
  if (set.source_triangle_count != ch.triangle_count()) {
    return MakeError(ErrorCode::kMismatchedAsset, file + ": the sphere set was fitted on " + std::to_string(set.source_triangle_count) +
                                                      " triangles, this character has " + std::to_string(ch.triangle_count()));
  }
  for (size_t t = 0; t < ch.triangle_count(); ++t) {
    for (int c = 0; c < 3; ++c) {
      if (set.triangle_vertices[3 * t + c] != static_cast<uint32_t>(ch.triangles[t][c])) {
        return MakeError(ErrorCode::kMismatchedAsset, file + ": triangle " + std::to_string(t) +
                                                          " of the sphere set has other vertices than the character's");
      }
    }
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

  // Exact mode skins only the source vertices, through the prepared (SIMD) layout built once; fast
  // mode skins nothing here (the narrow phase skins what it tests); --verify skins every vertex
  // from the plain influence lists.
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
  {
    float lo = INFINITY, hi = -INFINITY;
    for (const auto& p : ch.positions_rest) {
      lo = std::min(lo, p.y());
      hi = std::max(hi, p.y());
    }
    result.body_height = hi > lo ? hi - lo : 0.0f;
  }
  // --verify: every triangle of the mesh must be owned by a sphere (checked once), and lie in it
  // (every frame).
  if (options.verify) {
    std::vector<bool> owned(ch.triangle_count(), false);
    for (uint32_t t : set.triangles) owned[t] = true;
    result.triangles_unowned = static_cast<size_t>(std::count(owned.begin(), owned.end(), false));
  }
  runtime::FrameContacts oracle;
  // Frame count in double, capped: a clip of a million seconds must not overflow or exhaust memory.
  constexpr double kMaxFrames = 1e6;
  const double wanted = options.frames > 0 ? options.frames : std::floor(double(clip.duration_s) * options.fps + 1e-3) + 1.0;
  if (!(wanted <= kMaxFrames)) {
    return MakeError(ErrorCode::kInvalidArgument, file + ": clip \"" + clip.name + "\" would play " + std::to_string(wanted) +
                                                      " frames (at most 1000000)");
  }
  const int frames = std::max(1, static_cast<int>(wanted));
  result.frames = frames;
  for (int f = 0; f < frames; ++f) {
    const float t = f / options.fps;
    const float clip_time = skinning::LoopTime(t, clip.duration_s);
    auto t0 = Clock::now();
    skinning::SamplingJob sampling{&clip, &ch.skeleton, clip_time, locals};
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
    auto status = options.fast ? instance.UpdateFast(joint_world) : instance.UpdateExact(skinned, joint_world);
    if (status.code != ErrorCode::kOk) {
      return MakeError(status.code, file + ": frame " + std::to_string(f) + ": " + status.message);
    }
    auto t3 = Clock::now();
    const auto pairs = instance.Query();
    auto t4 = Clock::now();
    status = instance.FindContacts(options.fast ? std::span<const Eigen::Vector3f>() : std::span<const Eigen::Vector3f>(skinned));
    if (status.code != ErrorCode::kOk) {
      return MakeError(status.code, file + ": frame " + std::to_string(f) + ": " + status.message);
    }
    auto t5 = Clock::now();
    result.times.sample.Add(Seconds(t0, t1));
    result.times.skin.Add(Seconds(t1, t2));
    result.times.refit.Add(Seconds(t2, t3));
    result.times.query.Add(Seconds(t3, t4));
    result.times.narrow.Add(Seconds(t4, t5));
    const runtime::FrameContacts& contacts = instance.frame_contacts();

    // Summaries.
    result.sphere_pairs_total += pairs.size();
    result.sphere_pairs_most = std::max(result.sphere_pairs_most, pairs.size());
    result.triangle_pairs_total += contacts.triangle_pairs.size();
    result.triangle_pairs_most = std::max(result.triangle_pairs_most, contacts.triangle_pairs.size());
    for (const runtime::PartContact& p : contacts.parts) {
      PartPairSummary& e = Entry(result.contacts, p.part_a, p.part_b);
      const bool first_touch = e.frames.frames() == 0;
      e.frames.Add(f);
      e.most_triangle_pairs = std::max(e.most_triangle_pairs, p.triangle_pair_count);
      e.max_depth = std::max(e.max_depth, p.depth);
      if (p.intersecting_count > 0) e.intersecting = true;
      if (p.intersecting_count == 0 && (first_touch || p.min_distance < e.min_distance)) e.min_distance = p.min_distance;
    }
    for (size_t k = 0; k < pairs.size(); ++k) {
      const auto key = std::minmax(pairs[k].part_i, pairs[k].part_j);
      if (k > 0 && std::minmax(pairs[k - 1].part_i, pairs[k - 1].part_j) == key) continue;  // cheap repeat skip
      PartPairSummary& e = Entry(result.sphere_pairs, key.first, key.second);
      if (e.frames.last() != f) e.frames.Add(f);
    }

    const auto spheres = instance.spheres();
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
      // The narrow phase against the brute-force oracle on the whole skinned mesh (the positions the
      // narrow phase read are bit-identical to these).
      if (!runtime::FindContactsBruteForce(set, *(*asset)->narrow_phase(), (*asset)->filter(), skinned, &oracle) ||
          !(oracle == contacts)) {
        if (result.first_mismatch_frame < 0) result.first_mismatch_frame = f;
        ++result.narrow_mismatches;
      }
      result.times.verify.Add(Seconds(v0, Clock::now()));
    }
    if (sink) {
      FrameView view;
      view.index = f;
      view.time_s = t;
      view.clip_time_s = clip_time;
      view.sphere_pairs = pairs;
      view.contacts = &contacts;
      view.spheres = spheres;
      sink(view);
    }
    if (options.progress) {
      std::fprintf(stderr, "\r%s: frame %d/%d, %zu sphere pairs, %zu triangle pairs   ", clip.name.c_str(), f + 1, frames,
                   pairs.size(), contacts.triangle_pairs.size());
    }
  }
  if (options.progress) std::fprintf(stderr, "\n");
  return result;
}

void PrintPlaySummary(const PlayResult& r, const runtime::SphereSet& set, float fps, bool sphere_pairs, bool verify) {
  const double n = r.frames > 0 ? double(r.frames) : 1.0;
  std::printf("clip \"%s\": %d frames at %.0f fps; sphere pairs per frame: mean %.2f, max %zu; triangle pairs per frame: "
              "mean %.2f, max %zu\n",
              r.clip.c_str(), r.frames, fps, double(r.sphere_pairs_total) / n, r.sphere_pairs_most,
              double(r.triangle_pairs_total) / n, r.triangle_pairs_most);
  // Real contacts, by part pair.
  if (r.contacts.empty()) std::printf("  no contacts\n");
  auto share = [&](float d) { return r.body_height > 0.0f ? 100.0 * d / r.body_height : 0.0; };
  for (const PartPairSummary& e : r.contacts) {
    std::printf("  %s - %s: ", PartName(set, e.part_a).c_str(), PartName(set, e.part_b).c_str());
    if (e.intersecting) {
      std::printf("intersecting, frames %s (%zu frames), up to %u triangle pairs, depth up to %.4g (%.2f%% of height)\n",
                  e.frames.ToString().c_str(), e.frames.frames(), e.most_triangle_pairs, e.max_depth, share(e.max_depth));
    } else {
      std::printf("within margin, frames %s (%zu frames), up to %u triangle pairs, closest %.4g (%.2f%% of height)\n",
                  e.frames.ToString().c_str(), e.frames.frames(), e.most_triangle_pairs, e.min_distance, share(e.min_distance));
    }
  }
  if (sphere_pairs) {
    std::printf("sphere pairs (broad phase) by part pair:\n");
    if (r.sphere_pairs.empty()) std::printf("  none\n");
    for (const PartPairSummary& e : r.sphere_pairs) {
      std::printf("  %s - %s: frames %s (%zu frames)\n", PartName(set, e.part_a).c_str(), PartName(set, e.part_b).c_str(),
                  e.frames.ToString().c_str(), e.frames.frames());
    }
  }
  auto stage = [](const char* name, const StageTime& v) {
    if (v.count() > 0) {
      std::printf("  %-7s median %9.1f us   p95 %9.1f us\n", name, v.Percentile(0.5) * 1e6, v.Percentile(0.95) * 1e6);
    }
  };
  std::printf("time per frame:\n");
  stage("sample", r.times.sample);
  stage("skin", r.times.skin);
  stage("refit", r.times.refit);
  stage("query", r.times.query);
  stage("narrow", r.times.narrow);
  stage("verify", r.times.verify);
  if (verify) {
    std::printf("verify: %zu triangle-frames outside their sphere%s, %zu triangles owned by no sphere; narrow phase %s\n",
                r.triangles_outside,
                r.triangles_outside ? (" (first at frame " + std::to_string(r.first_bad_frame) + ")").c_str() : "",
                r.triangles_unowned,
                r.narrow_mismatches == 0
                    ? ("equal to the brute-force oracle in all " + std::to_string(r.frames) + " frames").c_str()
                    : ("differs from the brute-force oracle in " + std::to_string(r.narrow_mismatches) + " frames (first " +
                       std::to_string(r.first_mismatch_frame) + ")")
                          .c_str());
  }
}

}  // namespace skinspheres::tool
