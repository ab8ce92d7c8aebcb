// The filter's listed exclusions as bits (context_state.h: ListedPairBits), made once per filter:
// rows for the all-pairs kernels, or each sphere's neighbourhood in index order for the sweep.
#include <algorithm>

#include "broad_phase/frame.h"

namespace skinspheres::runtime::broad_phase {

kernels::FilterView Frame::AllPairsView() {
  kernels::FilterView v = view;
  const size_t words = AllPairsRowWords(n);
  if (filter.excluded_pair_count() == 0 || st.listed.bits.size() < words * n) return v;
  if (st.listed.sphere_count != n || st.listed.filter != filter.id()) {
    uint64_t* rows = st.listed.bits.data();
    std::fill(rows, rows + words * n, uint64_t{0});
    for (uint32_t i = 0; i < n; ++i) {
      for (const uint32_t j : filter.excluded_partners(i)) {
        if (j > i) rows[i * words + (j >> 6)] |= uint64_t{1} << (j & 63u);
      }
    }
    st.listed.filter = filter.id();
    st.listed.sphere_count = n;
  }
  v.row_bits = st.listed.bits.data();
  v.row_words = words;
  return v;
}

kernels::FilterView Frame::SweepView() {
  kernels::FilterView v = view;
  if (filter.excluded_pair_count() == 0) return v;
  if (st.listed.sphere_count != n || st.listed.filter != filter.id()) {
    uint64_t* near = st.listed.bits.data();
    std::fill(near, near + kernels::kNearWords * n, uint64_t{0});
    for (uint32_t i = 0; i < n; ++i) {
      uint8_t far = 0;
      for (const uint32_t j : filter.excluded_partners(i)) {
        const uint32_t d = j + kernels::kNearRange - i;  // modulo 2^32
        if (d < 2 * kernels::kNearRange) {
          near[size_t{i} * kernels::kNearWords + (d >> 6)] |= uint64_t{1} << (d & 63u);
        } else {
          far = 1;
        }
      }
      st.listed.far[i] = far;
    }
    st.listed.filter = filter.id();
    st.listed.sphere_count = n;
  }
  v.near = st.listed.bits.data();
  v.far = st.listed.far.data();
  return v;
}

}  // namespace skinspheres::runtime::broad_phase
