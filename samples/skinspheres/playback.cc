#include "playback.h"

#include <sys/resource.h>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>

#include "skinspheres/lib/geometry/mesh_helpers.h"
#include "skinspheres/lib/retarget/bake_clip.h"
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
    r.contact_sphere_pairs.assign(fr.contacts->sphere_pairs.begin(), fr.contacts->sphere_pairs.end());
    for (const runtime::TriangleContact& c : fr.contacts->triangle_pairs) {
      if (c.kind == runtime::TriangleContactKind::kIntersecting)
        r.triangle_pairs.push_back({c.triangle_a, c.triangle_b});
    }
    for (const runtime::PartContact& p : fr.contacts->parts) {
      r.parts.push_back({p.part_a, p.part_b, p.kind == runtime::PartContactKind::kPenetrating, p.depth});
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
  if (set->has_mesh() || set->fast_only || set->source_vertex_count != ch.vertex_count() ||
      set->source_triangle_count != ch.triangle_count()) {
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

float PlaybackTime(float time_s, float duration_s) {
  if (!(duration_s > 0.0f) || !std::isfinite(time_s)) return 0.0f;
  if (time_s >= 0.0f && time_s <= duration_s) return time_s;
  return skinning::LoopTime(time_s, duration_s);
}

void AddTouchToleranceOption(CLI::App& app, float* share) {
  app.add_option("--touch-tolerance", *share,
                 "a part pair whose triangles intersect by at most this share of the body height is touching, deeper "
                 "penetrating")
      ->capture_default_str();
}

std::optional<std::string> CheckTouchTolerance(float share) {
  if (share >= 0.0f && share < 1.0f) return std::nullopt;
  return "--touch-tolerance must be a share of the body height in [0, 1)";
}

runtime::NarrowPhaseSettings NarrowSettings(const PlayOptions& options) {
  runtime::NarrowPhaseSettings narrow;
  narrow.margin = options.margin;
  narrow.touch_tolerance_share = options.touch_tolerance;
  return narrow;
}

namespace {

// Playback, step 1: the set belongs to this character: same joints (by name), same triangles
// (the mesh it carries is the one tested), and every vertex of every owned triangle among its
// sphere's source vertices (what the exact refit reads).
std::optional<Error> CheckSetMatchesCharacter(const lib::RawCharacter& ch, const runtime::SphereSet& set,
                                              const std::string& file) {
  if (set.source_triangle_count != ch.triangle_count()) {
    return MakeError(ErrorCode::kMismatchedAsset,
                     file + ": the sphere set was fitted on " + std::to_string(set.source_triangle_count) +
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
    const auto first = set.vertices.begin() + set.vertex_offsets[s],
               last = set.vertices.begin() + set.vertex_offsets[s + 1];
    const bool sorted = std::is_sorted(first, last);
    for (uint32_t k = set.triangle_offsets[s]; k < set.triangle_offsets[s + 1]; ++k) {
      for (int v = 0; v < 3; ++v) {
        const uint32_t vi = static_cast<uint32_t>(ch.triangles[set.triangles[k]][v]);
        const bool listed = sorted ? std::binary_search(first, last, vi) : std::find(first, last, vi) != last;
        if (!listed) {
          return MakeError(ErrorCode::kInvalidData, file + ": sphere " + std::to_string(s) + " owns triangle " +
                                                        std::to_string(set.triangles[k]) + " but not its vertex " +
                                                        std::to_string(vi));
        }
      }
    }
  }
  return std::nullopt;
}

}  // namespace

std::vector<int32_t> SkinJoints(const lib::RawCharacter& ch) {
  std::vector<int32_t> joints;
  std::vector<char> seen(ch.skeleton.size(), 0);
  for (const skinning::BindEntry& b : ch.skin.binds) {
    if (b.joint < 0 || static_cast<size_t>(b.joint) >= seen.size() || seen[static_cast<size_t>(b.joint)]) continue;
    seen[static_cast<size_t>(b.joint)] = 1;
    joints.push_back(b.joint);
  }
  return joints;
}

std::string Playback::file() const {
  return loaded_.character.source_file.empty() ? "built-in character" : loaded_.character.source_file;
}

Result<std::shared_ptr<const Playback>> Playback::Create(const LoadedCharacter& loaded, const runtime::SphereSet& set,
                                                         const runtime::NarrowPhaseSettings& narrow) {
  const lib::RawCharacter& ch = loaded.character;
  std::shared_ptr<Playback> p(new Playback(loaded, set));
  const std::string file = p->file();
  if (set.fast_only) {  // no triangle lists: nothing for the narrow phase (or --verify) to test
    return MakeError(ErrorCode::kInvalidArgument, set.loaded_from +
                                                      ": a fast-only sphere set has no triangles, and play "
                                                      "reports triangle contacts (play the full set)");
  }
  if (!set.has_mesh()) {
    return MakeError(ErrorCode::kVersionMismatch,
                     file + ": the sphere set has no mesh (format version 1): fit it again");
  }
  auto asset = runtime::CharacterAsset::Create(set, narrow);
  if (!asset.ok()) return asset.error();
  if (auto err = (*asset)->Matches(ch.skeleton.joint_names, ch.vertex_count())) {
    return MakeError(err->code, file + ": " + err->message);
  }
  // The character's joints by name: a set fitted on the same joints in another order still plays.
  auto mapping = runtime::MapJoints(set, ch.skeleton.joint_names);
  if (!mapping.ok()) return MakeError(mapping.error().code, file + ": " + mapping.error().message);
  if (auto err = CheckSetMatchesCharacter(ch, set, file)) return *err;
  p->asset_ = std::move(*asset);
  p->mapping_ = std::move(*mapping);
  // The vertices the exact refit reads: every sphere's source vertices, skinned through the
  // prepared (SIMD) layout built once.
  p->sources_ = runtime::SourceVerticesOfPoints(set);  // a grid point needs its triangle's vertices
  std::string why;
  if (!p->prepared_.Build(ch.vertex_count(), ch.skin.influence_offsets, ch.skin.influence_binds,
                          ch.skin.influence_weights, p->sources_, &why)) {
    return MakeError(ErrorCode::kInvalidData, file + ": " + why);
  }
  p->body_height_ = lib::BodyHeight(ch.positions_rest);
  return std::shared_ptr<const Playback>(std::move(p));
}

Result<ClipPlayer> ClipPlayer::Create(std::shared_ptr<const Playback> playback, const PlayOptions& options) {
  auto created = runtime::CharacterInstance::Create(playback->asset(), playback->mapping());
  if (!created.ok()) return created.error();
  const lib::RawCharacter& ch = playback->loaded().character;
  ClipPlayer player;
  player.playback_ = std::move(playback);
  player.options_ = options;
  player.instance_.emplace(std::move(*created));
  player.locals_.resize(ch.skeleton.size());
  player.joint_world_.resize(ch.skeleton.size());
  player.bind_matrices_.resize(ch.skin.binds.size());
  player.skinned_.assign(ch.vertex_count(), Eigen::Vector3f::Zero());
  return player;
}

// Frame count in double, capped: a clip of a million seconds must not overflow or exhaust memory.
Result<size_t> ClipPlayer::FrameCount(const skinning::AnimationClip& clip) const {
  const double wanted = options_.frames > 0 ? options_.frames : lib::FramesAt(clip.duration_s, options_.fps);
  if (!(wanted <= lib::kMaxFrames)) {
    return MakeError(ErrorCode::kInvalidArgument, playback_->file() + ": clip \"" + clip.name + "\" would play " +
                                                      std::to_string(wanted) + " frames (at most 1000000)");
  }
  return static_cast<size_t>(std::max(1.0, wanted));
}

// One frame: sample, local to model, skinning matrices; skin the source vertices (exact mode);
// refit; query the sphere pairs; the narrow phase. Each stage timed into `times`.
std::optional<Error> ClipPlayer::Step(const skinning::AnimationClip& clip, int f, float clip_time, StageTimes* times) {
  const lib::RawCharacter& ch = playback_->loaded().character;
  const auto t0 = Clock::now();
  if (!skinning::SamplingJob{&clip, &ch.skeleton, clip_time, locals_}.Run()) {
    return MakeError(ErrorCode::kInvalidData, playback_->file() + ": clip \"" + clip.name +
                                                  "\" cannot be sampled at t=" + std::to_string(clip_time));
  }
  return Pose(f, t0, times);
}

std::optional<Error> ClipPlayer::PlayPose(std::span<const skinning::Transform> locals, int frame) {
  if (locals.size() != locals_.size()) {
    return MakeError(ErrorCode::kInvalidArgument, playback_->file() + ": a pose of " + std::to_string(locals.size()) +
                                                      " joints for a skeleton of " + std::to_string(locals_.size()));
  }
  std::copy(locals.begin(), locals.end(), locals_.begin());
  StageTimes times;
  return Pose(frame, Clock::now(), &times);
}

std::optional<Error> ClipPlayer::Pose(int f, Clock::time_point t0, StageTimes* times) {
  const lib::RawCharacter& ch = playback_->loaded().character;
  const std::string file = playback_->file();
  runtime::CharacterInstance& instance = *instance_;
  skinning::LocalToModelJob l2m;
  l2m.skeleton = &ch.skeleton;
  l2m.input = locals_;
  l2m.output = joint_world_;
  skinning::SkinningMatricesJob mats{ch.skin.binds, joint_world_, bind_matrices_};
  if (!l2m.Run() || !mats.Run()) {
    return MakeError(ErrorCode::kInvalidData, file + ": frame " + std::to_string(f) + ": the pose cannot be posed");
  }
  const auto t1 = Clock::now();
  if (!options_.fast) {
    skinning::SkinningJob skin;
    skin.joint_matrices = bind_matrices_;
    skin.vertex_count = ch.vertex_count();
    skin.in_positions = Floats(ch.skin.positions_bind);
    skin.out_positions = Floats(skinned_);
    skin.prepared = &playback_->prepared();
    if (!skin.RunParallel()) {
      return MakeError(ErrorCode::kInvalidData, file + ": skinning failed (influences do not fit the skeleton)");
    }
  }
  const auto t2 = Clock::now();
  auto status = options_.fast ? instance.UpdateFast(joint_world_) : instance.UpdateExact(skinned_, joint_world_);
  if (status.code != ErrorCode::kOk)
    return MakeError(status.code, file + ": frame " + std::to_string(f) + ": " + status.message);
  const auto t3 = Clock::now();
  pairs_ = instance.FindSpherePairs();
  const auto t4 = Clock::now();
  status = instance.FindContacts(options_.fast ? std::span<const Eigen::Vector3f>()
                                               : std::span<const Eigen::Vector3f>(skinned_));
  if (status.code != ErrorCode::kOk)
    return MakeError(status.code, file + ": frame " + std::to_string(f) + ": " + status.message);
  const auto t5 = Clock::now();
  times->sample.Add(Seconds(t0, t1));
  times->skin.Add(Seconds(t1, t2));
  times->refit.Add(Seconds(t2, t3));
  times->query.Add(Seconds(t3, t4));
  times->narrow.Add(Seconds(t4, t5));
  return std::nullopt;
}

// The frame's sphere pairs and contacts into the clip's bounded summaries.
void ClipPlayer::Summarise(int f, PlayResult* result) const {
  const runtime::FrameContacts& contacts = instance_->contacts();
  result->sphere_pairs_total += pairs_.size();
  result->sphere_pairs_most = std::max(result->sphere_pairs_most, pairs_.size());
  result->triangle_pairs_total += contacts.triangle_pairs.size();
  result->triangle_pairs_most = std::max(result->triangle_pairs_most, contacts.triangle_pairs.size());
  for (const runtime::PartContact& p : contacts.parts) {
    PartPairSummary& e = Entry(result->contacts, p.part_a, p.part_b);
    const bool first_touch = e.frames.frames() == 0;
    e.frames.Add(f);
    if (p.kind == runtime::PartContactKind::kPenetrating) e.penetrating.Add(f);
    e.most_triangle_pairs = std::max(e.most_triangle_pairs, p.triangle_pair_count);
    if (e.worst_frame < 0 || p.depth > e.max_depth) {
      e.worst_frame = f;
      e.max_depth = p.depth;
    }
    if (p.intersecting_count > 0) e.intersecting = true;
    if (p.intersecting_count == 0 && (first_touch || p.min_distance < e.min_distance)) e.min_distance = p.min_distance;
  }
  for (size_t k = 0; k < pairs_.size(); ++k) {
    const auto key = std::minmax(pairs_[k].part_i, pairs_[k].part_j);
    if (k > 0 && std::minmax(pairs_[k - 1].part_i, pairs_[k - 1].part_j) == key) continue;  // cheap repeat skip
    PartPairSummary& e = Entry(result->sphere_pairs, key.first, key.second);
    if (e.frames.last() != f) e.frames.Add(f);
  }
}

// --verify: every vertex skinned from the plain influence lists; every owned triangle inside its
// sphere; the narrow phase equal to the brute-force oracle on the whole skinned mesh (the
// positions the narrow phase read are bit-identical to these).
void ClipPlayer::Verify(int f, PlayResult* result) {
  const lib::RawCharacter& ch = playback_->loaded().character;
  const runtime::SphereSet& set = playback_->set();
  const auto v0 = Clock::now();
  skinning::SkinningJob skin_all;
  skin_all.joint_matrices = bind_matrices_;
  skin_all.vertex_count = ch.vertex_count();
  skin_all.in_positions = Floats(ch.skin.positions_bind);
  skin_all.out_positions = Floats(skinned_);
  skin_all.influence_offsets = ch.skin.influence_offsets;
  skin_all.influence_binds = ch.skin.influence_binds;
  skin_all.influence_weights = ch.skin.influence_weights;
  skin_all.RunParallel();
  const auto spheres = instance_->spheres();
  size_t outside = 0;
  for (size_t s = 0; s < set.size(); ++s) {
    const Eigen::Vector3d c = spheres[s].head<3>().cast<double>();
    const double r = spheres[s].w() * (1.0 + 1e-5);
    double needed = 0.0;  // the radius around this centre that holds the sphere's triangles and pieces
    auto check = [&](const Eigen::Vector3f* corner) {
      bool out = false;
      for (int v = 0; v < 3; ++v) {
        const double d = (corner[v].cast<double>() - c).norm();
        needed = std::max(needed, d);
        out |= d > r;
      }
      outside += out ? 1 : 0;
    };
    for (uint32_t k = set.triangle_offsets[s]; k < set.triangle_offsets[s + 1]; ++k) {
      const auto& tri = ch.triangles[set.triangles[k]];
      const Eigen::Vector3f corner[3] = {skinned_[tri[0]], skinned_[tri[1]], skinned_[tri[2]]};
      check(corner);
    }
    for (const runtime::TrianglePiece& piece : set.PiecesOf(s)) {  // each piece's corners
      const auto& tri = ch.triangles[piece.triangle];
      uint8_t grid[3][2];
      runtime::PieceCorners(piece.level, piece.index, grid);
      Eigen::Vector3f corner[3];
      for (int v = 0; v < 3; ++v) {
        corner[v] = runtime::GridPoint(skinned_[tri[0]], skinned_[tri[1]], skinned_[tri[2]], piece.level, grid[v][0],
                                       grid[v][1]);
      }
      check(corner);
    }
    if (needed > 0.0) {
      result->radius_ratio_sum += spheres[s].w() / needed;
      ++result->radius_ratio_count;
    }
  }
  if (outside && result->first_bad_frame < 0) result->first_bad_frame = f;
  result->triangles_outside += outside;
  const runtime::CharacterAsset& asset = *playback_->asset();
  if (!runtime::FindContactsBruteForce(set, *asset.narrow_phase(), asset.filter(), skinned_, &oracle_) ||
      !(oracle_ == instance_->contacts())) {
    if (result->first_mismatch_frame < 0) result->first_mismatch_frame = f;
    ++result->narrow_mismatches;
  }
  result->times.verify.Add(Seconds(v0, Clock::now()));
}

Result<PlayResult> ClipPlayer::Play(size_t clip_index, const FrameSink& sink) {
  const lib::RawCharacter& ch = playback_->loaded().character;
  const skinning::AnimationClip& clip = ch.clips.at(clip_index);
  PlayResult result;
  result.clip = clip.name;
  result.body_height = playback_->body_height();
  result.touch_tolerance = playback_->asset()->narrow_phase()->touch_tolerance();
  if (options_.verify) {  // every triangle of the mesh owned by a sphere (checked once)
    std::vector<bool> owned(ch.triangle_count(), false);
    for (uint32_t t : playback_->set().triangles) owned[t] = true;
    for (const runtime::TrianglePiece& piece : playback_->set().pieces) owned[piece.triangle] = true;
    result.triangles_unowned = static_cast<size_t>(std::count(owned.begin(), owned.end(), false));
  }
  auto frames = FrameCount(clip);
  if (!frames.ok()) return frames.error();
  result.frames = static_cast<int>(*frames);
  for (int f = 0; f < result.frames; ++f) {
    const float t = f / options_.fps;
    const float clip_time = PlaybackTime(t, clip.duration_s);
    if (auto err = Step(clip, f, clip_time, &result.times)) return *err;
    Summarise(f, &result);
    if (options_.verify) Verify(f, &result);
    if (sink) {
      FrameView view;
      view.index = f;
      view.time_s = t;
      view.clip_time_s = clip_time;
      view.sphere_pairs = pairs_;
      view.contacts = &instance_->contacts();
      view.spheres = instance_->spheres();
      view.joint_world = joint_world_;
      view.body_height = result.body_height;
      view.touch_tolerance = result.touch_tolerance;
      sink(view);
    }
    if (options_.progress) {
      std::fprintf(stderr, "\r%s: frame %d/%d, %zu sphere pairs, %zu triangle pairs   ", clip.name.c_str(), f + 1,
                   result.frames, pairs_.size(), instance_->contacts().triangle_pairs.size());
    }
  }
  if (options_.progress) std::fprintf(stderr, "\n");
  return result;
}

Result<PlayResult> PlayClip(const LoadedCharacter& loaded, const runtime::SphereSet& set, size_t clip,
                            const PlayOptions& options, const FrameSink& sink) {
  auto playback = Playback::Create(loaded, set, NarrowSettings(options));
  if (!playback.ok()) return playback.error();
  auto player = ClipPlayer::Create(std::move(*playback), options);
  if (!player.ok()) return player.error();
  return player->Play(clip, sink);
}

void PrintPlaySummary(const PlayResult& r, const runtime::SphereSet& set, float fps, bool sphere_pairs, bool verify) {
  const double n = r.frames > 0 ? double(r.frames) : 1.0;
  std::printf(
      "clip \"%s\": %d frames at %.0f fps; sphere pairs per frame: mean %.2f, max %zu; triangle pairs per frame: "
      "mean %.2f, max %zu\n",
      r.clip.c_str(), r.frames, fps, double(r.sphere_pairs_total) / n, r.sphere_pairs_most,
      double(r.triangle_pairs_total) / n, r.triangle_pairs_most);
  // Real contacts, by part pair.
  if (r.contacts.empty()) std::printf("  no contacts\n");
  auto share = [&](float d) { return r.body_height > 0.0f ? 100.0 * d / r.body_height : 0.0; };
  for (const PartPairSummary& e : r.contacts) {
    std::printf("  %s - %s: ", PartName(set, e.part_a).c_str(), PartName(set, e.part_b).c_str());
    if (e.penetrating.frames() > 0) {
      std::printf("penetrating, frames %s (%zu frames", e.penetrating.ToString().c_str(), e.penetrating.frames());
      if (e.frames.frames() > e.penetrating.frames())
        std::printf("; touching on %zu more", e.frames.frames() - e.penetrating.frames());
      std::printf("), up to %u triangle pairs, depth up to %.4g (%.2f%% of height) at frame %d\n",
                  e.most_triangle_pairs, e.max_depth, share(e.max_depth), e.worst_frame);
    } else if (e.intersecting) {
      std::printf(
          "touching, frames %s (%zu frames), up to %u triangle pairs, intersecting by at most %.4g (%.2f%% of "
          "height, within the %.2f%% tolerance)\n",
          e.frames.ToString().c_str(), e.frames.frames(), e.most_triangle_pairs, e.max_depth, share(e.max_depth),
          share(r.touch_tolerance));
    } else {
      std::printf(
          "touching (within margin), frames %s (%zu frames), up to %u triangle pairs, closest %.4g (%.2f%% of "
          "height)\n",
          e.frames.ToString().c_str(), e.frames.frames(), e.most_triangle_pairs, e.min_distance, share(e.min_distance));
    }
  }
  if (sphere_pairs) {
    std::printf("sphere pairs (broad phase) by part pair:\n");
    if (r.sphere_pairs.empty()) std::printf("  none\n");
    for (const PartPairSummary& e : r.sphere_pairs) {
      std::printf("  %s - %s: frames %s (%zu frames)\n", PartName(set, e.part_a).c_str(),
                  PartName(set, e.part_b).c_str(), e.frames.ToString().c_str(), e.frames.frames());
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
    std::printf(
        "radius / needed: mean %.3f over %zu sphere-frames (the refitted radius against the smallest around "
        "the same centre that holds the sphere's triangles)\n",
        r.radius_ratio_count ? r.radius_ratio_sum / static_cast<double>(r.radius_ratio_count) : 0.0,
        r.radius_ratio_count);
    std::printf(
        "verify: %zu triangle-frames outside their sphere%s, %zu triangles owned by no sphere; narrow phase %s\n",
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
