// Mean curvature flow, eqs. (7)-(8): P <- P + lambda H n, explicit Euler, cotangent weights
// recomputed every iteration. H n uses the mixed Voronoi area (Meyer et al. 2003) instead of
// the whole one-ring area of eq. (8), so H is the true mean curvature (1/r on a sphere of
// radius r; docs/paper.md) and a sphere follows r(t)^2 = r0^2 - 2t. Smooths well but makes the
// sampling more irregular. lambda = step * h^2; default step 0.1.
#include "core/flows/flow_table.h"
#include "core/flows/step_loops.h"

namespace meshsmooth::flows {
namespace {

class Mcf final : public FlowKernel {
 public:
  BlockStats Step(const StepContext& c, const Vec3* cur, Vec3* next, int32_t begin, int32_t end) const override {
    return ApplyCurvatureStep(
        c, cur, next, begin, end, [](const auto& k) __attribute__((always_inline)) { return k.hn; });
  }
};

std::unique_ptr<FlowKernel> MakeMcf(const FlowParams&, double) { return std::make_unique<Mcf>(); }

}  // namespace

FlowRow McfRow() {
  return {FlowId::kMcf,
          "mcf",
          FlowKind::kCurvature,
          0.1,
          10.0,
          "Mean curvature flow with cotangent weights: smooths well, sampling gets irregular",
          "eqs. (7)-(8)",
          {},
          {},
          nullptr,
          MakeMcf,
          PassReach::kMeanEdge};
}

}  // namespace meshsmooth::flows
