// Sets of each kind of contact rules (narrow_phase/contact_rules.h) for the format tests: a set as a
// file written before the rules on triangles reads (ContactRules::kSpherePairs), and a hand-made set
// with its rules on triangles filled by WriteContactRules.
#pragma once

#include <gtest/gtest.h>

#include <bit>
#include <cstdint>

#include "skinspheres/runtime/format/sphere_set.h"
#include "skinspheres/runtime/narrow_phase/contact_rules.h"

namespace skinspheres::runtime {

// The set as read from a file before the rules on triangles (JSON versions 1-3, binary layouts 1-5):
// its excluded pairs as they are, reasons included, contact hops 0 and rest gap 0.
inline SphereSet WithRulesOnSpherePairs(SphereSet set) {
  set.contact_rules = ContactRules::kSpherePairs;
  set.contact_hops = 0;
  set.rest_gap = 0.0f;
  return set;
}

// The set with its rules on triangles at `hops` and a rest gap of `rest_gap_share` of the rest height,
// excluded pairs as rule 2 gives them (WriteContactRules).
inline SphereSet WithRulesOnTriangles(SphereSet set, uint32_t hops, float rest_gap_share) {
  const auto err = WriteContactRules(&set, hops, rest_gap_share);
  EXPECT_FALSE(err.has_value()) << err->message;
  return set;
}

// A float's bits: -0 and +0 differ, as in a file.
inline uint32_t Bits(float x) { return std::bit_cast<uint32_t>(x); }

// The contact rules of two sets are the same, bit for bit.
inline void ExpectSameRules(const SphereSet& a, const SphereSet& b) {
  EXPECT_EQ(a.contact_rules, b.contact_rules);
  EXPECT_EQ(a.contact_hops, b.contact_hops);
  EXPECT_EQ(Bits(a.rest_gap), Bits(b.rest_gap)) << a.rest_gap << " vs " << b.rest_gap;
  ASSERT_EQ(a.excluded_pairs.size(), b.excluded_pairs.size());
  for (size_t k = 0; k < a.excluded_pairs.size(); ++k) {
    EXPECT_EQ(a.excluded_pairs[k].i, b.excluded_pairs[k].i) << "pair " << k;
    EXPECT_EQ(a.excluded_pairs[k].j, b.excluded_pairs[k].j) << "pair " << k;
    EXPECT_EQ(a.excluded_pairs[k].reason, b.excluded_pairs[k].reason) << "pair " << k;
  }
}

}  // namespace skinspheres::runtime
