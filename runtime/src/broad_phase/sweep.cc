// The sweep (above kAllPairsMax spheres): the sweep order in strips, kept between builds, and the
// block sweep into the cache's unsorted pairs, or, when no cache fits, straight into the output.
#include <algorithm>
#include <cmath>
#include <limits>

#include "broad_phase/frame.h"

namespace skinspheres::runtime::broad_phase {

SweepLayout Frame::PlanSweep(bool strips) {
  const float* grown = Soa(kGrown);
  // Bounds and spread of the centres (relative to the first, so float sums stay accurate), the
  // largest and mean grown radius.
  namespace F = simd::native;
  const F::Float4 c0 = F::Load4(spheres);
  F::Float4 lo = c0, hi = c0, sum = F::Zero(), sum2 = F::Zero();
  for (size_t s = 0; s < n; ++s) {
    const F::Float4 v = F::Load4(spheres + 4 * s);
    lo = F::Min(lo, v);
    hi = F::Max(hi, v);
    const F::Float4 d = F::Sub(v, c0);
    sum = F::Add(sum, d);
    sum2 = F::Add(sum2, F::Mul(d, d));
  }
  float lo_f[4], hi_f[4], sum_f[4], sum2_f[4];
  F::Store4(lo_f, lo);
  F::Store4(hi_f, hi);
  F::Store4(sum_f, sum);
  F::Store4(sum2_f, sum2);
  float max_r = 0.0f, sum_r = 0.0f;
  for (size_t s = 0; s < n; ++s) {
    max_r = std::max(max_r, grown[s]);
    sum_r += grown[s];
  }
  double variance[3];
  for (int a = 0; a < 3; ++a) {
    const double mean = double(sum_f[a]) / double(n);
    variance[a] = double(sum2_f[a]) / double(n) - mean * mean;
  }
  SweepLayout l;
  const int best = int(std::max_element(variance, variance + 3) - variance);
  l.keep_order = st.scratch.order_count == n && st.scratch.axis >= 0;
  if (!l.keep_order || variance[best] > 1.25 * variance[st.scratch.axis]) {
    if (best != st.scratch.axis) l.keep_order = false;
    st.scratch.axis = best;
  }
  l.axis = st.scratch.axis;
  const int axis = l.axis;
  l.strip_axis = variance[(axis + 1) % 3] >= variance[(axis + 2) % 3] ? (axis + 1) % 3 : (axis + 2) % 3;
  const int strip_axis = l.strip_axis;

  // Strips at least one grown diameter wide (touching spheres lie in the same or adjacent
  // strips), anchored at multiples of the width (so they do not move with the set) and kept
  // while the width is within 1.5x of the need. Worth it when they save more interval tests
  // than their extra sweep calls cost: a sphere meets about p * n / 2 intervals in one sweep,
  // p * 1.5 n / strips with strips, for 3 calls instead of 1 (p: the chance that two intervals
  // overlap on the sweep axis).
  const double need = 2.0 * double(max_r) * kCellMargin;
  if (!(st.scratch.cell >= need && st.scratch.cell <= 1.5 * need)) {
    st.scratch.cell = need;
    l.keep_order = false;
  }
  const double cell = std::max(
      {st.scratch.cell, std::max(std::fabs(double(lo_f[strip_axis])), std::fabs(double(hi_f[strip_axis]))) * 0x1p-40,
       (double(hi_f[strip_axis]) - lo_f[strip_axis]) / std::max(1.0, double(n / 4)),
       std::numeric_limits<double>::min()});
  l.inv_cell = 1.0 / cell;
  l.base = std::floor(double(lo_f[strip_axis]) * l.inv_cell);
  l.count = std::max<int64_t>(1, int64_t(double(hi_f[strip_axis]) * l.inv_cell - l.base) + 1);
  if (strips && l.count > 1) {
    const double extent = std::max(double(hi_f[axis]) - lo_f[axis], 1e-30);
    const double p = std::min(1.0, 4.0 * double(sum_r) / double(n) / extent);
    const double cost_one = kSweepCallCost * double(n) + 0.5 * p * double(n) * double(n);
    const double cost_strips = 3.0 * kSweepCallCost * double(n) + 1.5 * p * double(n) * double(n) / double(l.count);
    strips = cost_strips < cost_one;
  }
  if (!strips) l.count = 1;
  if (st.scratch.order_columns != (l.count > 1)) l.keep_order = false;
  return l;
}

uint64_t Frame::SortKey(const SweepLayout& l, size_t s) {
  // Strip index: the product is >= base up to rounding, so truncation is the floor.
  uint32_t strip = 0;
  if (l.count > 1) {
    strip = static_cast<uint32_t>(
        std::min<int64_t>(int64_t(std::max(double(Sphere(s)[l.strip_axis]) * l.inv_cell - l.base, 0.0)), l.count - 1));
  }
  return (uint64_t{strip} << 32) | OrderBits(Soa(kStartByIndex)[s]);
}

void Frame::IntervalStarts(int axis) {
  const float* grown = Soa(kGrown);
  float* start_by_sphere = Soa(kStartByIndex);
  for (size_t s = 0; s < n; ++s) {
    const float c = Sphere(s)[axis], r = grown[s];
    start_by_sphere[s] = c - r - IntervalPad(c, r);
  }
}

// One strip's run [b, e) of src, a few segments (one per strip its spheres came from, each nearly
// sorted): an insertion sort per segment, then each merged into the sorted prefix, into order[b, e).
// False when the moves pass the budget (the caller then sorts from scratch).
bool Frame::SortStripRun(SortItem* src, size_t b, size_t e, size_t* moves, size_t budget) {
  SortItem* order = st.scratch.order.data();
  size_t segment_end = b;
  SortItem* merged = src;  // holds [b, segment_end) sorted
  while (segment_end < e) {
    const size_t begin = segment_end;
    size_t end = begin + 1;
    while (end < e && src[end].from == src[begin].from) ++end;
    for (size_t q = begin + 1; q < end && *moves <= budget; ++q) {
      const SortItem item = src[q];
      if (!(item.key < src[q - 1].key)) continue;
      size_t m = q;
      do {
        src[m] = src[m - 1];
        --m;
        ++*moves;
      } while (m > begin && item.key < src[m - 1].key);
      src[m] = item;
    }
    if (*moves > budget) return false;
    if (begin > b) {
      // Merge [b, begin) of `merged` with this segment into the other array (which may be
      // src itself: the segment is the tail of the output range, and a forward merge
      // never writes past what it has read of it). Counted against the budget.
      SortItem* out = merged == src ? order : src;
      size_t x = b, y = begin, w = b;
      while (x < begin && y < end) out[w++] = src[y].key < merged[x].key ? src[y++] : merged[x++];
      while (x < begin) out[w++] = merged[x++];
      while (y < end) out[w++] = src[y++];
      merged = out;
      *moves += end - b;
    }
    segment_end = end;
  }
  if (merged != order) std::copy(merged + b, merged + e, order + b);
  return true;
}

// Sort by (strip, start), from the previous order when there is one: a stable counting sort by
// the new strip, after which each strip's run is a few segments, one per strip its spheres
// came from (in that strip order), each nearly sorted by start under coherent motion: an
// insertion sort per segment, then the segments merged (moves of both within a budget for the
// whole, else std::sort). An insertion sort of the whole run would move every sphere that
// changed strips across most of the run: a crowd of walking characters overran the budget on
// every build. Without strips there is one run of one segment (the previous order had no
// strips either, or it is not kept), so merges only happen with src = order_by_strip.
void Frame::SortSweepOrder(const SweepLayout& l) {
  SortItem* order = st.scratch.order.data();
  bool full_sort = !l.keep_order;
  if (l.keep_order) {
    for (size_t q = 0; q < n; ++q) {
      order[q].from = static_cast<uint32_t>(order[q].key >> 32);
      order[q].key = SortKey(l, order[q].sphere);
    }
    SortItem* src = order;
    if (l.count > 1) {
      uint32_t* at = st.scratch.row.data();
      std::fill(at, at + l.count + 1, 0u);
      for (size_t q = 0; q < n; ++q) ++at[(order[q].key >> 32) + 1];
      for (int64_t c = 0; c < l.count; ++c) at[c + 1] += at[c];
      src = st.scratch.order_by_strip.data();
      for (size_t q = 0; q < n; ++q) src[at[order[q].key >> 32]++] = order[q];
    }
    size_t moves = 0;
    const size_t budget = 4 * n + 64;
    for (size_t b = 0; b < n && !full_sort;) {
      const uint64_t strip = src[b].key >> 32;
      size_t e = b + 1;
      while (e < n && (src[e].key >> 32) == strip) ++e;
      full_sort = !SortStripRun(src, b, e, &moves, budget);
      b = e;
    }
    if (full_sort && src != order) std::copy(src, src + n, order);
  } else {
    for (size_t q = 0; q < n; ++q) order[q] = SortItem{SortKey(l, q), static_cast<uint32_t>(q), 0};
  }
  if (full_sort) {
    std::sort(order, order + n, [](const SortItem& a, const SortItem& b) { return a.key < b.key; });
  }
  st.last.full_sort = full_sort;
  st.scratch.order_count = n;
  st.scratch.order_columns = l.count > 1;
}

void Frame::GatherSweepOrder(int axis) {
  const SortItem* order = st.scratch.order.data();
  const float* grown = Soa(kGrown);
  const float* start_by_sphere = Soa(kStartByIndex);
  float* x = Soa(0);
  float* y = Soa(1);
  float* z = Soa(2);
  float* r_sorted = Soa(3);
  float* start = Soa(4);
  float* end = Soa(5);
  uint32_t* sphere = st.scratch.sphere.data();
  for (size_t q = 0; q < n; ++q) {
    const uint32_t s = order[q].sphere;
    const Vec4f& p = Sphere(s);
    const float r = grown[s];
    sphere[q] = s;
    x[q] = p.x();
    y[q] = p.y();
    z[q] = p.z();
    r_sorted[q] = r;
    start[q] = start_by_sphere[s];
    end[q] = p[axis] + r + IntervalPad(p[axis], r);
  }
  for (size_t q = n; q < padded; ++q) {
    x[q] = y[q] = z[q] = r_sorted[q] = 0.0f;
    start[q] = std::numeric_limits<float>::infinity();
    end[q] = -std::numeric_limits<float>::infinity();
    sphere[q] = 0;
  }
}

size_t Frame::ColumnRuns() {
  const SortItem* order = st.scratch.order.data();
  ColumnRun* runs = st.scratch.runs.data();
  size_t run_count = 0;
  for (size_t q = 0; q < n;) {
    const uint32_t col = static_cast<uint32_t>(order[q].key >> 32);
    size_t e = q + 1;
    while (e < n && static_cast<uint32_t>(order[e].key >> 32) == col) ++e;
    runs[run_count++] = ColumnRun{col, static_cast<uint32_t>(q), static_cast<uint32_t>(e)};
    q = e;
  }
  return run_count;
}

size_t Frame::Order(bool strips) {
  const SweepLayout layout = PlanSweep(strips);
  IntervalStarts(layout.axis);  // one computation, reused by the keys and the sweep
  SortSweepOrder(layout);
  GatherSweepOrder(layout.axis);
  return ColumnRuns();
}

float Frame::RunLength(const ColumnRun& run) {
  const float* start = Soa(4);
  const float* end = Soa(5);
  float len = 0.0f;
  for (uint32_t q = run.begin; q < run.end; ++q) len = std::max(len, end[q] - start[q]);
  return len * (1.0f + 1.0f / 65536.0f);
}

kernels::SoaSpheres Frame::SweepSoa() {
  return kernels::SoaSpheres{Soa(0), Soa(1), Soa(2), Soa(3), Soa(4), Soa(5), st.scratch.sphere.data()};
}

bool Frame::SweepBuild(size_t* pair_count) {
  const size_t run_count = Order(true);
  const ColumnRun* runs = st.scratch.runs.data();
  const kernels::SoaSpheres soa = SweepSoa();
  const kernels::FilterView sweep_view = SweepView();
  kernels::PairSink sink{st.scratch.pairs_i.data(), st.scratch.pairs_j.data(), st.max_candidates, 0, false};
  size_t tests = 0;
  for (size_t ri = 0; ri < run_count && !sink.full; ++ri) {
    const ColumnRun& ra = runs[ri];
    tests += k.sweep_blocks(soa, ra.begin, ra.end, 0, 0, 0.0f, sweep_view, &sink);
    // The next strip, if it holds spheres: both ways (blocks of A against B, then B against A
    // would count pairs twice, so one call with B's longest interval as reach).
    if (ri + 1 < run_count && runs[ri + 1].column == ra.column + 1 && !sink.full) {
      const ColumnRun& rb = runs[ri + 1];
      tests += k.sweep_blocks(soa, ra.begin, ra.end, rb.begin, rb.end, RunLength(rb), sweep_view, &sink);
    }
  }
  st.last.build_tests += tests;
  *pair_count = sink.count;
  return !sink.full;
}

void Frame::SweepDirect() {
  Order(false);
  const kernels::SoaSpheres soa = SweepSoa();
  kernels::PairSink sink{st.scratch.pairs_i.data(), st.scratch.pairs_j.data(), st.max_candidates, 0, false};
  size_t tests = 0;
  for (uint32_t a = 0; a + 1 < n; ++a) {
    const size_t before = sink.count;
    tests += k.sweep_range(soa, a, a + 1, static_cast<uint32_t>(n), view, &sink);
    if (!sink.full) continue;
    // Out of room: stream what came before this sphere, then redo it (max_candidates >= n + pad).
    FlushDirect(before);
    sink.count = 0;
    sink.full = false;
    k.sweep_range(soa, a, a + 1, static_cast<uint32_t>(n), view, &sink);
  }
  FlushDirect(sink.count);
  st.last.build_tests = tests;
}

}  // namespace skinspheres::runtime::broad_phase
