// No cache fits (or none pays): the frame's sphere pairs straight into the output, by all pairs or by
// the sweep (then sorted).
#include <algorithm>

#include "broad_phase/frame.h"
#include "broad_phase/sphere_test.h"

namespace skinspheres::runtime::broad_phase {

void Frame::FlushDirect(size_t m) {
  const uint32_t* pi = st.scratch.pairs_i.data();
  const uint32_t* pj = st.scratch.pairs_j.data();
  const bool listed = filter.excluded_pair_count() > 0;
  for (size_t p = 0; p < m; ++p) {
    const uint32_t i = pi[p], j = pj[p];
    if (listed && filter.excluded(i, j)) continue;
    job.out->push_back(
        SpherePair{i, j, internal::PenetrationDepth(Sphere(i), Sphere(j)), filter.part(i), filter.part(j)});
  }
}

void Frame::Direct() {
  st.last.build_tests = 0;
  if (n <= kAllPairsMax) {
    st.last.method = BroadPhaseMethod::kAllPairsDirect;
    CopyCentres();
    float* r = Soa(kGrown);
    for (size_t s = 0; s < n; ++s) r[s] = Sphere(s).w();
    PadIndexOrder();
    kernels::SoaSpheres s{Soa(0), Soa(1), Soa(2), Soa(kGrown), nullptr, nullptr, nullptr};
    kernels::ContactSink sink{st.stage.data(), kStage, 0};
    size_t tests = 0;
    const kernels::FilterView rows_view = AllPairsView();
    for (uint32_t row = 0; row < n;) {
      row = k.all_pairs_contacts(s, static_cast<uint32_t>(n), row, static_cast<uint32_t>(n), rows_view, &sink, &tests);
      job.out->insert(job.out->end(), st.stage.data(), st.stage.data() + sink.count);
      sink.count = 0;
    }
    st.last.build_tests = tests;
    return;
  }
  st.last.method = BroadPhaseMethod::kSweepDirect;
  float* r = Soa(kGrown);
  for (size_t s = 0; s < n; ++s) r[s] = Sphere(s).w();
  SweepDirect();
  std::sort(job.out->begin(), job.out->end(), ByPair);
}

}  // namespace skinspheres::runtime::broad_phase
