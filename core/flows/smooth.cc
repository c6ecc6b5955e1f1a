// Smooth(): validates the parameters, picks the order the mesh runs in (core/flows/reorder.h)
// and hands the iterations to the driver (core/flows/driver.h).
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
#include "core/flows/operators.h"
#include "core/flows/reorder.h"
#include "core/measure/metrics.h"

namespace meshsmooth {
namespace {

// What an automatic run typically takes on a noisy scan (docs/quality.md), for the choice of
// the order it runs in.
constexpr int kTypicalAutoIterations = 20;

}  // namespace

std::string_view StopReasonName(StopReason reason) {
  switch (reason) {
    case StopReason::kIterations: return "iterations";
    case StopReason::kTolerance: return "tolerance";
    case StopReason::kTimeBudget: return "time_budget";
    case StopReason::kNoiseRemoved: return "noise_removed";
    case StopReason::kNoNoise: return "no_noise";
    case StopReason::kConverged: return "converged";
    case StopReason::kNoEstimate: return "no_estimate";
  }
  return "iterations";
}

absl::Status ValidateFlowParams(const FlowParams& p, int32_t num_vertices) {
  // The cotangent kernel addresses coordinates as int32 3 * vertex (operators.h, MeanCurvatureLanes).
  if (num_vertices > std::numeric_limits<int32_t>::max() / 3) {
    return absl::InvalidArgumentError(absl::StrCat("the mesh has ", num_vertices, " vertices; at most ",
                                                   std::numeric_limits<int32_t>::max() / 3, " can be smoothed"));
  }
  if (static_cast<size_t>(p.flow) >= FlowTable().size()) {
    return absl::InvalidArgumentError(absl::StrCat("unknown flow id ", static_cast<int>(p.flow)));
  }
  const FlowRow& row = FlowOf(p.flow);
  if (p.iterations < kAutoIterations || p.iterations > kMaxIterations) {
    return absl::InvalidArgumentError(absl::StrCat("iterations must be in 1..", kMaxIterations, " or ",
                                                   kAutoIterations, " (automatic), got ", p.iterations));
  }
  if (p.max_auto_iterations < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("the automatic iteration limit must be >= 1, got ", p.max_auto_iterations));
  }
  const double step = p.step.value_or(row.default_step);
  if (!(step > 0.0) || !(step <= row.max_step)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "step must be in (0, %g] for %s, got %g%s", row.max_step, row.name, step,
        row.kind == FlowKind::kCurvature ? " (relative to the squared mean edge length)" : ""));
  }
  if (row.validate != nullptr) {
    if (absl::Status s = row.validate(p, step); !s.ok()) return s;
  }
  if (!std::isfinite(p.taubin_mu) || p.taubin_mu < 0.0) {
    return absl::InvalidArgumentError(absl::StrFormat("taubin mu must be >= 0 (0 = from the pass band), got %g", p.taubin_mu));
  }
  if (!(p.epsilon > 0.0) || !(p.epsilon < 1.0)) {
    return absl::InvalidArgumentError(absl::StrFormat("epsilon must be in (0, 1), got %g", p.epsilon));
  }
  if (p.adaptive == AdaptiveMode::kConstant && (!(p.adaptive_threshold >= 0.0) || !std::isfinite(p.adaptive_threshold))) {
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
    return absl::InvalidArgumentError(absl::StrCat("the lock mask has ", p.locked.size(),
                                                   " entries for ", num_vertices, " vertices"));
  }
  if (p.threads < 0) return absl::InvalidArgumentError(absl::StrCat("threads must be >= 0, got ", p.threads));
  return absl::OkStatus();
}

absl::StatusOr<FlowResult> Smooth(Mesh& mesh, const FlowParams& p, const RunControl& control) {
  const Topology topo = BuildTopology(mesh);
  return Smooth(mesh, topo, p, control);
}

