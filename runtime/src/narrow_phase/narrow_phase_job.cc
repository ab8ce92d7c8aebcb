// The narrow phase's job (narrow_phase.h): a frame's steps in order (internal.h lists them and
// their files), the context and the data's accessors, and the brute-force oracle's entry point.
#include <algorithm>
#include <atomic>
#include <cstring>
#include <optional>

#include "narrow_phase/depth.h"
#include "narrow_phase/internal.h"
#include "narrow_phase/lazy_skinning.h"
#include "skinspheres/runtime/narrow_phase/narrow_phase.h"
#include "skinspheres/skinning/skinning_matrices_job.h"

namespace skinspheres::runtime {

using namespace narrow_phase;

const char* ToString(TriangleContactKind kind) {
  switch (kind) {
    case TriangleContactKind::kIntersecting: return "intersecting";
    case TriangleContactKind::kWithinMargin: return "within_margin";
  }
  return "unknown";
}

const char* ToString(PartContactKind kind) {
  switch (kind) {
    case PartContactKind::kTouching: return "touching";
    case PartContactKind::kPenetrating: return "penetrating";
  }
  return "unknown";
}

void FrameContacts::Reserve(size_t triangle_pairs_capacity) {
  parts.reserve(triangle_pairs_capacity);
  sphere_pairs.reserve(triangle_pairs_capacity);
  triangle_pairs.reserve(triangle_pairs_capacity);
}

bool NarrowPhaseData::ShareVertex(uint32_t t, uint32_t u) const {
  const uint32_t* a = &layout_->welded[3 * size_t{t}];
  const uint32_t* b = &layout_->welded[3 * size_t{u}];
  for (int k = 0; k < 3; ++k) {
    if (a[k] == b[0] || a[k] == b[1] || a[k] == b[2]) return true;
  }
  return false;
}

bool NarrowPhaseData::RestExcluded(uint32_t t, uint32_t u) const {
  // The welded corners have the rest positions of the triangles' own.
  return NearAtRest(layout_->rest_positions.data(), &layout_->welded[3 * size_t{t}], &layout_->welded[3 * size_t{u}],
                    layout_->rest_distance);
}

// The internals shared by set-up, the job and the oracle.

NarrowPhaseData::NarrowPhaseData() : layout_(std::make_unique<Layout>()) {}
NarrowPhaseData::~NarrowPhaseData() = default;
NarrowPhaseData::NarrowPhaseData(const NarrowPhaseData& other)
    : layout_(std::make_unique<Layout>(other.layout_ ? *other.layout_ : Layout{})) {}
NarrowPhaseData& NarrowPhaseData::operator=(const NarrowPhaseData& other) {
  if (this != &other) layout_ = std::make_unique<Layout>(other.layout_ ? *other.layout_ : Layout{});
  return *this;
}
NarrowPhaseData::NarrowPhaseData(NarrowPhaseData&&) noexcept = default;
NarrowPhaseData& NarrowPhaseData::operator=(NarrowPhaseData&&) noexcept = default;

const NarrowPhaseSettings& NarrowPhaseData::settings() const { return layout_->settings; }
float NarrowPhaseData::margin() const { return layout_->settings.margin; }
float NarrowPhaseData::rest_height() const { return layout_->rest_height; }
float NarrowPhaseData::touch_tolerance() const {
  return layout_->settings.touch_tolerance_share * layout_->rest_height;
}
size_t NarrowPhaseData::sphere_count() const {
  return layout_->sphere_vertex_offsets.empty() ? 0 : layout_->sphere_vertex_offsets.size() - 1;
}
size_t NarrowPhaseData::triangle_count() const { return layout_->welded.size() / 3; }
size_t NarrowPhaseData::vertex_count() const { return layout_->rest_positions.size(); }
ContactRules NarrowPhaseData::rules() const { return layout_->rules; }
float NarrowPhaseData::rest_distance() const { return layout_->rest_distance; }
std::span<const Eigen::Vector3f> NarrowPhaseData::rest_positions() const { return layout_->rest_positions; }

NarrowPhaseContext::NarrowPhaseContext() : state_(std::make_unique<State>()) {}
NarrowPhaseContext::~NarrowPhaseContext() = default;
NarrowPhaseContext::NarrowPhaseContext(const NarrowPhaseContext& other)
    : state_(std::make_unique<State>(other.state_ ? *other.state_ : State{})) {}
NarrowPhaseContext& NarrowPhaseContext::operator=(const NarrowPhaseContext& other) {
  if (this != &other) state_ = std::make_unique<State>(other.state_ ? *other.state_ : State{});
  return *this;
}
NarrowPhaseContext::NarrowPhaseContext(NarrowPhaseContext&&) noexcept = default;
NarrowPhaseContext& NarrowPhaseContext::operator=(NarrowPhaseContext&&) noexcept = default;

bool NarrowPhaseContext::sized_for(const NarrowPhaseData& data) const { return state_->sized_for == &data; }
bool NarrowPhaseContext::has_lazy_skinning() const { return !state_->run_done.empty() || state_->skinned.size() > 0; }
const NarrowPhaseContext::Stats& NarrowPhaseContext::last_stats() const { return state_->stats; }
std::span<const Eigen::Vector3f> NarrowPhaseContext::lazy_positions() const { return state_->skinned; }
std::span<const uint32_t> NarrowPhaseContext::tested_spheres() const { return state_->involved; }
void NarrowPhaseContext::Reserve(size_t sphere_pairs) { state_->active_pairs.reserve(sphere_pairs); }

// ------------------------------------------------------------------------------- set-up

void NarrowPhaseContext::Resize(const NarrowPhaseData& data, bool lazy_skinning) {
  State& st = *state_;
  const NarrowPhaseData::Layout& layout = narrow_phase::Access::Of(data);
  st.sized_for = &data;
  for (narrow_phase::Chunk& c : st.chunks) {
    c.a.assign(data.settings().cluster_triangles, narrow_phase::Box{});
    c.b.assign(data.settings().cluster_triangles, narrow_phase::Box{});
    c.plane_a.assign(data.settings().cluster_triangles, narrow_phase::Plane{});
    c.plane_b.assign(data.settings().cluster_triangles, narrow_phase::Plane{});
    c.ka.assign(layout.max_sphere_clusters, 0);
    c.kb.assign(layout.max_sphere_clusters, 0);
    c.xa.assign(layout.max_sphere_clusters, 0);
    c.xb.assign(layout.max_sphere_clusters, 0);
    c.pa.assign(layout.max_sphere_patches + 1, 0);
    c.pb.assign(layout.max_sphere_patches + 1, 0);
    c.hits.reserve(256);
  }
  st.merged.reserve(256 * kChunks);
  st.keys.reserve(256);
  st.sphere_mark.assign(data.sphere_count(), 0);
  st.triangle_mark.assign(data.triangle_count(), 0);
  st.queue.assign(data.triangle_count(), 0);
  st.sphere_stamp = 0;
  st.sphere_seen.assign(data.sphere_count(), 0);
  st.involved.reserve(data.sphere_count());
  st.cluster_box.assign(layout.cluster_count(), narrow_phase::Box{});
  st.sphere_box.assign(data.sphere_count(), narrow_phase::Box{});
  const narrow_phase::Box no_box{{0, 0, 0}, {0, 0, 0}, 0};
  st.patch_box.assign(layout.patch_joint.size(), no_box);
  st.joint_motion.assign(layout.rest_inverse.size(), narrow_phase::JointMotion{});
  st.patch_deviation.assign(layout.patch_joint.size(), INFINITY);
  st.patch_mark.assign(layout.patch_joint.size(), 0);
  st.marked_patches.reserve(layout.patch_joint.size());
  st.patch_stamp = 0;
  st.active_pairs.reserve(4 * data.sphere_count());
  st.active_self.reserve(data.sphere_count());
  st.grid_pos.assign(layout.cluster_grid.size(), Eigen::Vector3f::Zero());
  st.frame_stamp = 0;
  if (lazy_skinning) {
    st.skinned.assign(data.vertex_count(), Eigen::Vector3f::Zero());
    st.run_bits.assign((layout.run_count() + 63) / 64, 0);
    st.run_done.assign(st.run_bits.size(), 0);
    st.marked_begin = st.run_bits.size();
    st.marked_end = 0;
    st.spans.reserve(layout.run_count() + layout.lazy_influences.size() / narrow_phase::LazySkinner::kBlock + 1);
  } else {
    st.skinned.clear();
    st.skinned.shrink_to_fit();
    st.run_bits.clear();
    st.run_bits.shrink_to_fit();
    st.run_done.clear();
    st.run_done.shrink_to_fit();
    st.spans.clear();
    st.spans.shrink_to_fit();
  }
}

// ------------------------------------------------------------------------------- per frame

bool NarrowPhaseJob::Validate() const {
  if (set == nullptr || data == nullptr || context == nullptr || out == nullptr) return false;
  if (!set->has_mesh() || data->sphere_count() != set->size() || data->triangle_count() != set->source_triangle_count ||
      data->vertex_count() != set->source_vertex_count) {
    return false;
  }
  if (spheres.size() != set->size() || !context->sized_for(*data)) return false;
  if (!joint_world.empty() && joint_world.size() < set->joint_count()) return false;
  if (!positions.empty()) return positions.size() >= set->source_vertex_count;
  return !joint_world.empty();
}

namespace {

// Mode (b): the skinning matrices of joint_world, then the involved spheres' vertices skinned into
// the context (frame->pos points at them). False when the matrices or the skinning fail.
bool SkinInvolved(const SphereSet& set, const NarrowPhaseData& data, std::span<const Mat4f> joint_world,
                  NarrowPhaseContext& ctx, const ParallelFor& parallel_for, std::optional<LazySkinner>* skinner,
                  Frame* frame) {
  Of(ctx).bind_matrices.resize(set.mesh.binds.size());
  if (!skinning::SkinningMatricesJob{set.mesh.binds, joint_world.first(set.joint_count()), Of(ctx).bind_matrices}
           .Run()) {
    return false;
  }
  std::fill(Of(ctx).run_done.begin(), Of(ctx).run_done.end(), uint64_t{0});
  skinner->emplace(LazySkinner{set, data, ctx, Of(ctx).bind_matrices});
  for (uint32_t s : Of(ctx).involved) (*skinner)->Collect(s);
  // Non-finite positions are caught by PrepareClusters, which boxes every vertex skinned here
  // (directly, or through the grid points computed from it).
  if (!(*skinner)->Skin(parallel_for)) return false;
  frame->pos = Of(ctx).skinned.data();
  return true;
}

void AddStats(const NarrowPhaseContext::Stats& from, NarrowPhaseContext::Stats* to) {
  to->sphere_pairs += from.sphere_pairs;
  to->patch_pairs += from.patch_pairs;
  to->still_patch_pairs += from.still_patch_pairs;
  to->cluster_pairs += from.cluster_pairs;
  to->culled_triangles += from.culled_triangles;
  to->box_tests += from.box_tests;
  to->triangle_tests += from.triangle_tests;
}

// The work: the sphere pairs, then the spheres tested against themselves, cut into chunks run
// through parallel_for; the chunks' hits merged in chunk order into Of(ctx).merged, their counts
// into Of(ctx).stats. False when a test failed.
bool TestWork(const Frame& frame, std::span<const SpherePair> pairs, std::span<const Vec4f> spheres,
              NarrowPhaseContext& ctx, const ParallelFor& parallel_for) {
  const std::span<const uint32_t> active = Of(ctx).active_pairs, self = Of(ctx).active_self;
  const bool all = Of(ctx).all_pairs;
  const size_t tested = all ? pairs.size() : active.size(), work = tested + self.size();
  const size_t chunks = std::min(work, NarrowPhaseContext::kChunks);
  for (size_t c = 0; c < chunks; ++c) {
    Of(ctx).chunks[c].hits.clear();
    Of(ctx).chunks[c].last_tested = UINT64_MAX;
    Of(ctx).chunks[c].stats = {};
    Of(ctx).chunks[c].ok = true;
  }
  parallel_for(chunks, 1, [&](size_t begin, size_t end) {
    for (size_t c = begin; c < end; ++c) {
      Chunk& chunk = Of(ctx).chunks[c];
      const size_t first = c * work / chunks, last = (c + 1) * work / chunks;
      for (size_t k = first; k < last; ++k) {
        if (k < tested) {
          const SpherePair& p = pairs[all ? k : active[k]];
          chunk.ok &= TestPair(frame, p.sphere_i, p.sphere_j, spheres[p.sphere_i], spheres[p.sphere_j], chunk);
        } else {
          chunk.ok &= TestSelf(frame, self[k - tested], chunk);
        }
      }
    }
  });
  bool ok = true;
  Of(ctx).merged.clear();
  for (size_t c = 0; c < chunks; ++c) {
    const Chunk& chunk = Of(ctx).chunks[c];
    ok &= chunk.ok;
    Of(ctx).merged.insert(Of(ctx).merged.end(), chunk.hits.begin(), chunk.hits.end());
    AddStats(chunk.stats, &Of(ctx).stats);
  }
  return ok;
}

}  // namespace

bool NarrowPhaseJob::RunParallel(const ParallelFor& parallel_for) const {
  if (out != nullptr) out->clear();
  if (!Validate()) return false;
  NarrowPhaseContext& ctx = *context;
  Of(ctx).stats = {};
  const size_t n = set->size();
  for (const SpherePair& p : pairs) {
    if (p.sphere_i >= p.sphere_j || p.sphere_j >= n) return false;
  }
  const bool lazy = positions.empty();
  if (lazy && !ctx.has_lazy_skinning()) ctx.Resize(*data, true);  // first mode-(b) run: warm-up allocation
  if (++Of(ctx).frame_stamp == 0) {
    std::fill(Of(ctx).sphere_seen.begin(), Of(ctx).sphere_seen.end(), 0u);
    Of(ctx).frame_stamp = 1;
  }
  PrepareMotion(*data, joint_world, ctx);
  Frame frame{*set,
              *data,
              positions.data(),
              data->margin(),
              Of(ctx).cluster_box.data(),
              Of(ctx).sphere_box.data(),
              Of(ctx).patch_box.data(),
              Of(ctx).has_motion ? Of(ctx).joint_motion.data() : nullptr,
              Of(ctx).patch_deviation.data(),
              Of(ctx).motion_slack,
              Of(ctx).grid_pos.data()};
  SelectWork(frame, pairs, lazy, ctx);
  Involved(pairs, ctx);
  // Positions: the caller's (mode a), or skinned here, the involved spheres' vertices only (mode b).
  std::optional<LazySkinner> skinner;
  if (lazy && !SkinInvolved(*set, *data, joint_world, ctx, parallel_for, &skinner, &frame)) return false;
  if (!PrepareClusters(frame, ctx, parallel_for)) return false;
  if (!lazy && frame.joint_motion != nullptr) MeasureDeviations(frame, pairs, ctx, parallel_for);
  if (!TestWork(frame, pairs, spheres, ctx, parallel_for)) {
    out->clear();
    return false;
  }
  Merge(frame, Of(ctx).merged, Of(ctx).keys, out);
  DepthScratch scratch{Of(ctx).triangle_mark, Of(ctx).queue, Of(ctx).triangle_stamp};
  if (lazy) {
    Depths(frame, Of(ctx).merged, *skinner, scratch, out);
    if (!skinner->ok) {
      out->clear();
      return false;
    }
  } else {
    Depths(frame, Of(ctx).merged, NoSkinning{}, scratch, out);
  }
  Of(ctx).stats.depth_vertices = scratch.vertices;
  return true;
}

bool NarrowPhaseJob::Run() const { return RunParallel(SerialFor()); }

bool FindContactsBruteForce(const SphereSet& set, const NarrowPhaseData& data, const PairFilter& filter,
                            std::span<const Eigen::Vector3f> positions, FrameContacts* out) {
  if (out == nullptr) return false;
  out->clear();
  if (!set.has_mesh() || data.sphere_count() != set.size() || data.triangle_count() != set.source_triangle_count ||
      data.vertex_count() != set.source_vertex_count || filter.size() != set.size() ||
      positions.size() < set.source_vertex_count) {
    return false;
  }
  const Frame frame{set, data, positions.data(), data.margin()};
  std::vector<Hit> hits;
  if (!AllPairs(frame, filter, &hits)) return false;
  std::vector<uint64_t> keys;
  Merge(frame, hits, keys, out);
  std::vector<uint32_t> marks(set.source_triangle_count, 0), queue(set.source_triangle_count, 0);
  uint32_t stamp = 0;
  DepthScratch scratch{marks, queue, stamp};
  Depths(frame, hits, NoSkinning{}, scratch, out);
  return true;
}

}  // namespace skinspheres::runtime
