// Internal to core/flows: which build of the arithmetic-bound loops runs (RunWithIsa in
// core/flows/step_loops.h). Every build computes the same bits.
#pragma once

#include <cstdint>

namespace meshsmooth::flows {

// The instruction set the arithmetic-bound loops are compiled for (RunWithIsa).
enum class VectorIsa : uint8_t { kSse2, kAvx2, kAvx512 };

// The widest this CPU has, or a narrower one named by MESHSMOOTH_VECTOR_ISA (sse2, avx2; for
// tests and measurements).
VectorIsa BestVectorIsa();

}  // namespace meshsmooth::flows
