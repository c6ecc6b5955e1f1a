// Internal to core/flows: which build of the arithmetic-bound loops runs (RunWithIsa in
// core/flows/step_loops.h). Every build computes the same bits.
#pragma once

#include <cstdint>

namespace meshsmooth::flows {

// The instruction set the arithmetic-bound loops are compiled for (RunWithIsa).
enum class VectorIsa : uint8_t { kSse2, kAvx2, kAvx512 };

// The AVX2 and AVX-512 builds rest on GCC: its builtins (__builtin_shuffle, the masked AVX-512
// ones, lanes.h and operators.h) and its rule that a builtin's instruction set is checked where
// it is inlined. clang, which compiles only the fuzz targets (fuzz/), builds the SSE2 baseline
// alone: BestVectorIsa() says kSse2 and RunWithIsa() runs it, with the same bits.
#if defined(__clang__)
#define MESHSMOOTH_WIDE_LANES 0
#else
#define MESHSMOOTH_WIDE_LANES 1
#endif

// The widest this CPU has, or a narrower one named by MESHSMOOTH_VECTOR_ISA (sse2, avx2; for
// tests and measurements).
VectorIsa BestVectorIsa();

}  // namespace meshsmooth::flows
