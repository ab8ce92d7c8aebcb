// SimdLevel: the instruction set a runtime stage's kernels run at (the broad phase, the fast refit,
// the crowd's batches). kAuto: the widest the CPU has (x86-64: AVX-512, AVX2, SSE2; elsewhere
// kPortable); kPortable: plain C++ over arrays of 4 floats, on every platform. Every level, on every
// platform, gives the same results, bit for bit: the choice is a matter of speed only.
#pragma once

#include <cstdint>

namespace skinspheres::runtime {

enum class SimdLevel : uint8_t { kAuto, kSse2, kAvx2, kAvx512, kPortable };

// "auto", "sse2", "avx2", "avx512", "portable".
const char* ToString(SimdLevel level);

// Whether this CPU runs the level: kAuto and kPortable always; kSse2 on x86-64; kAvx2 with AVX2,
// BMI1 and POPCNT (what the AVX2 copies are compiled for); kAvx512 with AVX-512F besides. The one
// check every stage's dispatch makes.
bool SimdLevelSupported(SimdLevel level);

}  // namespace skinspheres::runtime
