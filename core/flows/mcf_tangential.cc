// Mean curvature flow with a tangential Laplacian component, eq. (11):
//   P <- P + lambda { H n + C [U0 - (U0 . n) n] }
// The paper prints "(U0 . n) U0"; the projection onto the tangent plane is (U0 . n) n
// (docs/paper.md). The normal speed smooths, the tangential umbrella evens out the sampling.
// Units: lambda = step * h^2 for H n; C is taken relative to 1/h^2 so that the tangential part
// moves a vertex by step * C * U0_t (dimensionless, like a Laplacian step; must be <= 1).
// n is the unit area-weighted normal of the one-ring. Defaults: step 0.1, C 5 (tangential
// step 0.5, as the Laplacian default).
#include <limits>

#include "absl/strings/str_format.h"
#include "core/flows/flow_table.h"
#include "core/flows/step_loops.h"

namespace meshsmooth::flows {
namespace {

class McfTangential final : public FlowKernel {
 public:
  explicit McfTangential(double c) : c_(c) {}
  BlockStats Step(const StepContext& c, const Vec3* cur, Vec3* next, int32_t begin, int32_t end) const override {
    const double weight = c_ * c.inv_h2;
    return ApplyCurvatureStep(
        c, cur, next, begin, end, [&](const auto& k) __attribute__((always_inline)) {
          using V = decltype(k.hn.x);
          const LaneVec3<V>&u = k.u0, &n = k.normal, &hn = k.hn;
          // The tangential part U0 - (U0 . n) n with n = N / |N|, without the square root; none
          // where N is zero. (Selects only of the form `m ? x : 0` with x computed: GCC 12 rewrites
          // `m ? b + c : b` or `m ? constant : 0` into an & with a 512-bit mask, which it lowers
          // to a branch per lane.)
          const V zero{}, len2 = n.x * n.x + n.y * n.y + n.z * n.z;
          const auto has_normal = zero < len2;
          const V t = has_normal ? (u.x * n.x + u.y * n.y + u.z * n.z) / len2 : zero;
          const V tx = has_normal ? u.x - n.x * t : zero, ty = has_normal ? u.y - n.y * t : zero,
                  tz = has_normal ? u.z - n.z * t : zero;
          return LaneVec3<V>{hn.x + tx * weight, hn.y + ty * weight, hn.z + tz * weight};
        });
  }

 private:
  double c_;
};

absl::Status ValidateMcfTangential(const FlowParams& p, double step) {
  if (!(p.tangential_weight >= 0.0) || !(step * p.tangential_weight <= 1.0)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "mcf_tangential needs C >= 0 and step * C <= 1 (the tangential umbrella step), got C %g, step %g",
        p.tangential_weight, step));
  }
  return absl::OkStatus();
}

std::unique_ptr<FlowKernel> MakeMcfTangential(const FlowParams& p, double) {
  return std::make_unique<McfTangential>(p.tangential_weight);
}

}  // namespace

FlowRow McfTangentialRow() {
  const FlowParams d;
  return {FlowId::kMcfTangential,
          "mcf_tangential",
          FlowKind::kCurvature,
          0.1,
          10.0,
          "Mean curvature flow plus a tangential umbrella that evens out the sampling",
          "eq. (11)",
          {{"tangential_weight",
            "C: the tangential part moves a vertex by step * C * U0_t (step * C <= 1)",
            d.tangential_weight,
            0.0,
            std::numeric_limits<double>::infinity(),
            false,
            true,
            {}}},
          {"step * tangential_weight <= 1"},
          ValidateMcfTangential,
          MakeMcfTangential,
          PassReach::kMeanEdge};
}

}  // namespace meshsmooth::flows
