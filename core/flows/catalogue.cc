#include "core/flows/catalogue.h"

#include <limits>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "core/flows/flow.h"
#include "core/flows/flow_table.h"

namespace meshsmooth {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

ParameterInfo Step(const FlowRow& row) {
  return {
      "step",
      row.kind == FlowKind::kCurvature ? "lambda relative to the squared mean edge length" : "lambda, dimensionless",
      row.default_step,
      0.0,
      row.max_step,
      true,
      false,
      {}};
}

// The parameters of a flow with an implicit form (HasImplicitForm), after its own.
std::vector<ParameterInfo> IntegrationParameters() {
  const FlowParams d;
  return {
      {"integration",
       "explicit steps (the paper's), or implicit: one sparse solve per iteration, stable for any step in (0, 1e6], "
       "boundary fixed, no adaptive threshold",
       0,
       0,
       0,
       false,
       false,
       {"INTEGRATION_EXPLICIT", "INTEGRATION_IMPLICIT"}},
      {"theta",
       "implicit steps' weight of the new positions: 1 = backward Euler, 0.5 = Crank-Nicolson (second order)",
       d.theta,
       0.5,
       1.0,
       false,
       false,
       {}}};
}

}  // namespace

std::string_view FlowName(FlowId id) { return FlowOf(id).name; }

FlowKind KindOf(FlowId id) { return FlowOf(id).kind; }

double DefaultStep(FlowId id) { return FlowOf(id).default_step; }

absl::StatusOr<FlowId> ParseFlowName(std::string_view name) {
  for (const FlowRow& row : FlowTable()) {
    if (row.name == name) return row.id;
  }
  return absl::InvalidArgumentError(
      absl::StrCat("unknown flow '", std::string(name), "' (", absl::StrJoin(FlowNames(), ", "), ")"));
}

const std::vector<std::string>& FlowNames() {
  static const std::vector<std::string>* const kNames = [] {
    auto* names = new std::vector<std::string>;
    for (const FlowRow& row : FlowTable()) names->emplace_back(row.name);
    return names;
  }();
  return *kNames;
}

std::string ChoiceFlowNames() {
  std::vector<std::string> names;
  for (FlowId id : kChoiceFlows) names.emplace_back(FlowName(id));
  return absl::StrJoin(names, " and ");
}

std::vector<FlowInfo> DescribeFlows() {
  std::vector<FlowInfo> flows;
  for (const FlowRow& row : FlowTable()) {
    FlowInfo f{
        std::string(row.name), std::string(row.description), std::string(row.equations), {Step(row)}, row.constraints};
    f.parameters.insert(f.parameters.end(), row.parameters.begin(), row.parameters.end());
    if (HasImplicitForm(row.id)) {
      for (ParameterInfo& info : IntegrationParameters()) f.parameters.push_back(std::move(info));
      f.constraints.emplace_back("with integration IMPLICIT: step in (0, 1e6]");
    }
    flows.push_back(std::move(f));
  }
  return flows;
}

std::vector<ParameterInfo> CommonParameters(int max_iterations) {
  const FlowParams d;
  return {
      {"iterations",
       "number of iterations; 0 = automatic: estimate the input's noise and return the iteration whose estimated "
       "distance to the noise-free surface (SURE) is least (a clean mesh comes back unchanged, fine detail and all, "
       "and so does a mesh every run would leave rougher; closed meshes keep their volume); with no flow named and "
       "no step, " +
           ChoiceFlowNames() +
           " both run and the smaller "
           "estimated error wins",
       static_cast<double>(d.iterations),
       0,
       static_cast<double>(max_iterations),
       false,
       false,
       {}},
      {"adaptive.mode",
       "eq. (14): none, constant T, or T(P) = mean |H| over the 1-ring or the 1+2-rings",
       0,
       0,
       0,
       false,
       false,
       {"ADAPTIVE_MODE_NONE", "ADAPTIVE_MODE_CONSTANT", "ADAPTIVE_MODE_RING1", "ADAPTIVE_MODE_RING2"}},
      {"adaptive.threshold",
       "T for the constant mode: a curvature for the curvature flows, a length relative to the mean edge for the "
       "umbrella flows",
       0.0,
       0.0,
       kInf,
       false,
       true,
       {}},
      {"adaptive.recompute_every",
       "T(P) is recomputed every this many iterations",
       static_cast<double>(d.adaptive_recompute_every),
       1,
       kInf,
       false,
       true,
       {}},
      {"boundary",
       absl::StrCat("boundary vertices: fixed, or smoothed as polygonal curves; unset: the default job moves them "
                    "with bilateral_normal (towards their faces' planes) and keeps them with bilaplacian (but for "
                    "holes at most ",
                    kSmallHoleEdges, " edges around, whose vertices move as interior ones), any other job keeps them"),
       0,
       0,
       0,
       false,
       false,
       {"BOUNDARY_MODE_FIXED", "BOUNDARY_MODE_CURVE"}},
      {"tolerance",
       "stop when an iteration's largest move is below tolerance x mean edge length (0 = off)",
       0.0,
       0.0,
       kInf,
       false,
       true,
       {}},
      {"output.quantization_bits", "0 = lossless float32 positions; 1..24 = quantized", 0, 0, 24, false, false, {}},
      {"strength_attribute",
       "per-vertex strength: the name (metadata entry \"name\") of a one-component generic attribute of the "
       "upload, values in [0, 1]: 0 = the vertex does not move, 1 = the flow as it is, between = its moves scaled; "
       "the default job reads the noise on the vertices that may move and returns no more folded faces than it got; "
       "empty = 1 everywhere",
       1.0,
       0.0,
       1.0,
       false,
       false,
       {}},
      {"max_displacement",
       "a bound on displacement, mesh units: no vertex ends farther than this from its input position (each iteration "
       "puts a vertex leaving the ball around it back onto the ball; the default job returns no more folded faces "
       "than it got); the summary counts the vertices at the bound (0 = no bound)",
       0.0,
       0.0,
       kInf,
       false,
       true,
       {}},
      {"max_displacement_h",
       "the same bound in mean edge lengths of the input (0 = none; set at most one of the two)",
       0.0,
       0.0,
       kInf,
       false,
       true,
       {}},
  };
}

}  // namespace meshsmooth
