// The paper's flow, eqs. (12)-(13): move each vertex along the median direction m = U0/|U0|
// so that its normal speed equals the mean curvature:
//   F = |H| m / cos(theta)             if cos(theta) >  epsilon
//   F = 2 H n - |H| m / cos(theta)     if cos(theta) < -epsilon   (saddles, Fig. 8b)
//   F = 0                              if |cos(theta)| <= epsilon
// with cos(theta) = m . Hn / |Hn|. Smooths like the mean curvature flow and keeps or improves
// the regularity. Where |Hn| or |U0| is (numerically) zero the vertex does not move that
// iteration (docs/paper.md). lambda = step * h^2; defaults step 0.1, epsilon 0.1.
#include "core/flows/flow_table.h"
#include "core/flows/step_loops.h"

namespace meshsmooth::flows {
namespace {

class Median final : public FlowKernel {
 public:
  explicit Median(double epsilon) : epsilon_(epsilon) {}
  BlockStats Step(const StepContext& c, const Vec3* cur, Vec3* next, int32_t begin, int32_t end) const override {
    const double eps2 = epsilon_ * epsilon_;
    const double tiny_h = 1e-12 / c.h, tiny_u = 1e-12 * c.h;
    const double tiny_h2 = tiny_h * tiny_h, tiny_u2 = tiny_u * tiny_u;
    return ApplyCurvatureStep(
        c, cur, next, begin, end, [&](const auto& k) __attribute__((always_inline)) {
          using V = decltype(k.hn.x);
          const LaneVec3<V>&u = k.u0, &hn = k.hn;
          const V zero{};
          const V hm2 = hn.x * hn.x + hn.y * hn.y + hn.z * hn.z, um2 = u.x * u.x + u.y * u.y + u.z * u.z;
          // Without square roots: d = U0 . Hn = |U0| |Hn| cos(theta), so |cos(theta)| > epsilon
          // is d^2 > epsilon^2 |U0|^2 |Hn|^2, and |H| m / cos(theta) = U0 |Hn|^2 / d.
          const V d = u.x * hn.x + u.y * hn.y + u.z * hn.z;
          const V scale = hm2 / d;
          const V ax = u.x * scale, ay = u.y * scale, az = u.z * scale;
          const auto convex = zero < d;
          LaneVec3<V> f{convex ? ax : hn.x * 2.0 - ax, convex ? ay : hn.y * 2.0 - ay, convex ? az : hn.z * 2.0 - az};
          // The vertex stays where |Hn| or |U0| is (numerically) zero or |cos(theta)| <= epsilon:
          // it moves where hm2 > tiny_h2, um2 > tiny_u2 and d^2 > eps2 um2 hm2, that is where the
          // least of the three differences is > 0 (a - b > 0 exactly when a > b in IEEE
          // arithmetic). One comparison, not an & of three: GCC 12 lowers an & of 512-bit masks
          // to one branch per lane.
          const V e1 = hm2 - tiny_h2, e2 = um2 - tiny_u2, e3 = d * d - eps2 * um2 * hm2;
          V least = e1 < e2 ? e1 : e2;
          least = e3 < least ? e3 : least;
          const auto moves = zero < least;
          return LaneVec3<V>{moves ? f.x : zero, moves ? f.y : zero, moves ? f.z : zero};
        });
  }

 private:
  double epsilon_;
};

std::unique_ptr<FlowKernel> MakeMedian(const FlowParams& p, double) { return std::make_unique<Median>(p.epsilon); }

}  // namespace

FlowRow MedianRow() {
  const FlowParams d;
  return {FlowId::kMedian,
          "median",
          FlowKind::kCurvature,
          0.1,
          10.0,
          "The paper's flow: moves along the umbrella direction with normal speed equal to the mean "
          "curvature; smooths like mcf and keeps the mesh regular",
          "eqs. (12)-(13)",
          {{"epsilon", "vertices with |cos(theta)| <= epsilon do not move", d.epsilon, 0.0, 1.0, true, true, {}}},
          {},
          nullptr,
          MakeMedian,
          PassReach::kMeanEdge};
}

}  // namespace meshsmooth::flows
