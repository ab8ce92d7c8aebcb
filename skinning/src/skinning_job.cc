
#include "skinspheres/skinning/skinning_job.h"

#include <Eigen/Core>
#include <algorithm>
#include <limits>

#include "skinning_kernels.h"
#include "skinspheres/skinning/platform.h"

namespace skinspheres::skinning {
namespace {

static_assert(sizeof(Mat4f) == 64 && alignof(Mat4f) <= 16,
              "kernels read Matrix4f as 16 column-major floats; Eigen's ABI must match the users'");

// Floats a buffer of vertex_count vertices with this byte stride must hold; SIZE_MAX on overflow.
size_t RequiredFloats(size_t vertex_count, size_t stride_bytes) {
  if (vertex_count == 0) return 0;
  const size_t step = stride_bytes / sizeof(float);
  if (vertex_count - 1 > (std::numeric_limits<size_t>::max() - 3) / step) return std::numeric_limits<size_t>::max();
  return (vertex_count - 1) * step + 3;
}

bool StrideOk(size_t stride_bytes) { return stride_bytes >= 3 * sizeof(float) && stride_bytes % sizeof(float) == 0; }

// Everything checkable in O(1).
bool ValidateShape(const SkinningJob& job) {
  if (!SimdLevelSupported(job.simd)) return false;
  if (job.vertex_count == 0 || job.vertex_count > std::numeric_limits<uint32_t>::max()) return false;
  if (job.joint_matrices.data() == nullptr || job.joint_matrices.empty()) return false;
  if (!StrideOk(job.in_stride_bytes) || !StrideOk(job.out_stride_bytes)) return false;
  if (job.in_positions.data() == nullptr || job.out_positions.data() == nullptr) return false;
  if (job.in_positions.size() < RequiredFloats(job.vertex_count, job.in_stride_bytes)) return false;
  if (job.out_positions.size() < RequiredFloats(job.vertex_count, job.out_stride_bytes)) return false;
  if (job.prepared != nullptr) {
    if (!job.influence_offsets.empty() || !job.influence_binds.empty() || !job.influence_weights.empty() ||
        !job.subset.empty()) {
      return false;  // ambiguous: prepared and CSR influences at once
    }
    return job.prepared->required_vertex_count() <= job.vertex_count &&
           job.prepared->required_matrix_count() <= job.joint_matrices.size();
  }
  if (job.influence_offsets.size() < job.vertex_count + 1) return false;
  if (job.influence_offsets.data() == nullptr) return false;
  return true;
}

// What items [begin, end) of a CSR job read: offsets ordered and inside the arrays, bind indices
// inside joint_matrices, subset entries inside the buffers.
bool ValidateCsrRange(const SkinningJob& job, size_t begin, size_t end) {
  const auto& offsets = job.influence_offsets;
  const size_t pairs = std::min(job.influence_binds.size(), job.influence_weights.size());
  const size_t matrices = job.joint_matrices.size();
  auto binds_ok = [&](uint32_t first, uint32_t last) {
    uint32_t max_bind = 0;
    for (uint32_t k = first; k < last; ++k) max_bind = std::max<uint32_t>(max_bind, job.influence_binds[k]);
    return first == last || max_bind < matrices;
  };
  if (job.subset.empty()) {
    if (begin == end) return true;
    for (size_t v = begin; v < end; ++v) {
      if (offsets[v + 1] < offsets[v]) return false;
    }
    if (offsets[end] > pairs) return false;
    return binds_ok(offsets[begin], offsets[end]);
  }
  for (size_t i = begin; i < end; ++i) {
    const size_t v = job.subset[i];
    if (v >= job.vertex_count) return false;
    const uint32_t first = offsets[v], last = offsets[v + 1];
    if (last < first || last > pairs || !binds_ok(first, last)) return false;
  }
  return true;
}

kernels::Buffers MakeBuffers(const SkinningJob& job) {
  kernels::Buffers b;
  b.matrices = job.joint_matrices.data()->data();
  b.in = reinterpret_cast<const char*>(job.in_positions.data());
  b.in_stride = job.in_stride_bytes;
  b.out = reinterpret_cast<char*>(job.out_positions.data());
  b.out_stride = job.out_stride_bytes;
  return b;
}

// Runs a validated job's items [begin, end).
void RunUnchecked(const SkinningJob& job, size_t begin, size_t end) {
  const kernels::Buffers b = MakeBuffers(job);
  const SimdLevel level = ResolveSimdLevel(job.simd);
  if (job.prepared != nullptr) {
    switch (level) {
#if defined(SKINSPHERES_X86_64)
      case SimdLevel::kAvx2: kernels::avx2::RunPrepared(b, *job.prepared, begin, end); return;
      case SimdLevel::kSse2: kernels::sse2::RunPrepared(b, *job.prepared, begin, end); return;
#endif
      default: kernels::scalar::RunPrepared(b, *job.prepared, begin, end); return;
    }
  }
  kernels::Csr csr;
  csr.offsets = job.influence_offsets.data();
  csr.binds = job.influence_binds.data();
  csr.weights = job.influence_weights.data();
  csr.subset = job.subset.empty() ? nullptr : job.subset.data();
  switch (level) {
#if defined(SKINSPHERES_X86_64)
    case SimdLevel::kAvx2: kernels::avx2::RunCsr(b, csr, begin, end); return;
    case SimdLevel::kSse2: kernels::sse2::RunCsr(b, csr, begin, end); return;
#endif
    default: kernels::scalar::RunCsr(b, csr, begin, end); return;
  }
}

}  // namespace

SimdLevel ResolveSimdLevel(SimdLevel level) {
#if defined(SKINSPHERES_X86_64)
  switch (level) {
    case SimdLevel::kAuto: return SimdLevelSupported(SimdLevel::kAvx2) ? SimdLevel::kAvx2 : SimdLevel::kSse2;
    case SimdLevel::kAvx512: return SimdLevel::kAvx2;  // no AVX-512 copy: the AVX2 one (same bits)
    default: return level;
  }
#else
  return level == SimdLevel::kAuto ? SimdLevel::kPortable : level;
#endif
}

size_t SkinningJob::WorkSize() const {
  if (prepared != nullptr) return prepared->size();
  return subset.empty() ? vertex_count : subset.size();
}

bool SkinningJob::Validate() const {
  if (!ValidateShape(*this)) return false;
  return prepared != nullptr || ValidateCsrRange(*this, 0, WorkSize());
}

bool SkinningJob::Run() const { return RunRange(0, WorkSize()); }

bool SkinningJob::RunRange(size_t begin, size_t end) const {
  if (!ValidateShape(*this) || begin > end || end > WorkSize()) return false;
  if (prepared == nullptr && !ValidateCsrRange(*this, begin, end)) return false;
  RunUnchecked(*this, begin, end);
  return true;
}

bool SkinningJob::RunRanges(std::span<const std::pair<uint32_t, uint32_t>> ranges) const {
  if (!ValidateShape(*this)) return false;
  const size_t work = WorkSize();
  for (const auto& [begin, end] : ranges) {
    if (begin > end || end > work) return false;
    if (prepared == nullptr && !ValidateCsrRange(*this, begin, end)) return false;
  }
  for (const auto& [begin, end] : ranges) RunUnchecked(*this, begin, end);
  return true;
}

bool SkinningJob::RunParallel(const ParallelFor& parallel_for, size_t grain) const {
  if (!Validate()) return false;
  parallel_for(WorkSize(), std::max<size_t>(grain, 1),
               [this](size_t begin, size_t end) { RunUnchecked(*this, begin, end); });
  return true;
}

bool SkinReference(const SkinningJob& job) {
  if (job.prepared != nullptr || !job.Validate()) return false;
  const char* in = reinterpret_cast<const char*>(job.in_positions.data());
  char* out = reinterpret_cast<char*>(job.out_positions.data());
  const size_t items = job.WorkSize();
  for (size_t i = 0; i < items; ++i) {
    const size_t v = job.subset.empty() ? i : job.subset[i];
    const float* p = reinterpret_cast<const float*>(in + v * job.in_stride_bytes);
    const Vec4f p_bind(p[0], p[1], p[2], 1.0f);
    Vec4f acc = Vec4f::Zero();
    for (uint32_t k = job.influence_offsets[v]; k < job.influence_offsets[v + 1]; ++k) {
      acc += job.influence_weights[k] * (job.joint_matrices[job.influence_binds[k]] * p_bind);
    }
    float* q = reinterpret_cast<float*>(out + v * job.out_stride_bytes);
    q[0] = acc.x();
    q[1] = acc.y();
    q[2] = acc.z();
  }
  return true;
}

}  // namespace skinspheres::skinning
