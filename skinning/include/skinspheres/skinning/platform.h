// The one place that turns the compiler's own macros into skinspheres' platform switches, and the
// CPU-feature query behind every run-time choice of instruction set. No other file tests
// __x86_64__, _M_X64, __aarch64__, __GNUC__ or _MSC_VER to pick a code path, but the switch that
// compiles a SIMD copy for its instruction set (skinning/src/simd/target_begin_*.inc, target_end.inc)
// and the CPU query itself (platform.cc).
//
//   SKINSPHERES_X86_64   x86-64 (GCC, Clang, MSVC): SSE2 is the floor, so the SSE2 kernels are the
//                        baseline; the AVX2 and AVX-512 copies are compiled beside them and picked at
//                        run time by CpuFeatures.
//   otherwise            every other target (aarch64, 32-bit x86, ...): the portable kernels, plain
//                        C++ over 4-float arrays that compute in the same order as the SIMD ones
//                        (same bits; the compiler vectorises them as it can).
//   SKINSPHERES_FORCE_INLINE, SKINSPHERES_PREFETCH(address), SKINSPHERES_PRINTF_FORMAT(f, a)
//                        (a printf-like member function: format argument f, first value a,
//                        counting `this` as 1): the compiler's own spelling, or nothing where it
//                        has none.
//
// Same answers on every platform (docs/PLATFORMS.md): every copy of a kernel evaluates the same
// float operations in the same order, no operation is fused (the build turns contraction off on
// every compiler: -ffp-contract=off, /fp:precise), and nothing in the per-frame path calls the
// platform's transcendental functions. The macros depend on the target only, never on -m flags,
// so a consumer's flags cannot change what a header declares.
#pragma once

#if defined(__x86_64__) || defined(_M_X64)
#define SKINSPHERES_X86_64 1
#endif

#if defined(_MSC_VER) && !defined(__clang__)
#define SKINSPHERES_FORCE_INLINE __forceinline
#else
#define SKINSPHERES_FORCE_INLINE inline __attribute__((always_inline))
#endif

#if defined(__GNUC__) || defined(__clang__)
#define SKINSPHERES_PREFETCH(address) __builtin_prefetch(address)
#elif defined(SKINSPHERES_X86_64)
#include <xmmintrin.h>
#define SKINSPHERES_PREFETCH(address) _mm_prefetch(reinterpret_cast<const char*>(address), _MM_HINT_T0)
#else
#define SKINSPHERES_PREFETCH(address) ((void)(address))
#endif

#if defined(__GNUC__) || defined(__clang__)
#define SKINSPHERES_PRINTF_FORMAT(format_index, first_arg) __attribute__((format(printf, format_index, first_arg)))
#else
#define SKINSPHERES_PRINTF_FORMAT(format_index, first_arg)
#endif

namespace skinspheres {

// What the CPU this process runs on can execute, with the operating system's support for the
// wider registers (XGETBV) taken into account. All false off x86-64.
struct CpuFeatures {
  bool avx2 = false;
  bool fma = false;
  bool bmi1 = false;
  bool popcnt = false;
  bool avx512f = false;
};

// Read once (thread-safe), then cached.
const CpuFeatures& HostCpu();

}  // namespace skinspheres
