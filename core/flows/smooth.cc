// What every run shares: the names of stop reasons and phases, the parameters' checks, and one
// flow's run in the vertex order that pays (core/flows/reorder.h), handed to the driver
// (core/flows/driver.h). The front door, Smooth(), is the default job's (core/job/default_job.cc).
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/flows/driver.h"
#include "core/flows/flow.h"
#include "core/flows/flow_table.h"
#include "core/flows/operators.h"
#include "core/flows/reorder.h"

namespace meshsmooth {
namespace {

// What an automatic run typically takes on a noisy scan (docs/quality.md), for the choice of
// the order it runs in.
constexpr int kTypicalAutoIterations = 20;

// FlowParams::integration, theta and implicit_solver for the flow of `row`.
absl::Status ValidateIntegration(const FlowParams& p, const FlowRow& row) {
  if (p.integration != Integration::kExplicit && p.integration != Integration::kImplicit) {
    return absl::InvalidArgumentError(absl::StrCat("unknown integration ", static_cast<int>(p.integration)));
  }
  if (p.integration == Integration::kExplicit) return absl::OkStatus();
  if (!p.flow.has_value() && p.iterations == kAutoIterations && !p.step.has_value()) {
    return absl::InvalidArgumentError(
        "implicit integration needs a flow (laplacian, bilaplacian or mcf), an iteration count or a step: a job "
        "that names none chooses its flow among explicit candidates");
  }
  if (!HasImplicitForm(row.id)) {
    return absl::InvalidArgumentError(absl::StrCat("flow ", std::string(row.name),
                                                   " has no implicit form; implicit integration is for laplacian "
                                                   "(U0 or U1), bilaplacian and mcf"));
  }
  if (!(p.theta >= 0.5 && p.theta <= 1.0)) {
    return absl::InvalidArgumentError(
        absl::StrFormat("theta must be in [0.5, 1] (1 = backward Euler, 0.5 = Crank-Nicolson), got %g", p.theta));
  }
  if (p.adaptive != AdaptiveMode::kNone) {
    return absl::InvalidArgumentError("implicit integration takes no adaptive threshold (eq. (14) is explicit)");
  }
  if (p.boundary == BoundaryMode::kCurve) {
    return absl::InvalidArgumentError("implicit integration keeps the boundary fixed; boundary curve is explicit only");
  }
  if (!(p.cg_tolerance > 0.0 && p.cg_tolerance <= 0.1)) {
    return absl::InvalidArgumentError(
        absl::StrFormat("the implicit solve's CG tolerance must be in (0, 0.1], got %g", p.cg_tolerance));
  }
  if (p.implicit_solver != ImplicitSolver::kAuto && p.implicit_solver != ImplicitSolver::kDirect &&
      p.implicit_solver != ImplicitSolver::kCg) {
    return absl::InvalidArgumentError(absl::StrCat("unknown implicit solver ", static_cast<int>(p.implicit_solver)));
  }
  return absl::OkStatus();
}

}  // namespace

std::string_view StopReasonName(StopReason reason) {
  switch (reason) {
    case StopReason::kIterations:
      return "iterations";
    case StopReason::kTolerance:
      return "tolerance";
    case StopReason::kTimeBudget:
      return "time_budget";
    case StopReason::kNoiseRemoved:
      return "noise_removed";
    case StopReason::kNoNoise:
      return "no_noise";
    case StopReason::kConverged:
      return "converged";
    case StopReason::kNoEstimate:
      return "no_estimate";
    case StopReason::kNoGain:
      return "no_gain";
  }
  return "iterations";
}

std::string_view PhaseName(Phase phase) {
  switch (phase) {
    case Phase::kSmoothing:
      return "smoothing";
    case Phase::kNoiseEstimate:
      return "noise estimate";
    case Phase::kChoosing:
      return "choosing the flow";
    case Phase::kWriting:
      return "writing";
    case Phase::kEnhancing:
      return "enhancing";
  }
  return "smoothing";
}

absl::Status ValidateStrength(const std::vector<float>& strength, int32_t num_vertices) {
  if (strength.empty()) return absl::OkStatus();
  if (strength.size() != static_cast<size_t>(num_vertices)) {
    return absl::InvalidArgumentError(
        absl::StrCat("the strength has ", strength.size(), " values for ", num_vertices, " vertices"));
  }
  for (size_t v = 0; v < strength.size(); ++v) {
    // Written so that NaN fails too.
    if (!(strength[v] >= 0.0f && strength[v] <= 1.0f)) {
      return absl::InvalidArgumentError(
          absl::StrFormat("the strength of vertex %d is %g; strengths are in [0, 1]", v, strength[v]));
    }
  }
  return absl::OkStatus();
}

absl::Status ValidateFlowParams(const FlowParams& p, int32_t num_vertices) {
  // The cotangent kernel addresses coordinates as int32 3 * vertex (operators.h, MeanCurvatureLanes).
  if (num_vertices > std::numeric_limits<int32_t>::max() / 3) {
    return absl::InvalidArgumentError(absl::StrCat("the mesh has ", num_vertices, " vertices; at most ",
                                                   std::numeric_limits<int32_t>::max() / 3, " can be smoothed"));
  }
  const FlowId flow = p.flow.value_or(kDefaultFlow);
  if (static_cast<size_t>(flow) >= FlowTable().size()) {
    return absl::InvalidArgumentError(absl::StrCat("unknown flow id ", static_cast<int>(flow)));
  }
  const FlowRow& row = FlowOf(flow);
  if (p.iterations < kAutoIterations || p.iterations > kMaxIterations) {
    return absl::InvalidArgumentError(absl::StrCat("iterations must be in 1..", kMaxIterations, " or ", kAutoIterations,
                                                   " (automatic), got ", p.iterations));
  }
  if (p.max_auto_iterations < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("the automatic iteration limit must be >= 1, got ", p.max_auto_iterations));
  }
  if (absl::Status s = ValidateIntegration(p, row); !s.ok()) return s;
  const bool implicit = p.integration == Integration::kImplicit;
  const double step = p.step.value_or(row.default_step);
  const double max_step = implicit ? kMaxImplicitStep : row.max_step;
  if (!(step > 0.0) || !(step <= max_step)) {
    return absl::InvalidArgumentError(
        absl::StrFormat("step must be in (0, %g] for %s%s, got %g%s", max_step, implicit ? "implicit " : "", row.name,
                        step, row.kind == FlowKind::kCurvature ? " (relative to the squared mean edge length)" : ""));
  }
  if (row.validate != nullptr) {
    if (absl::Status s = row.validate(p, step); !s.ok()) return s;
  }
  if (!std::isfinite(p.taubin_mu) || p.taubin_mu < 0.0) {
    return absl::InvalidArgumentError(
        absl::StrFormat("taubin mu must be >= 0 (0 = from the pass band), got %g", p.taubin_mu));
  }
  if (!(p.epsilon > 0.0) || !(p.epsilon < 1.0)) {
    return absl::InvalidArgumentError(absl::StrFormat("epsilon must be in (0, 1), got %g", p.epsilon));
  }
  if (p.adaptive == AdaptiveMode::kConstant &&
      (!(p.adaptive_threshold >= 0.0) || !std::isfinite(p.adaptive_threshold))) {
    return absl::InvalidArgumentError(
        absl::StrFormat("the adaptive threshold T must be finite and >= 0, got %g", p.adaptive_threshold));
  }
  if (p.adaptive_recompute_every < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("the adaptive recompute interval must be >= 1, got ", p.adaptive_recompute_every));
  }
  if (!(p.tolerance >= 0.0) || !std::isfinite(p.tolerance)) {
    return absl::InvalidArgumentError(absl::StrFormat("tolerance must be finite and >= 0, got %g", p.tolerance));
  }
  if (!p.locked.empty() && p.locked.size() != static_cast<size_t>(num_vertices)) {
    return absl::InvalidArgumentError(
        absl::StrCat("the lock mask has ", p.locked.size(), " entries for ", num_vertices, " vertices"));
  }
  if (absl::Status s = ValidateStrength(p.strength, num_vertices); !s.ok()) return s;
  for (const auto& [name, bound] :
       {std::pair{"max_displacement", p.max_displacement}, std::pair{"max_displacement_h", p.max_displacement_h}}) {
    if (!(bound >= 0.0) || !std::isfinite(bound)) {
      return absl::InvalidArgumentError(
          absl::StrFormat("%s must be finite and >= 0 (0 = no bound), got %g", name, bound));
    }
  }
  if (p.max_displacement > 0.0 && p.max_displacement_h > 0.0) {
    return absl::InvalidArgumentError(
        absl::StrFormat("max_displacement (%g) and max_displacement_h (%g) are both set; give the bound one way",
                        p.max_displacement, p.max_displacement_h));
  }
  if (!p.bound_centre.empty() && p.bound_centre.size() != static_cast<size_t>(num_vertices)) {
    return absl::InvalidArgumentError(
        absl::StrCat("the bound's centres are ", p.bound_centre.size(), " positions for ", num_vertices, " vertices"));
  }
  if (p.threads < 0) return absl::InvalidArgumentError(absl::StrCat("threads must be >= 0, got ", p.threads));
  return absl::OkStatus();
}