namespace {

absl::StatusOr<FlowResult> SmoothWith(Mesh& mesh, const Topology& topo, const FlowParams& p,
                                      const RunControl& control, double h);

// FlowParams::choose_flow: every candidate runs on a copy of the input with automatic stopping;
// the one with the least estimated error gives the result. The first candidate's estimate
// decides whether there is anything to do at all.
absl::StatusOr<FlowResult> SmoothChoosing(Mesh& mesh, const Topology& topo, const FlowParams& p,
                                          const RunControl& control, double h) {
  std::optional<FlowResult> best;
  std::vector<Vec3> best_positions;
  // Progress counts the iterations of every candidate so far; the time budget is the whole
  // choice's.
  int done = 0;
  RunControl each = control;
  if (control.on_progress) {
    each.on_progress = [&done, &control](const Progress& progress) {
      Progress total = progress;
      total.iteration += done;
      control.on_progress(total);
    };
  }
  const auto t0 = std::chrono::steady_clock::now();
  for (FlowId flow : kChoiceFlows) {
    if (control.time_budget_seconds > 0.0) {
      each.time_budget_seconds = std::max(
          1e-9, control.time_budget_seconds - std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    Mesh copy = mesh;
    FlowParams q = p;
    q.flow = flow;
    q.choose_flow = false;
    absl::StatusOr<FlowResult> r = SmoothWith(copy, topo, q, each, h);
    if (r.ok()) done += r->last.iteration;
    if (!r.ok()) {
      // A candidate that diverges is not chosen; cancellation and the like end the job.
      if (r.status().code() == absl::StatusCode::kFailedPrecondition) continue;
      return r.status();
    }
    const bool idle = r->iterations_run == 0;
    if (!best || (r->auto_stop && best->auto_stop && r->auto_stop->risk_h2 < best->auto_stop->risk_h2)) {
      best = *std::move(r);
      best_positions = std::move(copy.positions);
    }
    if (idle) break;  // no noise to remove, or no estimate: the same for every candidate
  }
  if (!best) return absl::FailedPreconditionError("every candidate flow diverged");
  mesh.positions = std::move(best_positions);
  return *std::move(best);
}

// Up to kSampleVertices vertices of `mesh` in patches grown breadth-first from seeds spread
// over the vertex order, and the faces among them: a sample of the surface on which automatic
// stopping chooses for the whole mesh. The patches' rims are boundaries (fixed in the runs).
Mesh SamplePatches(const Mesh& mesh, const Topology& topo) {
  constexpr int kPatches = 8;
  const int32_t n = topo.num_vertices();
  std::vector<int32_t> index(n, -1);  // vertex -> sample vertex
  Mesh sample;
  std::vector<int32_t> queue;
  for (int i = 0; i < kPatches; ++i) {
    const auto budget = static_cast<size_t>(kSampleVertices) * (i + 1) / kPatches;
    const int32_t seed = static_cast<int32_t>(static_cast<int64_t>(n) * i / kPatches);
    if (index[seed] >= 0 || topo.kind[seed] == VertexKind::kIsolated) continue;
    queue.assign(1, seed);
    index[seed] = static_cast<int32_t>(sample.positions.size());
    sample.positions.push_back(mesh.positions[seed]);
    for (size_t head = 0; head < queue.size() && sample.positions.size() < budget; ++head) {
      const int32_t v = queue[head];
      for (int32_t k = topo.ring_offsets[v]; k < topo.ring_offsets[v + 1] && sample.positions.size() < budget; ++k) {
        const int32_t w = topo.ring[k];
        if (index[w] >= 0) continue;
        index[w] = static_cast<int32_t>(sample.positions.size());
        sample.positions.push_back(mesh.positions[w]);
        queue.push_back(w);
      }
    }
  }
  for (int32_t f : topo.faces) {
    const Triangle& t = mesh.triangles[f];
    if (index[t[0]] >= 0 && index[t[1]] >= 0 && index[t[2]] >= 0) {
      sample.triangles.push_back({index[t[0]], index[t[1]], index[t[2]]});
    }
  }
  return sample;
}

// Automatic stopping on a large mesh: flow (if it is to be chosen) and count from its patches,
// then one run of the whole mesh at that count.
absl::StatusOr<FlowResult> SmoothSampled(Mesh& mesh, const Topology& topo, const FlowParams& p,
                                         const RunControl& control, double h) {
  Mesh sample = SamplePatches(mesh, topo);
  const Topology sample_topo = BuildTopology(sample);
  RunControl quiet = control;
  quiet.on_progress = nullptr;
  FlowParams q = p;
  q.locked.clear();  // the sample's vertices are not the mesh's
  absl::StatusOr<FlowResult> chosen =
      q.choose_flow ? SmoothChoosing(sample, sample_topo, q, quiet, MeanEdgeLength(sample, sample_topo))
                    : SmoothWith(sample, sample_topo, q, quiet, MeanEdgeLength(sample, sample_topo));
  if (!chosen.ok()) return chosen.status();
  FlowParams whole = p;
  whole.flow = chosen->flow;
  whole.choose_flow = false;
  // An idle sample (no noise, or no estimate) leaves the decision to the whole mesh's own
  // estimate and stopping (nothing to do on a clean mesh: as cheap as the sample).
  whole.sampled_iterations = chosen->iterations_run;
  absl::StatusOr<FlowResult> result = SmoothWith(mesh, topo, whole, control, h);
  if (result.ok() && result->iterations_run > 0) {
    result->stop_reason = chosen->stop_reason;
    if (result->auto_stop && chosen->auto_stop) result->auto_stop->risk_h2 = chosen->auto_stop->risk_h2;
  }
  return result;
}

}  // namespace

// Large meshes whose order scatters neighbours run on a Morton-ordered copy (reorder.h); h is
// taken in the caller's order, so it is the same value whatever the order the run uses.
absl::StatusOr<FlowResult> Smooth(Mesh& mesh, const Topology& topo, const FlowParams& p, const RunControl& control) {
  const int32_t n = mesh.num_vertices();
  if (absl::Status s = ValidateFlowParams(p, n); !s.ok()) return s;
  if (topo.num_vertices() != n) {
    return absl::InvalidArgumentError("the topology was built for another mesh");
  }
  const double h = MeanEdgeLength(mesh, topo);
  if (p.iterations == kAutoIterations && p.sampled_iterations == 0 && n > kMaxChoiceVertices) {
    return SmoothSampled(mesh, topo, p, control, h);
  }
  if (p.choose_flow && p.iterations == kAutoIterations) return SmoothChoosing(mesh, topo, p, control, h);
  return SmoothWith(mesh, topo, p, control, h);
}

namespace {

absl::StatusOr<FlowResult> SmoothWith(Mesh& mesh, const Topology& topo, const FlowParams& p,
                                      const RunControl& control, double h) {
  const int32_t n = mesh.num_vertices();
  const int iterations = p.iterations != kAutoIterations ? p.iterations
                         : p.sampled_iterations > 0      ? p.sampled_iterations
                                                         : kTypicalAutoIterations;
  const bool reorder = p.reorder == ReorderMode::kAlways
                           ? ReorderableSize(n)
                           : p.reorder == ReorderMode::kAuto &&
                               MortonOrderPaysOff(topo, iterations * PassesPerIteration(p));  // validated: below 2^25
  if (!reorder) return flows::RunIterations(mesh, topo, p, control, h);

  const int threads = flows::ThreadsFor(n, p);
  ReorderedMesh local = ReorderByMorton(mesh, topo, p.locked, threads);
  FlowParams q = p;
  q.locked = std::move(local.locked);
  absl::StatusOr<FlowResult> result = flows::RunIterations(local.mesh, local.topo, q, control, h);
  // The positions as the run left them (the last good iteration on failure).
  RestoreOrder(local, mesh, threads);
  return result;
}

}  // namespace

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
