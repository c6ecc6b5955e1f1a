#include "core/flows/choice.h"

#include <optional>
#include <utility>
#include <vector>

#include "core/measure/metrics.h"

namespace meshsmooth::flows {

bool ChoosesFlow(const FlowParams& p) {
  return !p.flow.has_value() && p.iterations == kAutoIterations && !p.step.has_value();
}

absl::StatusOr<FlowResult> SmoothChoosing(Mesh& mesh, const Topology& topo, const FlowParams& p,
                                          const RunControl& control, double h) {
  std::optional<FlowResult> best;
  std::vector<Vec3> best_positions;
  // Progress counts the iterations of every candidate so far; the deadline is the whole
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
  for (FlowId flow : kChoiceFlows) {
    Mesh copy = mesh;
    FlowParams q = p;
    q.flow = flow;
    absl::StatusOr<FlowResult> r = SmoothOneFlow(copy, topo, q, each, h, /*fixed_auto_iterations=*/0);
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

namespace {

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

}  // namespace

absl::StatusOr<FlowResult> SmoothSampled(Mesh& mesh, const Topology& topo, const FlowParams& p,
                                         const RunControl& control, double h) {
  Mesh sample = SamplePatches(mesh, topo);
  const Topology sample_topo = BuildTopology(sample);
  RunControl quiet = control;
  quiet.on_progress = nullptr;
  FlowParams q = p;
  q.locked.clear();  // the sample's vertices are not the mesh's
  const bool choose = ChoosesFlow(p);
  if (!choose) q.flow = p.flow.value_or(kDefaultFlow);
  const double sample_h = MeanEdgeLength(sample, sample_topo);
  absl::StatusOr<FlowResult> chosen = choose ? SmoothChoosing(sample, sample_topo, q, quiet, sample_h)
                                             : SmoothOneFlow(sample, sample_topo, q, quiet, sample_h, 0);
  if (!chosen.ok()) return chosen.status();
  FlowParams whole = p;
  whole.flow = chosen->flow;
  // An idle sample (no noise, or no estimate) leaves the decision to the whole mesh's own
  // estimate and stopping (nothing to do on a clean mesh: as cheap as the sample).
  absl::StatusOr<FlowResult> result = SmoothOneFlow(mesh, topo, whole, control, h, chosen->iterations_run);
  if (result.ok() && result->iterations_run > 0) {
    result->stop_reason = chosen->stop_reason;
    if (result->auto_stop && chosen->auto_stop) result->auto_stop->risk_h2 = chosen->auto_stop->risk_h2;
  }
  return result;
}

}  // namespace meshsmooth::flows