double DisplacementBound(const FlowParams& p, double h) {
  return p.max_displacement > 0.0 ? p.max_displacement : p.max_displacement_h * h;
}

namespace flows {

absl::StatusOr<FlowResult> SmoothOneFlow(Mesh& mesh, Topology& topo, const FlowParams& p, const RunControl& control,
                                         double h, const RunPlan& plan) {
  const int32_t n = mesh.num_vertices();
  const int iterations = p.iterations != kAutoIterations ? p.iterations
                         : plan.fixed_iterations > 0     ? plan.fixed_iterations
                                                         : kTypicalAutoIterations;
  const bool reorder = p.reorder == ReorderMode::kAlways
                           ? ReorderableSize(n)
                           : p.reorder == ReorderMode::kAuto &&
                                 MortonOrderPaysOff(topo, iterations * PassesPerIteration(p));  // validated: below 2^25
  if (!reorder) return RunIterations(mesh, topo, p, control, h, plan);

  const int threads = ThreadsFor(n, p);
  // The run takes the caller's mesh and topology renumbered in place, and gives them back
  // renumbered the other way: no copy of either is held beside them.
  const std::vector<int32_t> order = MortonOrder(mesh.positions, threads);
  FlowParams q = p;
  q.locked = InOrder(order, p.locked);
  q.strength = InOrder(order, p.strength);
  q.bound_centre = InOrder(order, p.bound_centre);
  Renumber(order, mesh, topo, threads);
  absl::StatusOr<FlowResult> result = RunIterations(mesh, topo, q, control, h, plan);
  // The positions as the run left them (the last good iteration on failure).
  RenumberBack(order, mesh, topo, threads);
  return result;
}

}  // namespace flows

std::vector<Vec3> MeanCurvatureNormals(const Mesh& mesh, const Topology& topo) {
  flows::StepContext ctx;
  ctx.offsets = topo.ring_offsets.data();
  ctx.ring = topo.ring.data();
  ctx.kind = topo.kind.data();
  std::vector<Vec3> hn(mesh.positions.size());
  for (int32_t v = 0; v < topo.num_vertices(); ++v) {
    if (topo.kind[v] == VertexKind::kInterior) hn[v] = flows::MeanCurvatureNormal(ctx, mesh.positions.data(), v).hn;
  }
  return hn;
}

}  // namespace meshsmooth
