// A frame's joint motions, its work, its spheres and their cluster and patch boxes (internal.h,
// frame steps 1 and 3).
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <vector>

#include "narrow_phase/internal.h"
#include "simd/float4.h"

namespace skinspheres::runtime::narrow_phase {

void PrepareMotion(const NarrowPhaseData& data, std::span<const Mat4f> joint_world, NarrowPhaseContext& ctx) {
  Of(ctx).has_motion = !joint_world.empty() && Of(data).rules == ContactRules::kTriangles;
  if (!Of(ctx).has_motion) return;
  double reach = double(Of(data).rest_size);
  for (uint16_t j : Of(data).motion_joints) {
    JointMotion& m = Of(ctx).joint_motion[j];
    m.h = joint_world[j].cast<double>() * Of(data).rest_inverse[j];
    m.h.row(3) << 0.0, 0.0, 0.0, 1.0;
    // |L^-1| = 1 / the smallest singular value of L (rounded up); none when singular or not finite.
    const Eigen::Matrix3d linear = m.h.topLeftCorner<3, 3>();
    m.inv_norm = INFINITY;
    if (linear.allFinite() && m.h.col(3).allFinite()) {
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
      eig.computeDirect(linear.transpose() * linear, Eigen::EigenvaluesOnly);
      const double smallest = eig.eigenvalues()[0];
      if (smallest > 1e-12 * eig.eigenvalues()[2] && smallest > 0.0) m.inv_norm = (1.0 + 1e-6) / std::sqrt(smallest);
    }
    reach = std::max(reach, m.h.col(3).head<3>().cwiseAbs().maxCoeff());
  }
  // The positions' and the bound's own rounding: float skinning errs by a few ulps of the coordinates.
  Of(ctx).motion_slack = 1e-5 * (double(Of(data).rest_size) + reach);
}

void SelectWork(const Frame& f, std::span<const SpherePair> pairs, bool lazy, NarrowPhaseContext& ctx) {
  const NarrowPhaseData::Layout& d = Of(f.data);
  auto& active = Of(ctx).active_pairs;
  auto& self = Of(ctx).active_self;
  active.clear();
  self.clear();
  Of(ctx).all_pairs = !lazy || f.joint_motion == nullptr;
  if (Of(ctx).all_pairs) {
    self.assign(d.self_spheres.begin(), d.self_spheres.end());
    return;
  }
  // Deviations from the joint matrices, once per sphere of the pairs and self tests.
  ++Of(ctx).sphere_stamp;
  if (Of(ctx).sphere_stamp == 0) {
    std::fill(Of(ctx).sphere_mark.begin(), Of(ctx).sphere_mark.end(), 0u);
    Of(ctx).sphere_stamp = 1;
  }
  double* deviation = Of(ctx).patch_deviation.data();
  auto prepare = [&](uint32_t s) {
    if (Of(ctx).sphere_mark[s] == Of(ctx).sphere_stamp) return;
    Of(ctx).sphere_mark[s] = Of(ctx).sphere_stamp;
    WeightDeviations(f, s, deviation);
  };
  auto moving = [&](uint32_t a, uint32_t b) { return !d.near(d.patch_joint[a], d.patch_joint[b]) && !Still(f, a, b); };
  for (uint32_t k = 0; k < pairs.size(); ++k) {
    const uint32_t i = pairs[k].sphere_i, j = pairs[k].sphere_j;
    prepare(i);
    prepare(j);
    bool any = false;
    for (uint32_t a = d.patch_offsets[i]; a < d.patch_offsets[i + 1] && !any; ++a) {
      for (uint32_t b = d.patch_offsets[j]; b < d.patch_offsets[j + 1] && !any; ++b) any = moving(a, b);
    }
    if (any) active.push_back(k);
  }
  for (uint32_t s : d.self_spheres) {
    prepare(s);
    bool any = false;
    for (uint32_t a = d.patch_offsets[s]; a < d.patch_offsets[s + 1] && !any; ++a) {
      for (uint32_t b = a + 1; b < d.patch_offsets[s + 1] && !any; ++b) any = moving(a, b);
    }
    if (any) self.push_back(s);
  }
}

void Involved(std::span<const SpherePair> pairs, NarrowPhaseContext& ctx) {
  Of(ctx).involved.clear();
  auto add = [&](uint32_t s) {
    if (Of(ctx).sphere_seen[s] != Of(ctx).frame_stamp) {
      Of(ctx).sphere_seen[s] = Of(ctx).frame_stamp;
      Of(ctx).involved.push_back(s);
    }
  };
  ForEachActivePair(pairs, ctx, [&](uint32_t k) {
    add(pairs[k].sphere_i);
    add(pairs[k].sphere_j);
  });
  for (uint32_t s : Of(ctx).active_self) add(s);
}

bool PrepareClusters(const Frame& f, NarrowPhaseContext& ctx, const ParallelFor& parallel_for) {
  const NarrowPhaseData& d = f.data;
  std::atomic<bool> ok{true};
  parallel_for(Of(ctx).involved.size(), 4, [&](size_t begin, size_t end) {
    bool good = true;
    for (size_t k = begin; k < end; ++k) {
      const uint32_t s = Of(ctx).involved[k];
      for (uint32_t c = Of(d).cluster_offsets[s]; c < Of(d).cluster_offsets[s + 1]; ++c) {
        good &= PositionBox(f.set, d, f.pos, c, &Of(ctx).cluster_box[c], Of(ctx).grid_pos.data());
      }
      UniteClusters(d, s, ctx);
    }
    if (!good) ok.store(false, std::memory_order_relaxed);
  });
  for (uint32_t s : Of(ctx).involved)
    Of(ctx).stats.clusters_bounded += Of(d).cluster_offsets[s + 1] - Of(d).cluster_offsets[s];
  return ok.load();
}

void MeasureDeviations(const Frame& f, std::span<const SpherePair> pairs, NarrowPhaseContext& ctx,
                       const ParallelFor& parallel_for) {
  const NarrowPhaseData::Layout& d = Of(f.data);
  // The patches Still will be asked of and may say yes to: in a pair rule 2 leaves, whose boxes meet,
  // and whose joints' motions alone leave them still (CouldBeStill).
  auto& marked = Of(ctx).marked_patches;
  marked.clear();
  ++Of(ctx).patch_stamp;
  if (Of(ctx).patch_stamp == 0) {
    std::fill(Of(ctx).patch_mark.begin(), Of(ctx).patch_mark.end(), 0u);
    Of(ctx).patch_stamp = 1;
  }
  auto mark = [&](uint32_t p) {
    if (Of(ctx).patch_mark[p] == Of(ctx).patch_stamp || !d.patch_still_ok[p]) return;
    Of(ctx).patch_mark[p] = Of(ctx).patch_stamp;
    marked.push_back(p);
  };
  const float slack = Slack(f.margin);
  auto consider = [&](uint32_t a, uint32_t b) {
    if (d.near(d.patch_joint[a], d.patch_joint[b]) || !d.patch_still_ok[a] || !d.patch_still_ok[b]) return;
    if (!BoxesMeet(f.patch_box[a], f.patch_box[b], slack) || !CouldBeStill(f, a, b)) return;
    mark(a);
    mark(b);
  };
  ForEachActivePair(pairs, ctx, [&](uint32_t k) {
    const uint32_t i = pairs[k].sphere_i, j = pairs[k].sphere_j;
    for (uint32_t a = d.patch_offsets[i]; a < d.patch_offsets[i + 1]; ++a) {
      for (uint32_t b = d.patch_offsets[j]; b < d.patch_offsets[j + 1]; ++b) consider(a, b);
    }
  });
  for (uint32_t s : Of(ctx).active_self) {
    for (uint32_t a = d.patch_offsets[s]; a < d.patch_offsets[s + 1]; ++a) {
      for (uint32_t b = a + 1; b < d.patch_offsets[s + 1]; ++b) consider(a, b);
    }
  }
  parallel_for(marked.size(), 8, [&](size_t begin, size_t end) {
    for (size_t k = begin; k < end; ++k) {
      const uint32_t p = marked[k];
      const JointMotion& motion = f.joint_motion[d.patch_joint[p]];
      double e = 0.0;
      for (uint32_t c = d.patch_cluster_offsets[p]; c < d.patch_cluster_offsets[p + 1]; ++c) {
        const double x = MeasuredDeviation(f, c, motion);
        e = x > e || x != x ? x : e;
      }
      Of(ctx).patch_deviation[p] = e == e ? e : INFINITY;
    }
  });
}

void UniteClusters(const NarrowPhaseData& d, uint32_t s, NarrowPhaseContext& ctx) {
  Box all{{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}, s};
  for (uint32_t p = Of(d).patch_offsets[s]; p < Of(d).patch_offsets[s + 1]; ++p) {
    Box patch{{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}, p};
    for (uint32_t c = Of(d).patch_cluster_offsets[p]; c < Of(d).patch_cluster_offsets[p + 1]; ++c) {
      for (int k = 0; k < 3; ++k) {
        patch.lo[k] = std::min(patch.lo[k], Of(ctx).cluster_box[c].lo[k]);
        patch.hi[k] = std::max(patch.hi[k], Of(ctx).cluster_box[c].hi[k]);
      }
    }
    Of(ctx).patch_box[p] = patch;
    for (int k = 0; k < 3; ++k) {
      all.lo[k] = std::min(all.lo[k], patch.lo[k]);
      all.hi[k] = std::max(all.hi[k], patch.hi[k]);
    }
  }
  Of(ctx).sphere_box[s] = all;
}

}  // namespace skinspheres::runtime::narrow_phase
