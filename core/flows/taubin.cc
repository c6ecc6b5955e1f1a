// Taubin's lambda|mu smoothing, eq. (6): P <- (1 - mu U)(1 + lambda U) P with mu > lambda > 0.
// Implemented as the standard two passes over the whole mesh: one iteration is a lambda pass
// (P += lambda U(P)) followed by a mu pass (P -= mu U(P)), each a Jacobi update; the combined
// rule (6) is the same thing (docs/paper.md). mu is given, or derived from the pass band
// k_PB = 1/lambda - 1/mu (paper's example: lambda = 0.3, k_PB = 0.1 -> mu = 0.3093).
// U is U0 or U1. Defaults: lambda = 0.5, k_PB = 0.1 (mu = 0.5263).
#include <limits>

#include "absl/strings/str_format.h"
#include "core/flows/flow_table.h"
#include "core/flows/step_loops.h"

namespace meshsmooth::flows {
namespace {

template <bool kInverseDistance>
class Taubin final : public FlowKernel {
 public:
  Taubin(double lambda, double mu) : mu_(mu), mu_over_lambda_(mu / lambda) {}
  int passes() const override { return 2; }
  double mu() const override { return mu_; }
  double pass_factor(int pass) const override { return pass == 0 ? 1.0 : -mu_over_lambda_; }
  BlockStats Step(const StepContext& c, const Vec3* cur, Vec3* next, int32_t begin, int32_t end) const override {
    return ApplyStep(c, cur, next, begin, end,
                     [&](int32_t v) { return kInverseDistance ? UmbrellaU1(c, cur, v) : UmbrellaU0(c, cur, v); });
  }

 private:
  double mu_, mu_over_lambda_;
};

// mu as given, or from the pass band k_PB = 1/lambda - 1/mu.
double TaubinMu(const FlowParams& p, double lambda) {
  return p.taubin_mu > 0.0 ? p.taubin_mu : 1.0 / (1.0 / lambda - p.taubin_pass_band);
}

absl::Status ValidateTaubin(const FlowParams& p, double step) {
  if (p.taubin_mu > 0.0) {
    if (!(p.taubin_mu > step) || !(p.taubin_mu <= 1.0)) {
      return absl::InvalidArgumentError(
          absl::StrFormat("taubin needs mu > lambda and mu <= 1 (lambda %g, mu %g)", step, p.taubin_mu));
    }
  } else if (!(p.taubin_pass_band > 0.0) || !(p.taubin_pass_band < 1.0 / step - 1.0)) {
    return absl::InvalidArgumentError(
        absl::StrFormat("taubin pass band k_PB must be in (0, 1/lambda - 1) = (0, %g) so that lambda < mu <= 1, got %g",
                        1.0 / step - 1.0, p.taubin_pass_band));
  }
  return absl::OkStatus();
}

std::unique_ptr<FlowKernel> MakeTaubin(const FlowParams& p, double step) {
  const double lambda = step, mu = TaubinMu(p, step);
  if (p.weights == UmbrellaWeights::kInverseDistance) return std::make_unique<Taubin<true>>(lambda, mu);
  return std::make_unique<Taubin<false>>(lambda, mu);
}

}  // namespace

FlowRow TaubinRow() {
  const FlowParams d;
  return {FlowId::kTaubin,
          "taubin",
          FlowKind::kUmbrella,
          0.5,
          1.0,
          "Taubin lambda|mu smoothing: no shrinkage, but turns noise into low-frequency waves; one "
          "iteration is a lambda pass and a mu pass",
          "eq. (6)",
          {WeightsParameter(),
           {"taubin_mu", "mu (> lambda, <= 1); unset = from the pass band", 0.0, 0.0, 1.0, true, false, {}},
           {"taubin_pass_band",
            "k_PB = 1/lambda - 1/mu, used when mu is unset",
            d.taubin_pass_band,
            0.0,
            std::numeric_limits<double>::infinity(),
            true,
            true,
            {}}},
          {"taubin_mu set: step < taubin_mu <= 1",
           "taubin_mu unset: 0 < taubin_pass_band < 1/step - 1 (so step < 1 / (1 + taubin_pass_band))"},
          ValidateTaubin,
          MakeTaubin,
          PassReach::kExtent};
}

}  // namespace meshsmooth::flows
