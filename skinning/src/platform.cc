// HostCpu (platform.h): CPUID and XGETBV on x86-64, through the compiler's own intrinsics (GCC and
// Clang: <cpuid.h>; MSVC: <intrin.h>); nothing elsewhere.
#include "skinspheres/skinning/platform.h"

#include <cstdint>

#if defined(SKINSPHERES_X86_64)
#if defined(_MSC_VER) && !defined(__clang__)
#include <intrin.h>
#else
#include <cpuid.h>
#endif
#endif

namespace skinspheres {
namespace {

#if defined(SKINSPHERES_X86_64)
struct CpuidRegisters {
  uint32_t eax = 0, ebx = 0, ecx = 0, edx = 0;
};

CpuidRegisters Cpuid(uint32_t leaf, uint32_t subleaf) {
  CpuidRegisters r;
#if defined(_MSC_VER) && !defined(__clang__)
  int regs[4];
  __cpuidex(regs, static_cast<int>(leaf), static_cast<int>(subleaf));
  r.eax = static_cast<uint32_t>(regs[0]);
  r.ebx = static_cast<uint32_t>(regs[1]);
  r.ecx = static_cast<uint32_t>(regs[2]);
  r.edx = static_cast<uint32_t>(regs[3]);
#else
  __cpuid_count(leaf, subleaf, r.eax, r.ebx, r.ecx, r.edx);
#endif
  return r;
}

// XCR0: which register states the operating system saves on a context switch.
uint64_t ExtendedControlRegister0() {
#if defined(_MSC_VER) && !defined(__clang__)
  return _xgetbv(0);
#else
  uint32_t eax = 0, edx = 0;
  __asm__ volatile("xgetbv" : "=a"(eax), "=d"(edx) : "c"(0));
  return (uint64_t{edx} << 32) | eax;
#endif
}

CpuFeatures Detect() {
  CpuFeatures f;
  const uint32_t max_leaf = Cpuid(0, 0).eax;
  if (max_leaf < 1) return f;
  const CpuidRegisters l1 = Cpuid(1, 0);
  f.popcnt = (l1.ecx >> 23) & 1u;
  const bool osxsave = (l1.ecx >> 27) & 1u;
  const bool avx = (l1.ecx >> 28) & 1u;
  if (!osxsave || !avx || max_leaf < 7) return f;
  const uint64_t xcr0 = ExtendedControlRegister0();
  const bool ymm_state = (xcr0 & 0x6u) == 0x6u;    // SSE and AVX state
  const bool zmm_state = (xcr0 & 0xE6u) == 0xE6u;  // and the opmask and upper ZMM states
  const CpuidRegisters l7 = Cpuid(7, 0);
  f.bmi1 = (l7.ebx >> 3) & 1u;
  if (ymm_state) {
    f.avx2 = (l7.ebx >> 5) & 1u;
    f.fma = (l1.ecx >> 12) & 1u;
  }
  f.avx512f = zmm_state && f.avx2 && ((l7.ebx >> 16) & 1u);
  return f;
}
#else
CpuFeatures Detect() { return {}; }
#endif

}  // namespace

const CpuFeatures& HostCpu() {
  static const CpuFeatures features = Detect();
  return features;
}

}  // namespace skinspheres
