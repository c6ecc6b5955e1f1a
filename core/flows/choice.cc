#include "core/flows/choice.h"

#include <algorithm>
#include <iterator>
#include <optional>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "core/flows/auto_stop.h"
#include "core/flows/discrepancy.h"
#include "core/measure/noise.h"
#include "core/measure/normal_turn.h"

namespace meshsmooth::flows {
namespace {

// A sample holds one vertex in kSampleShare of the mesh's, at least kMinSample and at most
// kMaxSample, in patches of at least kMinPatch vertices, at most kMaxPatches of them; the risk is
// measured in the patches' cores, within kCorePercent of their radius (in rings) from the seed.
// docs/decisions.md ("The default job chooses on a sample") has the figures behind them.
constexpr int32_t kSampleShare = 16;
constexpr int32_t kMinSample = 10000;
constexpr int32_t kMaxSample = 20000;
constexpr int32_t kMinPatch = 2500;
constexpr int32_t kMaxPatches = 8;
constexpr int32_t kCorePercent = 60;
// On a sample, a later candidate (bilateral_normal) is chosen only when its estimate is below
// the first's (bilaplacian's) by more than this share of sigma^2: the patches' fixed rims hold
// back bilaplacian's wider reach more than the normal filter's, so its estimate on a sample reads
// high (docs/decisions.md, "The default job chooses on a sample", has the figures).
constexpr double kSampleBias = 0.025;

// The boundary a run of `flow` takes under the job's `requested` mode (q.boundary and
// q.small_hole_edges): BoundaryMode::kAuto moves the rims with the normal filters' vertex update
// (the planes of their faces: a rim does not shrink) and keeps them fixed with the umbrella
// flows, whose boundary curve umbrella would shrink small holes; there the vertices of holes at
// most kSmallHoleEdges edges around move as interior ones.
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

void Report(const RunControl& control, Phase phase, FlowId flow) {
  if (!control.on_progress) return;
  Progress progress;
  progress.phase = phase;
  progress.flow = flow;
  control.on_progress(progress);
}

// Every candidate (p.flow when set, else kChoiceFlows) on a copy of `mesh` with automatic
// stopping; the least estimated error gives the result, a later candidate's less `margin_h2`
// (the first candidate's estimate decides whether there is anything to do). Progress: one
// kChoosing report per candidate. `repair_idle`: AutoPlan's.
absl::StatusOr<FlowResult> Choose(Mesh& mesh, const Topology& topo, const FlowParams& p, const RunControl& control,
                                  double h, const NoiseEstimate& noise, const std::vector<uint8_t>* measured = nullptr,
                                  double margin_h2 = 0.0, bool repair_idle = false) {
  const std::vector<FlowId> candidates = CandidatesOf(p);
  RunControl quiet = control;
  quiet.on_progress = nullptr;
  std::optional<FlowResult> best;
  std::vector<Vec3> best_positions;
  std::optional<Roughness> input_roughness;
  std::optional<FlowResult> rejected;  // the first candidate that left the input rougher
  for (FlowId flow : candidates) {
    Report(control, Phase::kChoosing, flow);
    Mesh copy = mesh;
    const FlowParams q = ForFlow(p, flow);
    AutoPlan plan{0, &noise, measured, std::nullopt, p.boundary != BoundaryMode::kFixed, repair_idle};
    if (best && best->auto_stop && best->iterations_run > 0) plan.rival_risk_h2 = best->auto_stop->risk_h2 - margin_h2;
    absl::StatusOr<FlowResult> r = SmoothOneFlow(copy, topo, q, quiet, h, plan);
    if (!r.ok()) {
      // A candidate that diverges is not chosen (unless it is the only one); cancellation and
      // the like end the job.
      if (r.status().code() == absl::StatusCode::kFailedPrecondition && candidates.size() > 1) continue;
      return r.status();
    }
    const bool idle = r->iterations_run == 0;
    if (!idle) {
      // A run that left its input rougher did not remove noise, whatever its estimate says
      // (slivers: the estimate reads offsets along the normals, and a sliver's normal turns
      // under an offset far below h): it is not chosen.
      if (!input_roughness) input_roughness = RoughnessOf(mesh.positions, mesh, topo);
      if (Rougher(RoughnessOf(copy.positions, mesh, topo), *input_roughness, topo.faces.size())) {
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
  // Per sample vertex: in a patch's core (at most kCorePercent of the patch's radius, in rings,
  // from its seed), where the patch's fixed rim hardly reaches.
  std::vector<uint8_t> core;
  // Per sample vertex: its vertex in the mesh.
  std::vector<int32_t> origin;
};

// About `size` vertices of `mesh` in patches grown breadth-first from seeds spread over the
// vertex order, and the faces among them. The patches' rims are boundaries (fixed in the runs).
Sample SamplePatches(const Mesh& mesh, const Topology& topo, int32_t size) {
  const int patches = std::clamp(size / kMinPatch, 1, kMaxPatches);
  const int32_t n = topo.num_vertices();
  std::vector<int32_t> index(n, -1);  // vertex -> sample vertex
  Sample out;
  Mesh& sample = out.mesh;
  std::vector<int32_t> queue, depth;  // depth: per sample vertex, rings from its seed
  for (int i = 0; i < patches; ++i) {
    const auto budget = static_cast<size_t>(size) * (i + 1) / patches;
    const int32_t seed = static_cast<int32_t>(static_cast<int64_t>(n) * i / patches);
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
    for (size_t s = first; s < depth.size(); ++s) out.core.push_back(depth[s] * 100 <= radius * kCorePercent);
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

Roughness RoughnessOf(const std::vector<Vec3>& pos, const Mesh& mesh, const Topology& topo) {
  Roughness r;
  for (int32_t f : topo.faces) {
    const Triangle& t = mesh.triangles[f];
    r.area += 0.5 * Norm(Cross(pos[t[1]] - pos[t[0]], pos[t[2]] - pos[t[0]]));
  }
  const double cos_fold = FoldCosine();
  for (int32_t v = 0; v < topo.num_vertices(); ++v) {
    if (topo.kind[v] != VertexKind::kInterior) continue;
    // Each folded edge once: from its lower interior end.
    ForFoldedEdges(pos.data(), topo, v, cos_fold, [&](int32_t w) {
      r.folds += topo.kind[w] != VertexKind::kInterior || v < w;
      return false;
    });
  }
  return r;
}

bool Rougher(const Roughness& after, const Roughness& before, size_t faces) {
  return after.area > before.area ||
         static_cast<double>(after.folds - before.folds) > kNoGainFoldShare * static_cast<double>(faces);
}

int32_t SampleSize(int32_t n) {
  if (n <= kMaxChoiceVertices) return n;
  return std::min(n, std::clamp(n / kSampleShare, kMinSample, kMaxSample));
}

bool ChoosesFlow(const FlowParams& p) {
  return !p.flow.has_value() && p.iterations == kAutoIterations && !p.step.has_value();
}

namespace {

// The sample's vertices a run may not move: the patches' cuts (not the mesh's boundary), which
// the risk estimate does not measure either (they leave sample.core), and the mesh's own locked
// vertices.
std::vector<uint8_t> SampleLocks(Sample& sample, const Topology& sample_topo, const Topology& topo,
                                 const FlowParams& q) {
  std::vector<uint8_t> locked(sample_topo.num_vertices(), 0);
  for (int32_t s = 0; s < sample_topo.num_vertices(); ++s) {
    const int32_t v = sample.origin[s];
    const bool cut = sample_topo.kind[s] == VertexKind::kBoundary && topo.kind[v] != VertexKind::kBoundary;
    locked[s] = cut || (!q.locked.empty() && q.locked[v] != 0);
    if (cut) sample.core[s] = 0;
  }
  return locked;
}

// SmoothAutomatic once the noise is read: `q` has its flow set unless the job chooses it;
// `repair_idle` when outliers were moved (AutoPlan).
absl::StatusOr<FlowResult> SmoothWithEstimate(Mesh& mesh, const Topology& topo, const FlowParams& q,
                                              const RunControl& control, double h, const NoiseEstimate& noise,
                                              bool repair_idle) {
  const int32_t n = mesh.num_vertices();
  const int32_t size = SampleSize(n);
  if (size >= n) return Choose(mesh, topo, q, control, h, noise, nullptr, 0.0, repair_idle);

  Sample sample = SamplePatches(mesh, topo, size);
  const Topology sample_topo = BuildTopology(sample.mesh);
  FlowParams on_sample = q;
  on_sample.reorder = ReorderMode::kNever;  // `core` is in the sample's order
  // The patches' rims are cuts, not the mesh's boundary: they stay fixed and unmeasured
  // whatever the boundary mode. The mesh's own locked vertices stay locked.
  on_sample.locked = SampleLocks(sample, sample_topo, topo, q);
  // The sample runs with the mesh's h (the step of a curvature flow scales with it): its count
  // is then a count of the same iterations.
  const double sigma_h = RiskSigmaH(noise);
  absl::StatusOr<FlowResult> chosen =
      Choose(sample.mesh, sample_topo, on_sample, control, h, noise, &sample.core, kSampleBias * sigma_h * sigma_h);
  if (!chosen.ok()) return chosen.status();
  // Every candidate left the sample rougher: the whole mesh comes back as it came.
  if (chosen->stop_reason == StopReason::kNoGain) return chosen;
  const FlowParams whole = ForFlow(q, chosen->flow);
  if (chosen->iterations_run == 0) {
    // An idle sample (no noise, or no estimate on it) leaves the decision to the whole mesh's
    // own estimate and stopping (nothing to do on a clean mesh: as cheap as the sample).
    return Choose(mesh, topo, whole, control, h, noise, nullptr, 0.0, repair_idle);
  }
  absl::StatusOr<FlowResult> result = SmoothOneFlow(
      mesh, topo, whole, control, h,
      AutoPlan{chosen->iterations_run, &noise, nullptr, std::nullopt, q.boundary != BoundaryMode::kFixed});
  if (result.ok() && result->iterations_run > 0) {
    result->stop_reason = chosen->stop_reason;
    if (result->auto_stop && chosen->auto_stop) result->auto_stop->risk_h2 = chosen->auto_stop->risk_h2;
  }
  return result;
}

// Every candidate (p.flow when set, else kChoiceFlows) on a copy of `mesh`, stopped once its
// faces turned by `target` (DiscrepancyStop); the result whose face normals vary least
// (NormalVariation) wins, none when every result varies more than the input.
absl::StatusOr<std::optional<FlowResult>> ChooseByTurn(Mesh& mesh, const Topology& topo, const FlowParams& p,
                                                       const RunControl& control, double h, const NoiseEstimate& noise,
                                                       double target) {
  const std::vector<FlowId> candidates = CandidatesOf(p);
  RunControl quiet = control;
  quiet.on_progress = nullptr;
  const double input_variation = NormalVariation(mesh.positions.data(), topo);
  std::optional<FlowResult> best;
  std::vector<Vec3> best_positions;
  double best_variation = input_variation;
  for (FlowId flow : candidates) {
    Report(control, Phase::kChoosing, flow);
    Mesh copy = mesh;
    const FlowParams q = ForFlow(p, flow);
    DiscrepancyStop rule(target);
    AutoPlan plan{0, &noise, nullptr, std::nullopt, p.boundary != BoundaryMode::kFixed, false, &rule};
    absl::StatusOr<FlowResult> r = SmoothOneFlow(copy, topo, q, quiet, h, plan);
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

// SmoothAutomatic for noise the risk estimate cannot read: the candidates run to the discrepancy
// target, on the mesh itself or on its sample (then the whole mesh at the chosen count). The
// mesh keeps its positions when no candidate wins.
absl::StatusOr<std::optional<FlowResult>> SmoothToTurn(Mesh& mesh, const Topology& topo, const FlowParams& q,
                                                       const RunControl& control, double h,
                                                       const NoiseEstimate& noise) {
  const double target = kJobPolicy.discrepancy_turn_share * noise.normal_turn;
  const int32_t n = mesh.num_vertices();
  if (n <= kJobPolicy.max_whole_turn_vertices) return ChooseByTurn(mesh, topo, q, control, h, noise, target);
  const int32_t size = SampleSize(n);
  Sample sample = SamplePatches(mesh, topo, size);
  const Topology sample_topo = BuildTopology(sample.mesh);
  FlowParams on_sample = q;
  on_sample.reorder = ReorderMode::kNever;
  on_sample.locked = SampleLocks(sample, sample_topo, topo, q);
  absl::StatusOr<std::optional<FlowResult>> chosen =
      ChooseByTurn(sample.mesh, sample_topo, on_sample, control, h, noise, target);
  if (!chosen.ok() || !chosen->has_value()) return chosen;
  const FlowParams whole = ForFlow(q, (*chosen)->flow);
  absl::StatusOr<FlowResult> result = SmoothOneFlow(mesh, topo, whole, control, h,
                                                    AutoPlan{std::max((*chosen)->iterations_run, 1), &noise, nullptr,
                                                             std::nullopt, q.boundary != BoundaryMode::kFixed});
  if (!result.ok()) return result.status();
  result->stop_reason = (*chosen)->stop_reason;
  return std::optional<FlowResult>(*std::move(result));
}

}  // namespace

absl::StatusOr<FlowResult> SmoothAutomatic(Mesh& mesh, const Topology& topo, const FlowParams& p,
                                           const RunControl& control, double h) {
  FlowParams q = p;
  if (!ChoosesFlow(p)) q.flow = p.flow.value_or(kDefaultFlow);
  Report(control, Phase::kNoiseEstimate, q.flow.value_or(kDefaultFlow));
  // Every thread the job may use, whatever the mesh's size: the fits are independent and costly.
  NoiseEstimate noise = EstimateNoise(mesh, topo, h, p.threads, control.stop);
  int64_t outliers = 0;
  if (ChoosesFlow(p) && noise.reliable && noise.outlier_share > kImpulsiveShare) {
    // Twice, the second time at the threshold of the noise read without the first pass's
    // outliers, which had pulled their neighbours' fits and raised it.
    std::vector<uint8_t> moved(mesh.positions.size(), 0);
    for (int pass = 0; pass < 2 && noise.reliable; ++pass) {
      RemoveOutliers(mesh, topo, h, OutlierThresholdH(noise), kOutlierRounds, moved, p.threads, control.stop,
                     q.locked.empty() ? nullptr : q.locked.data());
      noise = EstimateNoise(mesh, topo, h, p.threads, control.stop);
    }
    for (uint8_t m : moved) outliers += m;
  }
  if (absl::Status s = control.stop.Check(); !s.ok()) return s;
  // The input, kept only where the discrepancy rule may take over (24 bytes a vertex).
  const bool visible = TurnsFacesVisibly(noise);
  const std::vector<Vec3> input = visible ? mesh.positions : std::vector<Vec3>{};
  absl::StatusOr<FlowResult> result = SmoothWithEstimate(mesh, topo, q, control, h, noise, outliers > 0);
  if (!result.ok()) return result;
  // The risk estimate assumes noise independent from vertex to vertex. When its best iteration
  // turned the faces by less than JobPolicy::risk_turn_share of the turn the noise gives them, the noise is
  // not that (a fused scan's is correlated over many edges, and the estimate reads it as shape):
  // the job starts again from its input with the discrepancy rule (discrepancy.h).
  const bool ran = result->iterations_run > 0 || result->stop_reason == StopReason::kNoGain;
  if (ran && visible) {
    const double turned = NormalTurn(input.data(), mesh.triangles, topo).Of(mesh.positions.data());
    if (turned < kJobPolicy.risk_turn_share * noise.normal_turn) {
      std::vector<Vec3> by_risk = std::move(mesh.positions);
      mesh.positions = input;
      absl::StatusOr<std::optional<FlowResult>> by_turn = SmoothToTurn(mesh, topo, q, control, h, noise);
      if (!by_turn.ok()) return by_turn.status();
      if (by_turn->has_value()) {
        result = **std::move(by_turn);
      } else {
        mesh.positions = std::move(by_risk);
      }
    }
  }
  result->outliers_moved = outliers;
  return result;
}

}  // namespace meshsmooth::flows
