// Which build of the arithmetic-bound loops runs (RunWithIsa in core/flows/step_loops.h), and
// the other choices between ways of computing the same bits (KernelOptions). Every build and
// every choice computes the same bits.
#pragma once

#include <cstdint>
#include <optional>

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

// How the runs compute, for tests and measurements (the results are the same bytes; only the
// speed differs). Process-wide: a program sets it before its first job (the binaries from their
// environment, base/kernel_environment.h), a test around its runs.
struct KernelOptions {
  // At most this wide (never wider than the CPU); none: the widest the CPU has.
  std::optional<VectorIsa> isa;
  // False: the cotangent flows go vertex by vertex rather than in lane batches (lane_batches.h).
  bool lane_batches = true;
  // False: a count chosen beforehand runs iteration by iteration rather than as one polynomial
  // (chebyshev.h).
  bool chebyshev = true;
};
void SetKernelOptions(const KernelOptions& options);
KernelOptions GetKernelOptions();

// The widest this CPU has, or the narrower one KernelOptions::isa names.
VectorIsa BestVectorIsa();

}  // namespace meshsmooth::flows
