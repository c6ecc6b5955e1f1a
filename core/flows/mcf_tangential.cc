// Mean curvature flow with a tangential Laplacian component, eq. (11):
//   P <- P + lambda { H n + C [U0 - (U0 . n) n] }
// The paper prints "(U0 . n) U0"; the projection onto the tangent plane is (U0 . n) n
// (NOTES.md). The normal speed smooths, the tangential umbrella evens out the sampling.
// Units: lambda = step * h^2 for H n; C is taken relative to 1/h^2 so that the tangential part
// moves a vertex by step * C * U0_t (dimensionless, like a Laplacian step; must be <= 1).
// n is the unit area-weighted normal of the one-ring. Defaults: step 0.1, C 5 (tangential
// step 0.5, as the Laplacian default).
#include "core/flows/kernel.h"

namespace meshsmooth::flows {
namespace {

class McfTangential final : public FlowKernel {
 public:
  explicit McfTangential(double c) : c_(c) {}
  bool curvature_units() const override { return true; }
  BlockStats Step(const StepContext& c, const Vec3* cur, Vec3* next, int32_t begin, int32_t end) const override {
    const double weight = c_ * c.inv_h2;
    return ApplyCurvatureStep(c, cur, next, begin, end, [&](const Curvature& k, int32_t) __attribute__((always_inline)) {
      const Vec3& u = k.u0;
      const double len2 = SquaredNorm(k.normal);
      if (!(len2 > 0.0)) return k.hn;
      // The tangential part U0 - (U0 . n) n with n = N / |N|, without the square root.
      return k.hn + (u - k.normal * (Dot(u, k.normal) / len2)) * weight;
    });
  }

 private:
  double c_;
};

}  // namespace

std::unique_ptr<FlowKernel> MakeMcfTangential(const FlowParams& p) {
  return std::make_unique<McfTangential>(p.tangential_weight);
}

}  // namespace meshsmooth::flows
