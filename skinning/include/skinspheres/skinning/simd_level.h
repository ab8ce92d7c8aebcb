// SimdLevel: the instruction set a stage's kernels run at, one enum for every stage (skinning; the
// runtime's broad phase, fast refit and crowd batches, which name it runtime::SimdLevel).
// kAuto: the widest the CPU has (x86-64: AVX-512, AVX2, SSE2; elsewhere kPortable); kPortable:
// plain C++ over arrays of 4 floats, on every platform. A stage without a copy for a level runs its
// widest narrower one (skinning and a lone fast refit have no AVX-512 copy: AVX2). Every level, on
// every platform, gives the same results, bit for bit: the choice is a matter of speed only. The
// declarations do not depend on the consumer's compiler flags.
#pragma once

#include <cstdint>

namespace skinspheres::skinning {

enum class SimdLevel : uint8_t { kAuto, kSse2, kAvx2, kAvx512, kPortable };

// "auto", "sse2", "avx2", "avx512", "portable".
const char* ToString(SimdLevel level);

// Whether this CPU runs the level: kAuto and kPortable always; kSse2 on x86-64; kAvx2 with AVX2,
// BMI1 and POPCNT (what the AVX2 copies are compiled for); kAvx512 with AVX-512F besides. The one
// check every stage's dispatch makes.
bool SimdLevelSupported(SimdLevel level);

}  // namespace skinspheres::skinning
