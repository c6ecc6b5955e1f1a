// The paper's flow, eqs. (12)-(13): move each vertex along the median direction m = U0/|U0|
// so that its normal speed equals the mean curvature:
//   F = |H| m / cos(theta)             if cos(theta) >  epsilon
//   F = 2 H n - |H| m / cos(theta)     if cos(theta) < -epsilon   (saddles, Fig. 8b)
//   F = 0                              if |cos(theta)| <= epsilon
// with cos(theta) = m . Hn / |Hn|. Smooths like the mean curvature flow and keeps or improves
// the regularity. Where |Hn| or |U0| is (numerically) zero the vertex does not move that
// iteration (NOTES.md). lambda = step * h^2; defaults step 0.1, epsilon 0.1.
#include "core/flows/kernel.h"

namespace meshsmooth::flows {
namespace {

class Median final : public FlowKernel {
 public:
  explicit Median(double epsilon) : epsilon_(epsilon) {}
  bool curvature_units() const override { return true; }
  BlockStats Step(const StepContext& c, const Vec3* cur, Vec3* next, int32_t begin, int32_t end) const override {
    const double eps2 = epsilon_ * epsilon_;
    const double tiny_h = 1e-12 / c.h, tiny_u = 1e-12 * c.h;
    const double tiny_h2 = tiny_h * tiny_h, tiny_u2 = tiny_u * tiny_u;
    return ApplyCurvatureStep(c, cur, next, begin, end, [&](const Curvature& k, int32_t) __attribute__((always_inline)) {
      const Vec3 hn = k.hn, u = k.u0;
      const double hm2 = SquaredNorm(hn), um2 = SquaredNorm(u);
      if (!(hm2 > tiny_h2) || !(um2 > tiny_u2)) return Vec3{};
      // Without square roots: d = U0 . Hn = |U0| |Hn| cos(theta), so |cos(theta)| > epsilon
      // is d^2 > epsilon^2 |U0|^2 |Hn|^2, and |H| m / cos(theta) = U0 |Hn|^2 / d.
      const double d = Dot(u, hn);
      if (!(d * d > eps2 * um2 * hm2)) return Vec3{};
      const Vec3 along = u * (hm2 / d);
      return d > 0.0 ? along : hn * 2.0 - along;
    });
  }

 private:
  double epsilon_;
};

}  // namespace

std::unique_ptr<FlowKernel> MakeMedian(const FlowParams& p) { return std::make_unique<Median>(p.epsilon); }

}  // namespace meshsmooth::flows
