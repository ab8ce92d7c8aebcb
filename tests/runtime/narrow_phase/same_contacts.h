// Narrow-phase outputs compared field by field, bit for bit (narrow_phase_tests.cc,
// narrow_phase_rules_tests.cc).
#pragma once

#include <gtest/gtest.h>

#include <cstring>
#include <string>

#include "skinspheres/runtime/narrow_phase/narrow_phase.h"

namespace skinspheres::test {

inline bool SameFloats(const float* a, const float* b, int n) { return std::memcmp(a, b, sizeof(float) * n) == 0; }

// Field by field, bit for bit; the first difference goes to *why.
inline bool Same(const runtime::FrameContacts& a, const runtime::FrameContacts& b, std::string* why) {
  if (a.parts.size() != b.parts.size()) return *why = "part pair counts differ", false;
  if (a.sphere_pairs != b.sphere_pairs) return *why = "sphere pairs differ", false;
  if (a.triangle_pairs.size() != b.triangle_pairs.size()) {
    return *why = "triangle pair counts differ: " + std::to_string(a.triangle_pairs.size()) + " vs " +
                  std::to_string(b.triangle_pairs.size()),
           false;
  }
  for (size_t k = 0; k < a.triangle_pairs.size(); ++k) {
    const auto &p = a.triangle_pairs[k], &q = b.triangle_pairs[k];
    if (p.triangle_a != q.triangle_a || p.triangle_b != q.triangle_b || p.kind != q.kind || p.distance != q.distance ||
        !SameFloats(p.point, q.point, 3) || !SameFloats(p.on_a, q.on_a, 3) || !SameFloats(p.on_b, q.on_b, 3)) {
      return *why = "triangle pair " + std::to_string(k) + " differs: (" + std::to_string(p.triangle_a) + "," +
                    std::to_string(p.triangle_b) + ") vs (" + std::to_string(q.triangle_a) + "," +
                    std::to_string(q.triangle_b) + ")",
             false;
    }
  }
  for (size_t k = 0; k < a.parts.size(); ++k) {
    const auto &p = a.parts[k], &q = b.parts[k];
    if (p.part_a != q.part_a || p.part_b != q.part_b || p.first_sphere_pair != q.first_sphere_pair ||
        p.sphere_pair_count != q.sphere_pair_count || p.first_triangle_pair != q.first_triangle_pair ||
        p.triangle_pair_count != q.triangle_pair_count || p.intersecting_count != q.intersecting_count ||
        p.depth != q.depth || p.min_distance != q.min_distance || !SameFloats(p.normal, q.normal, 3) ||
        !SameFloats(p.center, q.center, 3)) {
      return *why = "part pair " + std::to_string(k) + " differs (depth " + std::to_string(p.depth) + " vs " +
                    std::to_string(q.depth) + ")",
             false;
    }
  }
  return true;
}

#define EXPECT_SAME_CONTACTS(a, b, label)                                             \
  do {                                                                                \
    std::string why_;                                                                 \
    EXPECT_TRUE(::skinspheres::test::Same((a), (b), &why_)) << label << ": " << why_; \
  } while (0)

}  // namespace skinspheres::test
