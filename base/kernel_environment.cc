#include "base/kernel_environment.h"

#include <cstdlib>
#include <string_view>

#include "core/flows/vector_isa.h"

namespace meshsmooth {
namespace {

// True when the variable `name` is set to "0".
bool Off(const char* name) {
  const char* value = std::getenv(name);
  return value != nullptr && std::string_view(value) == "0";
}

}  // namespace

void ApplyKernelEnvironment() {
  flows::KernelOptions options;
  if (const char* isa = std::getenv("MESHSMOOTH_VECTOR_ISA")) {
    const std::string_view want = isa;
    if (want == "sse2") options.isa = flows::VectorIsa::kSse2;
    if (want == "avx2") options.isa = flows::VectorIsa::kAvx2;
  }
  options.lane_batches = !Off("MESHSMOOTH_LANE_BATCHES");
  options.chebyshev = !Off("MESHSMOOTH_CHEBYSHEV");
  flows::SetKernelOptions(options);
}

}  // namespace meshsmooth
