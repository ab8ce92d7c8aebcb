// Private: mode (b)'s skinning (internal.h, frame step 2).
#pragma once

#include <algorithm>
#include <atomic>
#include <bit>
#include <span>

#include "narrow_phase/internal.h"
#include "skinspheres/skinning/skinning_job.h"

namespace skinspheres::runtime::narrow_phase {

// Mode (b): skins the vertex groups of the spheres asked for, each group once per frame: Collect
// marks a sphere's groups' runs (a few words of the run bitset, ORed), Skin skins the marked runs,
// adjacent runs merged into one span. Every vertex is skinned by the same instructions as on the
// whole-mesh path, so the positions are bit-identical to skinning the whole mesh with SkinningJob.
struct LazySkinner {
  static constexpr uint32_t kBlock = 1024;  // slots per span at most: work items for parallel_for

  const SphereSet& set;
  const NarrowPhaseData& data;
  NarrowPhaseContext& ctx;
  std::span<const Mat4f> matrices;
  bool ok = true;

  // Marks the runs of sphere's groups not skinned yet this frame; false when there are none.
  bool Collect(uint32_t sphere) {
    const std::span<const uint32_t> offsets = Of(data).sphere_run_offsets;
    const std::span<const uint32_t> words = Of(data).sphere_run_words;
    const std::span<const uint64_t> bits = Of(data).sphere_run_bits;
    const uint32_t k0 = offsets[sphere], k1 = offsets[sphere + 1];
    if (k0 == k1) return false;
    uint64_t added = 0;
    for (uint32_t k = k0; k < k1; ++k) {
      const uint64_t mark = bits[k] & ~Of(ctx).run_done[words[k]];
      Of(ctx).run_bits[words[k]] |= mark;
      added |= mark;
    }
    // Words ascending: the range Skin scans grows to this sphere's first and last.
    Of(ctx).marked_begin = std::min<size_t>(Of(ctx).marked_begin, words[k0]);
    Of(ctx).marked_end = std::max<size_t>(Of(ctx).marked_end, size_t{words[k1 - 1]} + 1);
    return added != 0;
  }

  // Appends [begin, end) to the spans, cut into blocks of at most kBlock slots.
  void AddSpan(uint32_t begin, uint32_t end) {
    Of(ctx).stats.skinned_vertices += end - begin;
    for (; begin < end; begin += std::min(kBlock, end - begin)) {
      Of(ctx).spans.emplace_back(begin, begin + std::min(kBlock, end - begin));
    }
  }

  // Skins what Collect marked. False on a job the skinning library refuses.
  bool Skin(const ParallelFor& parallel_for) {
    const std::span<const uint32_t> run_begin = Of(data).run_begin;
    Of(ctx).spans.clear();
    // Maximal sequences of marked runs: runs tile the slots, so consecutive runs are adjacent.
    uint32_t open_begin = 0, open_end = 0;  // the span being extended (empty: none)
    for (size_t word = Of(ctx).marked_begin; word < Of(ctx).marked_end; ++word) {
      uint64_t bits = Of(ctx).run_bits[word];
      if (bits == 0) continue;
      Of(ctx).run_bits[word] = 0;
      Of(ctx).run_done[word] |= bits;
      while (bits != 0) {  // per sequence of set bits: runs [r, r + length), adjacent slots
        const int first = std::countr_zero(bits);
        const int length = std::countr_one(bits >> first);
        const uint32_t r = uint32_t(word * 64 + size_t(first));
        bits = first + length == 64 ? 0 : bits & (~uint64_t{0} << (first + length));
        if (open_end != run_begin[r]) {
          AddSpan(open_begin, open_end);
          open_begin = run_begin[r];
        }
        open_end = run_begin[r + size_t(length)];
      }
    }
    AddSpan(open_begin, open_end);
    Of(ctx).marked_begin = Of(ctx).run_bits.size();
    Of(ctx).marked_end = 0;
    if (Of(ctx).spans.empty()) return true;
    skinning::SkinningJob job;
    job.joint_matrices = matrices;
    job.vertex_count = set.mesh.vertex_count();
    job.in_positions = {reinterpret_cast<const float*>(set.mesh.positions_bind.data()), 3 * set.mesh.vertex_count()};
    job.out_positions = {reinterpret_cast<float*>(Of(ctx).skinned.data()), 3 * Of(ctx).skinned.size()};
    job.prepared = &Of(data).lazy_influences;
    std::atomic<bool> good{true};
    parallel_for(Of(ctx).spans.size(), 1, [&](size_t begin, size_t end) {
      if (!job.RunRanges(std::span(Of(ctx).spans).subspan(begin, end - begin)))
        good.store(false, std::memory_order_relaxed);
    });
    ok &= good.load();
    return good.load();
  }

  // The depth estimate's on-demand call: one sphere, on this thread. The spheres in pairs were
  // checked finite by PrepareClusters; any other gets its vertices checked here, once a frame.
  void operator()(uint32_t sphere) {
    if (Of(ctx).sphere_seen[sphere] == Of(ctx).frame_stamp) return;
    Of(ctx).sphere_seen[sphere] = Of(ctx).frame_stamp;
    if (Collect(sphere)) Skin(SerialFor());
    const std::span<const uint32_t> offsets = Of(data).sphere_vertex_offsets;
    for (uint32_t k = offsets[sphere]; k < offsets[sphere + 1]; ++k) {
      ok &= Of(ctx).skinned[Of(data).sphere_vertices[k]].allFinite();
    }
  }
};

}  // namespace skinspheres::runtime::narrow_phase
