// Bilaplacian flow: P <- P - lambda U0^2(P), U0^2(P) = (1/n) sum_i U0(Q_i) - U0(P).
// The paper prints "+ lambda U^2"; the stable sign (thin-plate gradient descent, Taubin with
// mu = lambda) is minus (docs/paper.md). Uses the plain umbrella U0 as the paper does. lambda is
// dimensionless, (0, 0.5] (U0^2 has eigenvalues up to 4); default 0.2.
#include "core/flows/flow_table.h"
#include "core/flows/step_loops.h"

namespace meshsmooth::flows {
namespace {

class Bilaplacian final : public FlowKernel {
 public:
  // U0 at every vertex with a ring (fixed ones too: their U0 enters their neighbours' U0^2).
  void Prepare(const StepContext& c, const Vec3* cur, int32_t n, int threads) override {
    u_.resize(n);
    ForBlocks(n, threads, [&](int32_t, int32_t begin, int32_t end) {
      for (int32_t v = begin; v < end; ++v) {
        PrefetchPositionsAhead(cur, v, n);
        u_[v] = c.offsets[v + 1] > c.offsets[v] ? UmbrellaU0(c, cur, v) : Vec3{};
      }
    });
  }
  BlockStats Step(const StepContext& c, const Vec3* cur, Vec3* next, int32_t begin, int32_t end) const override {
    const Vec3* u = u_.data();
    // The umbrella of the field U0 is U0^2.
    // (ApplyStep prefetches cur ahead; the neighbours read here are u's.)
    return ApplyStep(c, cur, next, begin, end, [&](int32_t v) {
      PrefetchPositionsAhead(u, v, c.num_vertices);
      return -UmbrellaU0(c, u, v);
    });
  }

  // U0 = D^-1 A - I (A the ring's adjacency, D the valences) is similar to a symmetric matrix
  // with eigenvalues in [-2, 0], so U0^2's are in [0, 4]; zeroing the fixed vertices' rows keeps
  // them real and in [0, 4] (its free block is a principal block of a matrix similar to a
  // symmetric one). The step I - lambda U0^2 then has its eigenvalues in [1 - 4 lambda, 1].
  std::optional<double> LinearStepFloor(double lambda) const override { return 1.0 - 4.0 * lambda; }

 private:
  std::vector<Vec3> u_;
};

std::unique_ptr<FlowKernel> MakeBilaplacian(const FlowParams&, double) { return std::make_unique<Bilaplacian>(); }

}  // namespace

FlowRow BilaplacianRow() {
  return {FlowId::kBilaplacian,
          "bilaplacian",
          FlowKind::kUmbrella,
          0.2,
          0.5,
          "Bilaplacian flow P -= lambda U0^2(P): smooth, slight deformation",
          "Section 2 (sign: docs/paper.md)",
          {},
          {},
          nullptr,
          MakeBilaplacian,
          PassReach::kExtent};
}

}  // namespace meshsmooth::flows
