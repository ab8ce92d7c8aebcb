// The candidate cache (broad_phase/frame.h, context_state.h: CandidateCache): its per-frame check,
// the skins and builds (all pairs, or the sweep of sweep.cc, then sorted), and the exact sphere test
// on its candidates.
//
// Rounding. The build accepts every pair whose grown spheres truly touch: its float test errs by a
// few units of 2^-24 relative to the distances, far below the 2^-16 growth. The check's float
// error is at most ~8u relative to the moved distance plus 2u |shift| (each subtraction is exactly
// rounded relative to its result), covered by allowing only skin (1 - 2^-16) - 2^-20 |shift|. A
// pair the exact float test accepts is within (r_i + r_j)(1 + 4u) in reals, also covered. So a
// frame's sphere pairs are exactly the oracle's whatever the cache's history.
#include <algorithm>
#include <cmath>
#include <limits>

#include "broad_phase/frame.h"
#include "broad_phase/sphere_test.h"

namespace skinspheres::runtime::broad_phase {

bool Frame::CacheHolds(const float sum[3]) {
  const float inv_n = 1.0f / static_cast<float>(n);
  float shift[3];
  float largest = 0.0f;
  for (int a = 0; a < 3; ++a) {
    shift[a] = (sum[a] - st.cache.ref_sum[a]) * inv_n;
    largest = std::max(largest, std::fabs(shift[a]));
  }
  return k.check_motion(spheres, st.cache.ref.data(), st.cache.allow.data(), n, shift, largest * kSlackRelative, padded,
                        st.cache.motion.data());
}

void Frame::Skins(bool have_motion, float lookahead) {
  float radius_sum = 0.0f, speed_sum = 0.0f;
  const float inv_age = 1.0f / static_cast<float>(std::max<uint32_t>(st.cache.age, 1));
  float* speed = st.cache.speed.data();
  for (size_t s = 0; s < n; ++s) {
    radius_sum += Sphere(s).w();
    speed[s] = have_motion ? std::max(st.cache.motion[s] * inv_age, 0.5f * speed[s]) : 0.0f;
    speed_sum += speed[s];
  }
  const float cap_add = 4.0f * radius_sum / static_cast<float>(n);
  const float slowest = 0.5f * speed_sum / static_cast<float>(n);
  float* grown = Soa(kGrown);
  for (size_t s = 0; s < n; ++s) {
    const float r = Sphere(s).w();
    const float floor = std::max(r * kSkinFloorRelative, kSkinMin);
    const float cap = std::max(floor, std::min(r + cap_add, internal::kMaxMagnitude));
    const float skin = std::clamp(lookahead * std::max(speed[s], slowest), floor, cap);
    grown[s] = (r + skin) * kGrow;
    st.cache.allow[s] = skin * kAllowFactor;
  }
}

void Frame::CopyCentres() {
  float* x = Soa(0);
  float* y = Soa(1);
  float* z = Soa(2);
  for (size_t s = 0; s < n; ++s) {
    x[s] = Sphere(s).x();
    y[s] = Sphere(s).y();
    z[s] = Sphere(s).z();
  }
}

void Frame::PadIndexOrder() {
  for (int field : {0, 1, 2, int(kGrown)}) {
    std::fill(Soa(field) + n, Soa(field) + padded, std::numeric_limits<float>::quiet_NaN());
  }
}

bool Frame::AllPairsBuild() {
  kernels::SoaSpheres s{Soa(0), Soa(1), Soa(2), Soa(kGrown), nullptr, nullptr, nullptr};
  kernels::PairSink sink{st.cache.i.data(), st.cache.j.data(), st.max_candidates, 0, false};
  size_t tests = 0;
  const kernels::FilterView rows_view = AllPairsView();
  const uint32_t next =
      k.all_pairs_build(s, static_cast<uint32_t>(n), 0, static_cast<uint32_t>(n), rows_view, &sink, &tests);
  st.last.build_tests += tests;
  st.cache.count = sink.count;
  return next == n;
}

void Frame::SortPairsIntoCache(size_t m) {
  uint32_t* count = st.scratch.row.data();
  const auto pass = [&](const uint32_t* key, const uint32_t* other, uint32_t* key_out, uint32_t* other_out) {
    std::fill(count, count + n + 1, 0u);
    for (size_t p = 0; p < m; ++p) ++count[key[p] + 1];
    for (size_t s = 0; s < n; ++s) count[s + 1] += count[s];
    for (size_t p = 0; p < m; ++p) {
      const uint32_t at = count[key[p]]++;
      key_out[at] = key[p];
      other_out[at] = other[p];
    }
  };
  pass(st.scratch.pairs_j.data(), st.scratch.pairs_i.data(), st.cache.j.data(),
       st.cache.i.data());  // by j into (ci, cj)
  pass(st.cache.i.data(), st.cache.j.data(), st.scratch.pairs_i.data(),
       st.scratch.pairs_j.data());  // stably by i into (pi, pj)
  std::swap(st.cache.i, st.scratch.pairs_i);
  std::swap(st.cache.j, st.scratch.pairs_j);
  st.cache.count = m;
}

void Frame::PadCache() {
  std::fill(st.cache.i.data() + st.cache.count, st.cache.i.data() + st.cache.count + kPad, 0u);
  std::fill(st.cache.j.data() + st.cache.count, st.cache.j.data() + st.cache.count + kPad, 0u);
}

bool Frame::Build(bool have_motion, const float sum[3]) {
  ++st.last.builds;
  st.last.build_tests = 0;
  const bool small = n <= kAllPairsMax;
  for (float lookahead : {have_motion ? kLookahead[st.lookahead.rung] : 0.0f, 0.0f}) {
    st.lookahead.last = lookahead;
    Skins(have_motion, lookahead);
    CopyCentres();
    bool fits;
    if (small) {
      PadIndexOrder();
      fits = AllPairsBuild();
    } else {
      size_t m = 0;
      fits = SweepBuild(&m);
      if (fits) SortPairsIntoCache(m);
    }
    if (fits) {
      st.last.method = small ? BroadPhaseMethod::kAllPairsBuild : BroadPhaseMethod::kSweepBuild;
      PadCache();
      // The reference: this frame's spheres.
      float* rx = st.cache.ref.data();
      for (size_t s = 0; s < n; ++s) {
        const Vec4f& p = Sphere(s);
        rx[s] = p.x();
        rx[padded + s] = p.y();
        rx[2 * padded + s] = p.z();
        rx[3 * padded + s] = p.w();
      }
      std::copy(sum, sum + 3, st.cache.ref_sum);
      st.cache.valid = true;
      st.cache.sphere_count = n;
      st.cache.filter = filter.id();
      st.cache.age = 0;
      return true;
    }
    // Too many candidates with these skins: less lookahead from now on, and this rung looks
    // expensive for a long while. A small set goes straight to the direct path (all pairs into
    // the output), cheaper than another build.
    double& memory = st.lookahead.rung_cost[st.lookahead.rung];
    memory = 4.0 * std::max({memory, st.lookahead.rung_cost[std::max(MinRung(), st.lookahead.rung - 1)], 1.0});
    st.lookahead.rung = std::max(MinRung(), st.lookahead.rung - 2);
    if (lookahead == 0.0f || small) break;
  }
  st.cache.valid = false;
  return false;
}

void Frame::TestCache() {
  const uint16_t* parts = filter.parts().data();
  kernels::ContactSink sink{st.stage.data(), kStage, 0};
  const size_t count = st.cache.count;
  for (size_t pos = 0; pos < count;) {
    pos = k.test_candidates(spheres, st.cache.i.data(), st.cache.j.data(), pos, count, parts, &sink);
    job.out->insert(job.out->end(), st.stage.data(), st.stage.data() + sink.count);
    sink.count = 0;
  }
  st.last.candidates = count;
}

}  // namespace skinspheres::runtime::broad_phase
