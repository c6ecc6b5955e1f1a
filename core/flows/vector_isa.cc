// The process-wide KernelOptions and the instruction set the CPU offers (vector_isa.h).
#include "core/flows/vector_isa.h"

#include <algorithm>
#include <mutex>
#include <optional>

namespace meshsmooth::flows {

namespace {

std::mutex kernel_options_mutex;
KernelOptions kernel_options;

}  // namespace

void SetKernelOptions(const KernelOptions& options) {
  const std::lock_guard<std::mutex> lock(kernel_options_mutex);
  kernel_options = options;
}

KernelOptions GetKernelOptions() {
  const std::lock_guard<std::mutex> lock(kernel_options_mutex);
  return kernel_options;
}

VectorIsa BestVectorIsa() {
  VectorIsa best = VectorIsa::kSse2;
  if (__builtin_cpu_supports("avx2")) best = VectorIsa::kAvx2;
  if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512dq")) {
    best = VectorIsa::kAvx512;
  }
  if (const std::optional<VectorIsa> want = GetKernelOptions().isa) best = std::min(best, *want);
  return MESHSMOOTH_WIDE_LANES ? best : VectorIsa::kSse2;
}

}  // namespace meshsmooth::flows
