// Laplacian smoothing, eq. (2): P <- P + lambda U(P), with U0 (eq. 3, uniform weights) or U1
// (eq. 4, inverse-distance weights). U0 improves the sampling rate but shrinks and flattens the
// shape; U1 worsens the sampling rate (the paper's eq. (5) argument). lambda is dimensionless,
// (0, 1]; default 0.5.
#include "core/flows/flow_table.h"
#include "core/flows/step_loops.h"

namespace meshsmooth::flows {
namespace {

template <bool kInverseDistance>
class Laplacian final : public FlowKernel {
 public:
  BlockStats Step(const StepContext& c, const Vec3* cur, Vec3* next, int32_t begin, int32_t end) const override {
    return ApplyStep(c, cur, next, begin, end,
                     [&](int32_t v) { return kInverseDistance ? UmbrellaU1(c, cur, v) : UmbrellaU0(c, cur, v); });
  }
};

std::unique_ptr<FlowKernel> MakeLaplacian(const FlowParams& p, double /*step*/) {
  if (p.weights == UmbrellaWeights::kInverseDistance) return std::make_unique<Laplacian<true>>();
  return std::make_unique<Laplacian<false>>();
}

}  // namespace

FlowRow LaplacianRow() {
  return {FlowId::kLaplacian,
          "laplacian",
          FlowKind::kUmbrella,
          0.5,
          1.0,
          "Laplacian smoothing: regularises the sampling but shrinks and flattens",
          "eqs. (2)-(4)",
          {WeightsParameter()},
          {},
          nullptr,
          MakeLaplacian,
          PassReach::kConvex};
}

}  // namespace meshsmooth::flows
