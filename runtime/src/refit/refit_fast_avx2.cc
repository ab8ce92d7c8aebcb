// The fast refit's loop (refit_fast.inc) compiled for AVX2 whatever the build's flags, picked at run
// time when the CPU has it (refit_internal.h). The same source and float operations as the SSE2 level,
// so the same bits; the VEX encoding (three operands, no register copies) makes it faster.
#include "refit/refit_internal.h"

#if defined(__x86_64__) || defined(__i386__)
// Every header refit_fast.inc needs, before the target pragma (standard templates stay baseline).
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <limits>
#include <type_traits>

#include <immintrin.h>

// GCC takes the target from the pragma; clang ignores it and needs the attribute on every function.
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx2"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx2")
#endif

namespace skinspheres::runtime::internal::avx2 {
constexpr RefitSimd kThisLevel = RefitSimd::kAvx2;
#include "refit/refit_fast.inc"
}  // namespace skinspheres::runtime::internal::avx2

#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif
#endif  // x86
