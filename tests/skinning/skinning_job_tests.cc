// SkinningJob against the plain reference loop (SkinReference) and analytic cases: every SIMD
// level, CSR and prepared influences, 0..8 influences, strided buffers, subsets, 1 vs N threads,
// and every refusal of Validate().
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <utility>
#include <vector>

#include "skinning/synthetic_mesh.h"
#include "skinspheres/skinning/prepared_influences.h"
#include "skinspheres/skinning/skinning_job.h"
#include "test_support.h"

namespace skinspheres::skinning {
namespace {

using test::MakeSyntheticMesh;
using test::SyntheticMesh;

constexpr float kSentinel = -12345.0f;

std::vector<SimdLevel> SupportedLevels() {
  std::vector<SimdLevel> levels;
  for (SimdLevel l : {SimdLevel::kPortable, SimdLevel::kSse2, SimdLevel::kAvx2, SimdLevel::kAvx512})
    if (SimdLevelSupported(l)) levels.push_back(l);
  return levels;
}

// Copies packed xyz into a buffer with the given stride (floats), padding filled with sentinels.
std::vector<float> Strided(const std::vector<float>& packed, size_t stride_floats) {
  const size_t n = packed.size() / 3;
  std::vector<float> out((n - 1) * stride_floats + 3, kSentinel);
  for (size_t v = 0; v < n; ++v)
    for (int c = 0; c < 3; ++c) out[v * stride_floats + c] = packed[3 * v + c];
  return out;
}

SkinningJob CsrJob(const SyntheticMesh& m, std::span<const float> in, std::span<float> out) {
  SkinningJob job;
  job.joint_matrices = m.matrices;
  job.vertex_count = m.vertex_count;
  job.in_positions = in;
  job.out_positions = out;
  job.influence_offsets = m.offsets;
  job.influence_binds = m.binds;
  job.influence_weights = m.weights;
  return job;
}

// Largest |a - b| over the xyz of the given vertices.
float MaxDiff(const std::vector<float>& a, const std::vector<float>& b, size_t stride,
              const std::vector<uint32_t>& verts) {
  float d = 0.0f;
  for (uint32_t v : verts)
    for (int c = 0; c < 3; ++c) d = std::max(d, std::abs(a[v * stride + c] - b[v * stride + c]));
  return d;
}

std::vector<uint32_t> AllVertices(size_t n) {
  std::vector<uint32_t> v(n);
  for (size_t i = 0; i < n; ++i) v[i] = static_cast<uint32_t>(i);
  return v;
}

TEST(SkinningJob, DefaultJobIsInvalid) {
  SkinningJob job;
  EXPECT_FALSE(job.Validate());
  EXPECT_FALSE(job.Run());
  EXPECT_FALSE(job.RunParallel());
  EXPECT_FALSE(SkinReference(job));
}

TEST(SkinningJob, RigidTransformIsExactForAnyWeights) {
  // All matrices equal T: p' = Σ w_k T p = T p when Σ w_k = 1 (analytic, independent of the reference).
  SyntheticMesh m = MakeSyntheticMesh(500, 12, 1, 8, 1);
  std::mt19937 rng(5);
  const skinspheres::Mat4f t = test::RandomAffine(rng, false);
  std::fill(m.matrices.begin(), m.matrices.end(), t);
  for (SimdLevel level : SupportedLevels()) {
    std::vector<float> out(m.positions.size(), 0.0f);
    SkinningJob job = CsrJob(m, m.positions, out);
    job.simd = level;
    ASSERT_TRUE(job.Run()) << ToString(level);
    for (size_t v = 0; v < m.vertex_count; ++v) {
      const skinspheres::Vec4f p =
          t * skinspheres::Vec4f(m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2], 1);
      for (int c = 0; c < 3; ++c) ASSERT_NEAR(out[3 * v + c], p[c], 1e-5f) << ToString(level) << " vertex " << v;
    }
  }
}

TEST(SkinningJob, MatchesReferenceOneToEightInfluences) {
  for (int max_inf = 1; max_inf <= 8; ++max_inf) {
    const SyntheticMesh m = MakeSyntheticMesh(3000, 70, max_inf == 1 ? 0 : 1, max_inf, 100 + max_inf);
    std::vector<float> expected(m.positions.size(), 0.0f);
    ASSERT_TRUE(SkinReference(CsrJob(m, m.positions, expected)));
    for (SimdLevel level : SupportedLevels()) {
      std::vector<float> out(m.positions.size(), kSentinel);
      SkinningJob job = CsrJob(m, m.positions, out);
      job.simd = level;
      ASSERT_TRUE(job.Validate());
      ASSERT_TRUE(job.Run());
      EXPECT_LT(MaxDiff(out, expected, 3, AllVertices(m.vertex_count)), 2e-5f)
          << ToString(level) << " max influences " << max_inf;
    }
  }
}

TEST(SkinningJob, PreparedIsBitIdenticalToCsr) {
  const SyntheticMesh m = MakeSyntheticMesh(4000, 70, 1, 11, 7);  // counts past the unrolled 8 too
  std::mt19937 rng(3);
  std::vector<uint32_t> subset;
  for (size_t i = 0; i < 700; ++i) subset.push_back(static_cast<uint32_t>(rng() % m.vertex_count));
  for (bool use_subset : {false, true}) {
    PreparedInfluences prepared;
    ASSERT_TRUE(prepared.Build(m.vertex_count, m.offsets, m.binds, m.weights,
                               use_subset ? std::span<const uint32_t>(subset) : std::span<const uint32_t>()));
    for (SimdLevel level : SupportedLevels()) {
      std::vector<float> csr_out(m.positions.size(), kSentinel), prep_out(m.positions.size(), kSentinel);
      SkinningJob csr = CsrJob(m, m.positions, csr_out);
      csr.simd = level;
      if (use_subset) csr.subset = subset;
      ASSERT_TRUE(csr.Run());
      SkinningJob prep;
      prep.joint_matrices = m.matrices;
      prep.vertex_count = m.vertex_count;
      prep.in_positions = m.positions;
      prep.out_positions = prep_out;
      prep.prepared = &prepared;
      prep.simd = level;
      ASSERT_TRUE(prep.Validate());
      ASSERT_TRUE(prep.Run());
      EXPECT_EQ(0, std::memcmp(csr_out.data(), prep_out.data(), csr_out.size() * sizeof(float)))
          << ToString(level) << (use_subset ? " subset" : " full");
    }
  }
}

// The documented order of operations (skinning_kernels.h), written out in plain floats: the blended
// columns in two chains (even and odd influences) added at the end, then ((C0 x + C1 y) + C2 z) +
// C3. Every level must give exactly these bits: that is what makes skinning, and the exact refit
// and narrow phase behind it, the same on every platform (aarch64 runs the portable level).
std::vector<float> SkinInDocumentedOrder(const SyntheticMesh& m) {
  std::vector<float> out(m.positions.size(), 0.0f);
  for (size_t v = 0; v < m.vertex_count; ++v) {
    const uint32_t first = m.offsets[v], count = m.offsets[v + 1] - first;
    float even[16] = {}, odd[16] = {};
    for (uint32_t k = 0; k < count; ++k) {
      const float* mat = m.matrices[m.binds[first + k]].data();
      const float w = m.weights[first + k];
      float* chain = k % 2 == 0 ? even : odd;
      for (int e = 0; e < 16; ++e) chain[e] = k < 2 ? w * mat[e] : chain[e] + w * mat[e];
    }
    float c[16];
    for (int e = 0; e < 16; ++e) c[e] = count > 1 ? even[e] + odd[e] : even[e];
    const float x = m.positions[3 * v], y = m.positions[3 * v + 1], z = m.positions[3 * v + 2];
    for (int r = 0; r < 3; ++r) {
      const float xy = c[r] * x + c[4 + r] * y;
      const float xyz = xy + c[8 + r] * z;
      out[3 * v + r] = count == 0 ? 0.0f : xyz + c[12 + r];
    }
  }
  return out;
}

TEST(SkinningJob, EveryLevelGivesTheDocumentedBits) {
  for (int max_inf = 1; max_inf <= 11; ++max_inf) {
    const SyntheticMesh m = MakeSyntheticMesh(2000, 70, max_inf == 1 ? 0 : 1, max_inf, 300 + max_inf);
    const std::vector<float> expected = SkinInDocumentedOrder(m);
    PreparedInfluences prepared;
    ASSERT_TRUE(prepared.Build(m.vertex_count, m.offsets, m.binds, m.weights, {}));
    for (SimdLevel level : SupportedLevels()) {
      for (bool use_prepared : {false, true}) {
        std::vector<float> out(m.positions.size(), kSentinel);
        SkinningJob job = CsrJob(m, m.positions, out);
        job.simd = level;
        if (use_prepared) {
          job.influence_offsets = {};
          job.influence_binds = {};
          job.influence_weights = {};
          job.prepared = &prepared;
        }
        ASSERT_TRUE(job.Run());
        size_t differ = 0;
        for (size_t i = 0; i < out.size(); ++i) differ += std::memcmp(&out[i], &expected[i], sizeof(float)) != 0;
        EXPECT_EQ(differ, 0u) << ToString(level) << (use_prepared ? " prepared" : " csr") << ", up to " << max_inf
                              << " influences: coordinates that differ from the documented order";
      }
    }
    std::printf("up to %d influences: %zu levels checked\n", max_inf, SupportedLevels().size());
  }
}

TEST(SkinningJob, StridedBuffersAndSubsetTouchOnlyTheirVertices) {
  const SyntheticMesh m = MakeSyntheticMesh(2000, 40, 1, 6, 11);
  const size_t in_stride = 8, out_stride = 5;  // floats: position + normal + uv / position + 2 extras
  const std::vector<float> in = Strided(m.positions, in_stride);
  std::mt19937 rng(9);
  std::vector<uint32_t> subset;
  for (size_t v = 0; v < m.vertex_count; ++v)
    if (rng() % 7 == 0) subset.push_back(static_cast<uint32_t>(v));
  subset.push_back(subset.front());  // duplicates are allowed
  std::vector<float> expected(m.positions.size(), 0.0f);
  ASSERT_TRUE(SkinReference(CsrJob(m, m.positions, expected)));
  const std::vector<float> expected_strided = Strided(expected, out_stride);

  PreparedInfluences prepared;
  ASSERT_TRUE(prepared.Build(m.vertex_count, m.offsets, m.binds, m.weights, subset));
  for (SimdLevel level : SupportedLevels()) {
    for (bool use_prepared : {false, true}) {
      std::vector<float> out((m.vertex_count - 1) * out_stride + 3, kSentinel);
      SkinningJob job = CsrJob(m, in, out);
      job.in_stride_bytes = in_stride * sizeof(float);
      job.out_stride_bytes = out_stride * sizeof(float);
      job.simd = level;
      if (use_prepared) {
        job.influence_offsets = {};
        job.influence_binds = {};
        job.influence_weights = {};
        job.prepared = &prepared;
      } else {
        job.subset = subset;
      }
      ASSERT_TRUE(job.Run()) << ToString(level);
      std::vector<bool> in_subset(m.vertex_count, false);
      for (uint32_t v : subset) in_subset[v] = true;
      for (size_t i = 0; i < out.size(); ++i) {
        const size_t v = i / out_stride, c = i % out_stride;
        if (c < 3 && in_subset[v]) {
          ASSERT_NEAR(out[i], expected_strided[i], 2e-5f) << "vertex " << v;
        } else {
          ASSERT_EQ(out[i], kSentinel) << "float " << i << " (vertex " << v << ") was written";
        }
      }
    }
  }
}

TEST(SkinningJob, InPlaceWithSameBufferAndStride) {
  const SyntheticMesh m = MakeSyntheticMesh(300, 10, 1, 4, 2);
  std::vector<float> expected(m.positions.size(), 0.0f);
  ASSERT_TRUE(SkinReference(CsrJob(m, m.positions, expected)));
  std::vector<float> buffer = m.positions;
  SkinningJob job = CsrJob(m, buffer, buffer);
  ASSERT_TRUE(job.Run());
  EXPECT_LT(MaxDiff(buffer, expected, 3, AllVertices(m.vertex_count)), 2e-5f);
}

TEST(SkinningJob, OneAndManyThreadsAreBitIdentical) {
  const SyntheticMesh m = MakeSyntheticMesh(20000, 70, 1, 8, 21);
  std::mt19937 rng(4);
  std::vector<uint32_t> subset;
  for (size_t v = 0; v < m.vertex_count; v += 1 + rng() % 5) subset.push_back(static_cast<uint32_t>(v));
  PreparedInfluences prepared;
  ASSERT_TRUE(prepared.Build(m.vertex_count, m.offsets, m.binds, m.weights, subset));
  for (int variant = 0; variant < 3; ++variant) {  // CSR full, CSR subset, prepared subset
    std::vector<float> serial(m.positions.size(), kSentinel);
    SkinningJob job = CsrJob(m, m.positions, serial);
    if (variant == 1) job.subset = subset;
    if (variant == 2) {
      job.influence_offsets = {};
      job.influence_binds = {};
      job.influence_weights = {};
      job.prepared = &prepared;
    }
    ASSERT_TRUE(job.Run());
    for (int threads : {1, 2, 4}) {
      for (size_t grain : {size_t{1}, size_t{37}, size_t{4096}}) {
        std::vector<float> parallel(m.positions.size(), kSentinel);
        SkinningJob pj = job;
        pj.out_positions = parallel;
        bool ok = false;
        test::WithDefaultThreads(threads, [&] { ok = pj.RunParallel(DefaultParallelFor(), grain); });
        ASSERT_TRUE(ok);
        ASSERT_EQ(0, std::memcmp(serial.data(), parallel.data(), serial.size() * sizeof(float)))
            << "variant " << variant << " threads " << threads << " grain " << grain;
      }
    }
    // Manual split through RunRange, as an engine scheduler would.
    std::vector<float> split(m.positions.size(), kSentinel);
    SkinningJob sj = job;
    sj.out_positions = split;
    const size_t n = sj.WorkSize();
    ASSERT_TRUE(sj.RunRange(0, n / 3));
    ASSERT_TRUE(sj.RunRange(n / 3, n / 3));  // empty range
    ASSERT_TRUE(sj.RunRange(n / 3, n));
    EXPECT_EQ(0, std::memcmp(serial.data(), split.data(), serial.size() * sizeof(float)));
    // The same split as one list of ranges, out of order, one empty and one overlapping.
    std::vector<float> listed(m.positions.size(), kSentinel);
    sj.out_positions = listed;
    const std::vector<std::pair<uint32_t, uint32_t>> ranges = {
        {uint32_t(n / 2), uint32_t(n)}, {uint32_t(n / 3), uint32_t(n / 3)}, {0, uint32_t(n / 2)}, {1, 7}};
    ASSERT_TRUE(sj.RunRanges(ranges));
    EXPECT_EQ(0, std::memcmp(serial.data(), listed.data(), serial.size() * sizeof(float))) << "variant " << variant;
    // Only the ranges listed are written.
    std::vector<float> part(m.positions.size(), kSentinel);
    sj.out_positions = part;
    const std::vector<std::pair<uint32_t, uint32_t>> some = {{2, 9}, {uint32_t(n / 2), uint32_t(n / 2 + 5)}};
    ASSERT_TRUE(sj.RunRanges(some));
    std::vector<float> by_range(m.positions.size(), kSentinel);
    sj.out_positions = by_range;
    for (const auto& [b, e] : some) ASSERT_TRUE(sj.RunRange(b, e));
    EXPECT_EQ(0, std::memcmp(by_range.data(), part.data(), part.size() * sizeof(float))) << "variant " << variant;
    EXPECT_NE(0, std::memcmp(serial.data(), part.data(), part.size() * sizeof(float)))
        << "more than the ranges written";
  }
}

class SkinningJobValidate : public ::testing::Test {
 protected:
  SyntheticMesh m = MakeSyntheticMesh(100, 8, 1, 4, 3);
  std::vector<float> out = std::vector<float>(m.positions.size(), kSentinel);
  SkinningJob Good() { return CsrJob(m, m.positions, out); }
  void ExpectRefused(const SkinningJob& job, const char* why) {
    EXPECT_FALSE(job.Validate()) << why;
    EXPECT_FALSE(job.Run()) << why;
    EXPECT_FALSE(job.RunParallel()) << why;
    for (float f : out) ASSERT_EQ(f, kSentinel) << why << ": output written by a refused job";
  }
};

TEST_F(SkinningJobValidate, GoodJobPasses) { EXPECT_TRUE(Good().Validate()); }

TEST_F(SkinningJobValidate, RefusesBadBuffers) {
  SkinningJob j = Good();
  j.joint_matrices = {};
  ExpectRefused(j, "no matrices");
  j = Good();
  j.in_positions = std::span<const float>(m.positions).first(m.positions.size() - 1);
  ExpectRefused(j, "input one float short");
  j = Good();
  j.out_positions = std::span<float>(out).first(out.size() - 1);
  ExpectRefused(j, "output one float short");
  j = Good();
  j.in_positions = {};
  ExpectRefused(j, "null input");
  j = Good();
  j.out_positions = {};
  ExpectRefused(j, "null output");
  j = Good();
  j.in_stride_bytes = 8;
  ExpectRefused(j, "input stride below 12 bytes");
  j = Good();
  j.out_stride_bytes = 13;
  ExpectRefused(j, "output stride not a multiple of 4");
  j = Good();
  j.out_stride_bytes = 16;
  ExpectRefused(j, "output too short for its stride");
  j = Good();
  j.vertex_count = 0;
  ExpectRefused(j, "no vertices");
  j = Good();
  j.vertex_count = m.vertex_count + 1;
  ExpectRefused(j, "more vertices than the buffers hold");
  j = Good();
  j.simd = static_cast<SimdLevel>(77);
  ExpectRefused(j, "unknown SIMD level");
}

TEST_F(SkinningJobValidate, RefusesBadInfluences) {
  SkinningJob j = Good();
  j.influence_offsets = std::span<const uint32_t>(m.offsets).first(m.vertex_count);
  ExpectRefused(j, "offsets one short");
  j = Good();
  j.influence_binds = std::span<const uint16_t>(m.binds).first(m.binds.size() - 1);
  ExpectRefused(j, "binds shorter than the last offset");
  j = Good();
  j.influence_weights = std::span<const float>(m.weights).first(m.weights.size() - 1);
  ExpectRefused(j, "weights shorter than the last offset");
  j = Good();
  j.joint_matrices = std::span<const skinspheres::Mat4f>(m.matrices).first(m.matrices.size() - 1);
  const uint16_t max_bind = *std::max_element(m.binds.begin(), m.binds.end());
  ASSERT_EQ(max_bind, m.matrices.size() - 1);
  ExpectRefused(j, "bind index past the matrices");

  std::vector<uint16_t> binds = m.binds;
  binds[binds.size() / 2] = 500;
  j = Good();
  j.influence_binds = binds;
  ExpectRefused(j, "one bind index out of range");
  std::vector<uint32_t> offsets = m.offsets;
  std::swap(offsets[10], offsets[11]);
  j = Good();
  j.influence_offsets = offsets;
  ExpectRefused(j, "decreasing offsets");
}

TEST_F(SkinningJobValidate, RefusesBadSubsetAndRanges) {
  std::vector<uint32_t> subset = {0, 5, static_cast<uint32_t>(m.vertex_count)};
  SkinningJob j = Good();
  j.subset = subset;
  ExpectRefused(j, "subset index out of range");
  EXPECT_TRUE(j.RunRange(0, 2)) << "the valid part of the range still runs";
  EXPECT_FALSE(j.RunRange(1, 3));
  EXPECT_FALSE(j.RunRange(2, 1));
  EXPECT_FALSE(Good().RunRange(0, m.vertex_count + 1));
  // RunRanges checks every range before it writes anything.
  const uint32_t all = uint32_t(m.vertex_count);
  using Ranges = std::vector<std::pair<uint32_t, uint32_t>>;
  EXPECT_TRUE(j.RunRanges(Ranges{{0, 2}, {1, 2}})) << "the valid part of the subset still runs";
  std::fill(out.begin(), out.end(), kSentinel);
  for (const Ranges& bad : {Ranges{{0, 2}, {1, 3}}, Ranges{{0, 2}, {2, 1}}}) {
    EXPECT_FALSE(j.RunRanges(bad));
    for (float f : out) ASSERT_EQ(f, kSentinel) << "output written by a refused list of ranges";
  }
  EXPECT_FALSE(Good().RunRanges(Ranges{{0, 10}, {0, all + 1}}));
  for (float f : out) ASSERT_EQ(f, kSentinel) << "output written by a refused list of ranges";
  SkinningJob no_matrices = Good();
  no_matrices.joint_matrices = {};
  EXPECT_FALSE(no_matrices.RunRanges(Ranges{{0, 10}}));
  EXPECT_TRUE(Good().RunRanges({})) << "no range: nothing to do";
}

TEST_F(SkinningJobValidate, RefusesBadPreparedJobs) {
  PreparedInfluences prepared;
  ASSERT_TRUE(prepared.Build(m.vertex_count, m.offsets, m.binds, m.weights));
  EXPECT_EQ(prepared.required_matrix_count(), m.matrices.size());
  SkinningJob j = Good();
  j.prepared = &prepared;
  ExpectRefused(j, "prepared and CSR at once");
  j.influence_offsets = {};
  j.influence_binds = {};
  j.influence_weights = {};
  EXPECT_TRUE(j.Validate());
  SkinningJob k = j;
  k.joint_matrices = std::span<const skinspheres::Mat4f>(m.matrices).first(m.matrices.size() - 1);
  ExpectRefused(k, "prepared needs more matrices");
  k = j;
  k.vertex_count = m.vertex_count - 1;
  ExpectRefused(k, "prepared reads past vertex_count");
  std::vector<uint32_t> subset = {1};
  k = j;
  k.subset = subset;
  ExpectRefused(k, "subset with prepared");
}

}  // namespace
}  // namespace skinspheres::skinning
