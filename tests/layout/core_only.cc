// A program that links meshsmooth::core and nothing of ours besides, as a library user's would:
// it must get the standard operator new and no re-exec (the process-wide plumbing is in
// meshsmooth::base). check_core_only.sh reads its symbols; run, it smooths a noisy icosphere.
#include <cstdio>

#include "core/flows/flow.h"
#include "core/shapes/added_noise.h"
#include "core/shapes/parametric.h"

int main() {
  meshsmooth::Mesh mesh = meshsmooth::Icosphere(3);
  meshsmooth::AddNormalNoise(mesh, 0.2, 1);
  meshsmooth::FlowParams params;
  params.iterations = 5;
  const auto result = meshsmooth::Smooth(mesh, params);
  if (!result.ok()) {
    std::fprintf(stderr, "%s\n", result.status().ToString().c_str());
    return 1;
  }
  std::printf("%d iterations\n", result->iterations_run);
  return result->iterations_run == 5 ? 0 : 1;
}
