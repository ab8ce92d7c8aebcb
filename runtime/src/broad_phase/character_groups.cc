// A space of several characters (a filter from PairFilter::Combine, above kAllPairsMax spheres) run
// by character (context_state.h: CharacterGroups).
//
// With the filter of PairFilter::Combine, one cache for the whole space would end whenever any
// one character's sphere left its skin: with ten walking characters that is every frame, and
// each build sweeps every character's own pairs again. Instead each character (group) keeps its
// own context and cache, as if it were alone, and the pairs between characters come from a
// sweep of the characters' bounding boxes: for each pair of characters whose boxes overlap, the
// spheres of each that lie inside the other's box, every pair of them given the exact test. The
// two lists are merged by (i, j): within a row, a character's own pairs come first (their j lies
// in its own index range, before every later character's).
#include <algorithm>
#include <cstdint>
#include <limits>
#include <vector>

#include "broad_phase/frame.h"

namespace skinspheres::runtime::broad_phase {

bool Frame::UseGroups() const {
  const size_t groups = filter.group_count();
  return groups >= 2 && n > kAllPairsMax && n >= 16 * groups;
}

bool Frame::SetUpGroups() {
  if (st.groups.filter == filter.id() && st.groups.filters.size() == filter.group_count()) return true;
  const size_t groups = filter.group_count();
  st.groups.filter = 0;
  st.groups.filters.clear();
  st.groups.filters.reserve(groups);
  st.groups.contexts.resize(groups);
  std::vector<ExcludedPair> listed;
  size_t largest = 0;
  for (uint32_t g = 0; g < groups; ++g) {
    const uint32_t b = filter.group_begin(g), e = filter.group_begin(g + 1);
    listed.clear();
    for (uint32_t i = b; i < e; ++i) {
      for (const uint32_t j : filter.excluded_partners(i)) {
        if (j > i && j < e) listed.push_back(ExcludedPair{i - b, j - b, ExclusionReason::kSameJoint});
      }
    }
    auto made = PairFilter::Create(e - b, filter.parts().subspan(b, e - b), listed);
    if (!made.ok()) return false;
    st.groups.filters.push_back(std::move(*made));
    BroadPhaseContext& c = st.groups.contexts[g];
    if (c.max_spheres() != e - b) {
      c.Resize(e - b);
    } else {
      c.Invalidate();
    }
    largest = std::max<size_t>(largest, e - b);
  }
  st.groups.box.assign(8 * groups, 0.0f);
  st.groups.order.resize(groups);
  for (uint32_t g = 0; g < groups; ++g) st.groups.order[g] = g;
  st.groups.inside_a.reserve(largest);
  st.groups.inside_b.reserve(largest);
  st.groups.cross.clear();
  st.groups.cross.shrink_to_fit();
  st.groups.cross.reserve(n);
  // A character's sphere pairs: at most its cache's room while it has a cache (more only on the
  // frames it is answered without one, see Direct).
  size_t most = 0;
  for (const BroadPhaseContext& c : st.groups.contexts) most = std::max(most, c.max_candidates());
  st.groups.out.clear();
  st.groups.out.reserve(most + kPad);
  st.groups.filter = filter.id();
  return true;
}

void Frame::PaddedBox(const float* sphere, simd::native::Float4* lo, simd::native::Float4* hi) {
  namespace F = simd::native;
  const F::Float4 v = F::Load4(sphere);
  const F::Float4 r = F::Splat<3>(v);
  const F::Float4 pad = F::Add(F::Mul(F::Add(F::Abs(v), r), F::Set1(kPadRelative)), F::Set1(kPadAbsolute));
  *lo = F::Sub(F::Sub(v, r), pad);
  *hi = F::Add(F::Add(v, r), pad);
}

bool Frame::BoxesOverlap(const float* a, const float* b) {  // 8 floats each (low, high)
  namespace F = simd::native;
  const unsigned lo_ok = F::Bits(F::LessEqual(F::Load4(a), F::Load4(b + 4)));
  const unsigned hi_ok = F::Bits(F::LessEqual(F::Load4(b), F::Load4(a + 4)));
  return (lo_ok & hi_ok & 7) == 7;
}

void Frame::GroupBoxes() {
  const size_t groups = filter.group_count();
  float* box = st.groups.box.data();
  namespace F = simd::native;
  for (uint32_t g = 0; g < groups; ++g) {
    F::Float4 lo = F::Set1(std::numeric_limits<float>::infinity());
    F::Float4 hi = F::Set1(-std::numeric_limits<float>::infinity());
    for (uint32_t s = filter.group_begin(g); s < filter.group_begin(g + 1); ++s) {
      F::Float4 l, h;
      PaddedBox(spheres + 4 * size_t{s}, &l, &h);
      lo = F::Min(lo, l);
      hi = F::Max(hi, h);
    }
    F::Store4(box + 8 * g, lo);
    F::Store4(box + 8 * g + 4, hi);
  }
}

int Frame::SortGroupsByLow() {
  const size_t groups = filter.group_count();
  const float* box = st.groups.box.data();
  float lo_end[3], hi_end[3];
  for (int a = 0; a < 3; ++a) {
    lo_end[a] = std::numeric_limits<float>::infinity();
    hi_end[a] = -std::numeric_limits<float>::infinity();
    for (uint32_t g = 0; g < groups; ++g) {
      if (!(box[8 * g] <= box[8 * g + 4])) continue;  // no sphere
      lo_end[a] = std::min(lo_end[a], box[8 * g + a]);
      hi_end[a] = std::max(hi_end[a], box[8 * g + a]);
    }
  }
  int axis = 0;
  for (int a = 1; a < 3; ++a) axis = hi_end[a] - lo_end[a] > hi_end[axis] - lo_end[axis] ? a : axis;
  uint32_t* order = st.groups.order.data();
  const auto low = [&](uint32_t g) { return box[8 * g + axis]; };
  const auto before = [&](uint32_t g, uint32_t h) { return low(g) < low(h) || (low(g) == low(h) && g < h); };
  size_t moves = 0;
  for (size_t q = 1; q < groups && moves <= 4 * groups; ++q) {
    const uint32_t g = order[q];
    size_t m = q;
    for (; m > 0 && before(g, order[m - 1]); --m, ++moves) order[m] = order[m - 1];
    order[m] = g;
  }
  if (moves > 4 * groups) std::sort(order, order + groups, before);
  return axis;
}

size_t Frame::CrossGroups(bool to_out) {
  const size_t groups = filter.group_count();
  GroupBoxes();
  const int axis = SortGroupsByLow();
  const float* box = st.groups.box.data();
  const uint32_t* order = st.groups.order.data();
  const auto low = [&](uint32_t g) { return box[8 * g + axis]; };
  namespace F = simd::native;
  // Candidates of one pair of characters at a time, rows ascending (test_candidates reads a
  // block as one row when its first and last rows agree, so the rows must not go back).
  st.groups.cross.clear();
  uint32_t* pi = st.scratch.pairs_i.data();
  uint32_t* pj = st.scratch.pairs_j.data();
  const size_t capacity = st.max_candidates;
  const uint16_t* parts = filter.parts().data();
  size_t count = 0, candidates = 0;
  bool room = true;
  const auto test = [&] {
    std::fill(pi + count, pi + count + kPad, 0u);
    std::fill(pj + count, pj + count + kPad, 0u);
    kernels::ContactSink sink{st.stage.data(), kStage, 0};
    for (size_t pos = 0; pos < count;) {
      pos = k.test_candidates(spheres, pi, pj, pos, count, parts, &sink);
      std::vector<SpherePair>& into = to_out ? *job.out : st.groups.cross;
      if (!to_out && st.groups.cross.size() + sink.count > st.groups.cross.capacity()) room = false;
      if (room) into.insert(into.end(), st.stage.data(), st.stage.data() + sink.count);
      sink.count = 0;
    }
    candidates += count;
    count = 0;
  };
  const auto inside = [&](uint32_t g, const float* other, std::vector<uint32_t>* list) {
    list->clear();
    float sphere_box[8];
    for (uint32_t s = filter.group_begin(g); s < filter.group_begin(g + 1); ++s) {
      F::Float4 l, h;
      PaddedBox(spheres + 4 * size_t{s}, &l, &h);
      F::Store4(sphere_box, l);
      F::Store4(sphere_box + 4, h);
      if (BoxesOverlap(sphere_box, other)) list->push_back(s);
    }
  };
  // A sweep along that axis over the characters' boxes; each pair whose boxes overlap, as it is
  // found.
  for (size_t q = 0; q < groups && room; ++q) {
    const uint32_t first = order[q];
    const float high = box[8 * first + 4 + axis];
    for (size_t q2 = q + 1; q2 < groups && low(order[q2]) <= high && room; ++q2) {
      const uint32_t g = std::min(first, order[q2]), h = std::max(first, order[q2]);
      if (!BoxesOverlap(box + 8 * g, box + 8 * h)) continue;
      inside(g, box + 8 * h, &st.groups.inside_a);
      if (st.groups.inside_a.empty()) continue;
      inside(h, box + 8 * g, &st.groups.inside_b);
      for (const uint32_t a : st.groups.inside_a) {
        if (count + st.groups.inside_b.size() > capacity) test();
        for (const uint32_t b : st.groups.inside_b) {
          pi[count] = a;
          pj[count] = b;
          ++count;
        }
      }
      test();
    }
  }
  if (!room) return SIZE_MAX;
  if (!to_out) std::sort(st.groups.cross.begin(), st.groups.cross.end(), ByPair);
  return candidates;
}

void Frame::RunGroups() {
  const size_t groups = filter.group_count();
  const bool between = filter.pairs_between_groups();
  size_t cross_candidates = between ? CrossGroups(false) : 0;
  const bool merged = cross_candidates != SIZE_MAX;
  if (!between || !merged) st.groups.cross.clear();
  size_t candidates = 0, tests = 0, builds = 0;
  double lookahead = 0.0;
  const std::vector<SpherePair>& cross = st.groups.cross;
  size_t c = 0;
  std::vector<SpherePair>& out = *job.out;
  if (filter.pairs_within_groups()) {
    for (uint32_t g = 0; g < groups; ++g) {
      const uint32_t b = filter.group_begin(g), e = filter.group_begin(g + 1);
      BroadPhaseContext& gc = st.groups.contexts[g];
      const uint64_t builds_before = gc.build_count();
      const BroadPhaseJob sub{job.spheres.subspan(b, e - b), &st.groups.filters[g], &gc, &st.groups.out, job.simd};
      st.groups.out.clear();
      Frame(sub, k).Run();  // cannot fail: the values were checked, the sizes match
      candidates += gc.last_candidate_count();
      tests += gc.last_build_tests();
      builds += gc.build_count() - builds_before;
      lookahead += gc.last_lookahead();
      for (SpherePair w : st.groups.out) {
        w.sphere_i += b;
        w.sphere_j += b;
        while (c < cross.size() && ByPair(cross[c], w)) out.push_back(cross[c++]);
        out.push_back(w);
      }
    }
  }
  out.insert(out.end(), cross.begin() + static_cast<ptrdiff_t>(c), cross.end());
  if (!merged) {
    // More sphere pairs between characters than the context holds: appended, then all sorted.
    cross_candidates = CrossGroups(true);
    std::sort(out.begin(), out.end(), ByPair);
  }
  // Characters piled into each other: their pairs, tested afresh every frame, cost more than
  // one cache over the whole space would hold; run the space as one set for a while.
  if (cross_candidates > kGroupsCrossMax * n + 1024) st.groups.pause = kGroupsPause;
  st.last.method = BroadPhaseMethod::kGroups;
  st.last.candidates = candidates + cross_candidates;
  st.last.build_tests = tests + cross_candidates;
  st.last.builds += builds;
  st.lookahead.last = float(lookahead / double(groups));
}

}  // namespace skinspheres::runtime::broad_phase
