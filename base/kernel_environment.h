// The environment's say in how the runs compute (flows::KernelOptions, core/flows/vector_isa.h),
// for tests and measurements: the results are the same bytes, only the speed differs.
//   MESHSMOOTH_VECTOR_ISA=sse2 (or avx2)  the cotangent and normal-filter loops' x86-64 baseline
//                                         (or AVX2) build instead of the widest the CPU has;
//   MESHSMOOTH_LANE_BATCHES=0             the cotangent flows vertex by vertex, not in batches;
//   MESHSMOOTH_CHEBYSHEV=0                a count chosen beforehand iteration by iteration.
// The binaries call it in main(), before their first job.
#pragma once

namespace meshsmooth {

void ApplyKernelEnvironment();

}  // namespace meshsmooth
