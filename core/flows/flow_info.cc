#include "core/flows/flow_info.h"

#include <limits>

#include "core/flows/flow.h"

namespace meshsmooth {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

ParameterInfo Step(const std::string& flow, double max, const std::string& what) {
  return {"step", what, DefaultStep(flow), 0.0, max, true, false, {}};
}

ParameterInfo Weights() {
  return {"weights", "umbrella operator: U0 uniform (eq. 3) or U1 inverse distance (eq. 4)", 0, 0, 0, false, false,
          {"UMBRELLA_WEIGHTS_UNIFORM", "UMBRELLA_WEIGHTS_INVERSE_DISTANCE"}};
}

}  // namespace

std::vector<FlowInfo> DescribeFlows() {
  const FlowParams d;
  std::vector<FlowInfo> flows;
  flows.push_back({"laplacian", "Laplacian smoothing: regularises the sampling but shrinks and flattens", "eqs. (2)-(4)",
                   {Step("laplacian", 1.0, "lambda, dimensionless"), Weights()}});
  flows.push_back({"taubin",
                   "Taubin lambda|mu smoothing: no shrinkage, but turns noise into low-frequency waves; one "
                   "iteration is a lambda pass and a mu pass",
                   "eq. (6)",
                   {Step("taubin", 1.0, "lambda, dimensionless"), Weights(),
                    {"taubin_mu", "mu (> lambda, <= 1); unset = from the pass band", 0.0, 0.0, 1.0, true, false, {}},
                    {"taubin_pass_band", "k_PB = 1/lambda - 1/mu, used when mu is unset", d.taubin_pass_band, 0.0,
                     kInf, true, true, {}}}});
  flows.push_back({"bilaplacian", "Bilaplacian flow P -= lambda U0^2(P): smooth, slight deformation", "Section 2 (sign: NOTES.md)",
                   {Step("bilaplacian", 0.5, "lambda, dimensionless")}});
  flows.push_back({"mcf", "Mean curvature flow with cotangent weights: smooths well, sampling gets irregular",
                   "eqs. (7)-(8)", {Step("mcf", 10.0, "lambda relative to the squared mean edge length")}});
  flows.push_back({"mcf_tangential",
                   "Mean curvature flow plus a tangential umbrella that evens out the sampling", "eq. (11)",
                   {Step("mcf_tangential", 10.0, "lambda relative to the squared mean edge length"),
                    {"tangential_weight", "C: the tangential part moves a vertex by step * C * U0_t (step * C <= 1)",
                     d.tangential_weight, 0.0, kInf, false, true, {}}}});
  flows.push_back({"median",
                   "The paper's flow: moves along the umbrella direction with normal speed equal to the mean "
                   "curvature; smooths like mcf and keeps the mesh regular",
                   "eqs. (12)-(13)",
                   {Step("median", 10.0, "lambda relative to the squared mean edge length"),
                    {"epsilon", "vertices with |cos(theta)| <= epsilon do not move", d.epsilon, 0.0, 1.0, true, true,
                     {}}}});
  return flows;
}

std::vector<ParameterInfo> CommonParameters(int max_iterations) {
  const FlowParams d;
  return {
      {"iterations", "number of iterations", static_cast<double>(d.iterations), 1, static_cast<double>(max_iterations),
       false, false, {}},
      {"adaptive.mode", "eq. (14): none, constant T, or T(P) = mean |H| over the 1-ring or the 1+2-rings", 0, 0, 0,
       false, false, {"ADAPTIVE_MODE_NONE", "ADAPTIVE_MODE_CONSTANT", "ADAPTIVE_MODE_RING1", "ADAPTIVE_MODE_RING2"}},
      {"adaptive.threshold",
       "T for the constant mode: a curvature for the curvature flows, a length relative to the mean edge for the "
       "umbrella flows",
       0.0, 0.0, kInf, false, true, {}},
      {"adaptive.recompute_every", "T(P) is recomputed every this many iterations",
       static_cast<double>(d.adaptive_recompute_every), 1, kInf, false, true, {}},
      {"boundary", "boundary vertices: fixed, or smoothed as polygonal curves", 0, 0, 0, false, false,
       {"BOUNDARY_MODE_FIXED", "BOUNDARY_MODE_CURVE"}},
      {"tolerance", "stop when an iteration's largest move is below tolerance x mean edge length (0 = off)", 0.0, 0.0,
       kInf, false, true, {}},
      {"output.quantization_bits", "0 = lossless float32 positions; 1..30 = quantized", 0, 0, 30, false, false, {}},
  };
}

}  // namespace meshsmooth
