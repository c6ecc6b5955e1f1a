#include "core/job/choice.h"

#include <algorithm>
#include <iterator>
#include <optional>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "core/flows/driver.h"
#include "core/job/repair.h"
#include "core/job/rules.h"
#include "core/measure/noise.h"
#include "core/measure/normal_turn.h"

namespace meshsmooth::job {

using flows::SmoothOneFlow;

namespace {

// A sample holds one vertex in sample_share of the mesh's, at least min_sample and at most
// max_sample, in patches of at least min_patch vertices, at most max_patches of them; the risk is
// measured in the patches' cores, within core_percent of their radius (in rings) from the seed.
// On a sample, a later candidate (bilateral_normal) is chosen only when its estimate is below the
// first's (bilaplacian's) by more than sample_bias of sigma^2: the patches' fixed rims hold back
// bilaplacian's wider reach more than the normal filter's, so its estimate on a sample reads high.

// The boundary a run of `flow` takes under the job's `requested` mode (q.boundary and
// q.small_hole_edges): BoundaryMode::kAuto moves the rims with the normal filters' vertex update
// (the planes of their faces: a rim does not shrink) and keeps them fixed with the umbrella
// flows, whose boundary curve umbrella would shrink small holes; there the vertices of holes at
// most kSmallHoleEdges (core/flows/catalogue.h) edges around move as interior ones.
void SetBoundary(FlowParams& q, FlowId flow, BoundaryMode requested) {
  q.boundary = requested;
  if (requested != BoundaryMode::kAuto) return;
  const FlowKind kind = KindOf(flow);
  q.boundary = kind == FlowKind::kNormalFilter ? BoundaryMode::kCurve : BoundaryMode::kFixed;
  if (kind == FlowKind::kUmbrella) q.small_hole_edges = kSmallHoleEdges;
}

// The candidates of a job: p.flow when set, else kChoiceFlows.
std::vector<FlowId> CandidatesOf(const FlowParams& p) {
  if (p.flow) return {*p.flow};
  return {std::begin(kChoiceFlows), std::end(kChoiceFlows)};
}

// `p` for a run of `flow`: the flow set, its boundary as SetBoundary gives it.
FlowParams ForFlow(const FlowParams& p, FlowId flow) {
  FlowParams q = p;
  q.flow = flow;
  SetBoundary(q, flow, p.boundary);
  return q;
}

}  // namespace

void ReportPhase(const RunControl& control, Phase phase, FlowId flow) {
  if (!control.on_progress) return;
  Progress progress;
  progress.phase = phase;
  progress.flow = flow;
  control.on_progress(progress);
}

namespace {

// Every candidate (p.flow when set, else kChoiceFlows) on a copy of `mesh` with automatic
// stopping; the least estimated error gives the result, a later candidate's less `margin_h2`
// (the first candidate's estimate decides whether there is anything to do). Progress: one
// kChoosing report per candidate. `repair_idle`: JobRule's.
absl::StatusOr<FlowResult> Choose(Mesh& mesh, Topology& topo, const FlowParams& p, const RunControl& control, double h,
                                  const NoiseEstimate& noise, const JobPolicy& policy,
                                  const std::vector<uint8_t>* measured = nullptr, double margin_h2 = 0.0,
                                  bool repair_idle = false) {
  const std::vector<FlowId> candidates = CandidatesOf(p);
  RunControl quiet = control;
  quiet.on_progress = nullptr;
  std::optional<FlowResult> best;
  std::vector<Vec3> best_positions;
  std::optional<double> input_area;
  std::optional<FlowResult> rejected;  // the first candidate that left the input rougher
  for (FlowId flow : candidates) {
    ReportPhase(control, Phase::kChoosing, flow);
    Mesh copy = mesh;
    const FlowParams q = ForFlow(p, flow);
    RiskStop rule(h, noise, policy, measured, p.boundary != BoundaryMode::kFixed, repair_idle);
    if (best && best->auto_stop && best->iterations_run > 0) rule.SetRival(best->auto_stop->risk_h2 - margin_h2);
    absl::StatusOr<FlowResult> r = SmoothOneFlow(copy, topo, q, quiet, h, {0, &rule});
    if (!r.ok()) {
      // A candidate that diverges is not chosen (unless it is the only one); cancellation and
      // the like end the job.
      if (r.status().code() == absl::StatusCode::kFailedPrecondition && candidates.size() > 1) continue;
      return r.status();
    }
    const bool idle = r->iterations_run == 0;
    if (!idle) {
      // A run that left its input more area did not remove noise, whatever its estimate says
      // (slivers: the estimate reads offsets along the normals, and a sliver's normal turns
      // under an offset far below h): it is not chosen.
      if (!input_area) input_area = SurfaceArea(mesh.positions, mesh, topo);
      if (SurfaceArea(copy.positions, mesh, topo) > *input_area) {
        if (!rejected) rejected = *std::move(r);
        continue;
      }
    }
    if (!best || (r->auto_stop && best->auto_stop && r->auto_stop->risk_h2 < best->auto_stop->risk_h2 - margin_h2)) {
      best = *std::move(r);
      best_positions = std::move(copy.positions);
    }
    if (idle) break;  // no noise to remove, or no estimate: the same for every candidate
  }
  if (!best && rejected) {
    // Every candidate left the input rougher: the input comes back, as it came.
    FlowResult& none = *rejected;
    none.iterations_run = 0;
    none.stop_reason = StopReason::kNoGain;
    if (none.auto_stop) none.auto_stop->displacement_h = 0.0;
    return *std::move(rejected);
  }
  if (!best) return absl::FailedPreconditionError("every candidate flow diverged");
  mesh.positions = std::move(best_positions);
  return *std::move(best);
}

struct Sample {
  Mesh mesh;
  // Per sample vertex: in a patch's core (at most core_percent of the patch's radius, in rings,
  // from its seed), where the patch's fixed rim hardly reaches.
  std::vector<uint8_t> core;
  // Per sample vertex: its vertex in the mesh.
  std::vector<int32_t> origin;
};

// About `size` vertices of `mesh` in patches grown breadth-first from seeds spread over the
// vertex order, and the faces among them. The patches' rims are boundaries (fixed in the runs).
// A seed that `locked` (per vertex; empty: none) holds moves on to the next vertex free to move,
// so that the patches measure the vertices the job moves.
Sample SamplePatches(const Mesh& mesh, const Topology& topo, int32_t size, const JobPolicy& policy,
                     const std::vector<uint8_t>& locked) {
  const int patches = std::clamp(size / policy.min_patch, 1, policy.max_patches);
  const int32_t n = topo.num_vertices();
  std::vector<int32_t> index(n, -1);  // vertex -> sample vertex
  Sample out;
  Mesh& sample = out.mesh;
  std::vector<int32_t> queue, depth;  // depth: per sample vertex, rings from its seed
  for (int i = 0; i < patches; ++i) {
    const auto budget = static_cast<size_t>(size) * (i + 1) / patches;
    int32_t seed = static_cast<int32_t>(static_cast<int64_t>(n) * i / patches);
    while (!locked.empty() && seed + 1 < n && locked[seed] != 0) ++seed;
    if (index[seed] >= 0 || topo.kind[seed] == VertexKind::kIsolated) continue;
    queue.assign(1, seed);
    const size_t first = sample.positions.size();
    index[seed] = static_cast<int32_t>(first);
    sample.positions.push_back(mesh.positions[seed]);
    out.origin.push_back(seed);
    depth.push_back(0);
    for (size_t head = 0; head < queue.size() && sample.positions.size() < budget; ++head) {
      const int32_t v = queue[head];
      for (int32_t k = topo.ring_offsets[v]; k < topo.ring_offsets[v + 1] && sample.positions.size() < budget; ++k) {
        const int32_t w = topo.ring[k];
        if (index[w] >= 0) continue;
        index[w] = static_cast<int32_t>(sample.positions.size());
        sample.positions.push_back(mesh.positions[w]);
        out.origin.push_back(w);
        depth.push_back(depth[index[v]] + 1);
        queue.push_back(w);
      }
    }
    const int32_t radius = depth.back();
    for (size_t s = first; s < depth.size(); ++s) out.core.push_back(depth[s] * 100 <= radius * policy.core_percent);
  }
  for (int32_t f : topo.faces) {
    const Triangle& t = mesh.triangles[f];
    if (index[t[0]] >= 0 && index[t[1]] >= 0 && index[t[2]] >= 0) {
      sample.triangles.push_back({index[t[0]], index[t[1]], index[t[2]]});
    }
  }
  return out;
}

}  // namespace

int32_t SampleSize(int32_t n, const JobPolicy& policy) {
  if (n <= kMaxChoiceVertices) return n;
  return std::min(n, std::clamp(n / policy.sample_share, policy.min_sample, policy.max_sample));
}

bool ChoosesFlow(const FlowParams& p) {
  return !p.flow.has_value() && p.iterations == kAutoIterations && !p.step.has_value();
}

namespace {

// The sample's vertices a run may not move: the patches' cuts (not the mesh's boundary), which
// the risk estimate does not measure either (they leave sample.core), and the mesh's own locked
// vertices. The mesh's strengths (FlowParams::strength) and bound centres go to the sample's
// vertices in `on_sample`.
void SampleLocks(Sample& sample, const Topology& sample_topo, const Topology& topo, const FlowParams& q,
                 FlowParams& on_sample) {
  std::vector<uint8_t> locked(sample_topo.num_vertices(), 0);
  for (int32_t s = 0; s < sample_topo.num_vertices(); ++s) {
    const int32_t v = sample.origin[s];
    const bool cut = sample_topo.kind[s] == VertexKind::kBoundary && topo.kind[v] != VertexKind::kBoundary;
    locked[s] = cut || (!q.locked.empty() && q.locked[v] != 0);
    // With strengths, a held vertex (a rim's, which the estimate would count) is not measured.
    if (cut || (locked[s] && !q.strength.empty())) sample.core[s] = 0;
  }
  on_sample.locked = std::move(locked);
  on_sample.bound_centre.clear();
  if (!q.bound_centre.empty()) {
    on_sample.bound_centre.resize(sample_topo.num_vertices());
    for (int32_t s = 0; s < sample_topo.num_vertices(); ++s)
      on_sample.bound_centre[s] = q.bound_centre[sample.origin[s]];
  }
  on_sample.strength.clear();
  if (q.strength.empty()) return;
  on_sample.strength.resize(sample_topo.num_vertices());
  for (int32_t s = 0; s < sample_topo.num_vertices(); ++s) on_sample.strength[s] = q.strength[sample.origin[s]];
}

}  // namespace

absl::StatusOr<FlowResult> SmoothByRisk(Mesh& mesh, Topology& topo, const FlowParams& q, const RunControl& control,
                                        double h, const NoiseEstimate& noise, const JobPolicy& policy,
                                        bool repair_idle) {
  const int32_t n = mesh.num_vertices();
  const int32_t size = SampleSize(n, policy);
  // With strengths, the estimate measures the vertices free to move only (a held rim's would count).
  std::vector<uint8_t> free_to_move;
  if (!q.strength.empty()) {
    free_to_move.resize(n);
    for (int32_t v = 0; v < n; ++v) free_to_move[v] = q.locked[v] == 0;
  }
  const std::vector<uint8_t>* const measured = free_to_move.empty() ? nullptr : &free_to_move;
  if (size >= n) return Choose(mesh, topo, q, control, h, noise, policy, measured, 0.0, repair_idle);

  Sample sample = SamplePatches(mesh, topo, size, policy, q.locked);
  Topology sample_topo = BuildTopology(sample.mesh);
  FlowParams on_sample = q;
  on_sample.reorder = ReorderMode::kNever;  // `core` is in the sample's order
  // The patches' rims are cuts, not the mesh's boundary: they stay fixed and unmeasured
  // whatever the boundary mode. The mesh's own locked vertices stay locked.
  SampleLocks(sample, sample_topo, topo, q, on_sample);
  // The sample runs with the mesh's h (the step of a curvature flow scales with it): its count
  // is then a count of the same iterations.
  const double sigma_h = RiskSigmaH(noise, policy);
  absl::StatusOr<FlowResult> chosen = Choose(sample.mesh, sample_topo, on_sample, control, h, noise, policy,
                                             &sample.core, policy.sample_bias * sigma_h * sigma_h);
  if (!chosen.ok()) return chosen.status();
  // Every candidate left the sample rougher: the whole mesh comes back as it came.
  if (chosen->stop_reason == StopReason::kNoGain) return chosen;
  const FlowParams whole = ForFlow(q, chosen->flow);
  if (chosen->iterations_run == 0) {
    // An idle sample (no noise, or no estimate on it) leaves the decision to the whole mesh's
    // own estimate and stopping (nothing to do on a clean mesh: as cheap as the sample).
    return Choose(mesh, topo, whole, control, h, noise, policy, measured, 0.0, repair_idle);
  }
  JobRule rule(h, noise, policy, nullptr, q.boundary != BoundaryMode::kFixed);
  absl::StatusOr<FlowResult> result = SmoothOneFlow(mesh, topo, whole, control, h, {chosen->iterations_run, &rule});
  if (result.ok() && result->iterations_run > 0) {
    result->stop_reason = chosen->stop_reason;
    if (result->auto_stop && chosen->auto_stop) result->auto_stop->risk_h2 = chosen->auto_stop->risk_h2;
  }
  return result;
}

namespace {

// Every candidate (p.flow when set, else kChoiceFlows) on a copy of `mesh`, stopped once its
// faces turned by `target` (TurnStop); the result whose face normals vary least
// (NormalVariation) wins, none when every result varies more than the input.
absl::StatusOr<std::optional<FlowResult>> ChooseByTurn(Mesh& mesh, Topology& topo, const FlowParams& p,
                                                       const RunControl& control, double h, const NoiseEstimate& noise,
                                                       const JobPolicy& policy, double target) {
  const std::vector<FlowId> candidates = CandidatesOf(p);
  RunControl quiet = control;
  quiet.on_progress = nullptr;
  const double input_variation = NormalVariation(mesh.positions.data(), topo);
  std::optional<FlowResult> best;
  std::vector<Vec3> best_positions;
  double best_variation = input_variation;
  for (FlowId flow : candidates) {
    ReportPhase(control, Phase::kChoosing, flow);
    Mesh copy = mesh;
    const FlowParams q = ForFlow(p, flow);
    TurnStop rule(h, noise, policy, target, p.boundary != BoundaryMode::kFixed);
    absl::StatusOr<FlowResult> r = SmoothOneFlow(copy, topo, q, quiet, h, {0, &rule});
    if (!r.ok()) {
      if (r.status().code() == absl::StatusCode::kFailedPrecondition && candidates.size() > 1) continue;
      return r.status();
    }
    const double variation = NormalVariation(copy.positions.data(), topo);
    if (variation >= best_variation) continue;
    best = *std::move(r);
    best_positions = std::move(copy.positions);
    best_variation = variation;
  }
  if (best) mesh.positions = std::move(best_positions);
  return best;
}

}  // namespace

absl::StatusOr<std::optional<FlowResult>> SmoothByTurn(Mesh& mesh, Topology& topo, const FlowParams& q,
                                                       const RunControl& control, double h, const NoiseEstimate& noise,
                                                       const JobPolicy& policy, double turnable) {
  const double target = turnable * policy.discrepancy_turn_share * noise.normal_turn;
  const int32_t n = mesh.num_vertices();
  if (n <= policy.max_whole_turn_vertices) return ChooseByTurn(mesh, topo, q, control, h, noise, policy, target);
  const int32_t size = SampleSize(n, policy);
  Sample sample = SamplePatches(mesh, topo, size, policy, q.locked);
  Topology sample_topo = BuildTopology(sample.mesh);
  FlowParams on_sample = q;
  on_sample.reorder = ReorderMode::kNever;
  SampleLocks(sample, sample_topo, topo, q, on_sample);
  absl::StatusOr<std::optional<FlowResult>> chosen =
      ChooseByTurn(sample.mesh, sample_topo, on_sample, control, h, noise, policy, target);
  if (!chosen.ok() || !chosen->has_value()) return chosen;
  const FlowParams whole = ForFlow(q, (*chosen)->flow);
  JobRule rule(h, noise, policy, nullptr, q.boundary != BoundaryMode::kFixed);
  absl::StatusOr<FlowResult> result =
      SmoothOneFlow(mesh, topo, whole, control, h, {std::max((*chosen)->iterations_run, 1), &rule});
  if (!result.ok()) return result.status();
  result->stop_reason = (*chosen)->stop_reason;
  return std::optional<FlowResult>(*std::move(result));
}

}  // namespace meshsmooth::job
