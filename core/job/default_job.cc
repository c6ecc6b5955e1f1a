// The front door, Smooth(), and the default job: what runs when a job leaves the iterations to
// the input's noise (FlowParams::iterations == kAutoIterations), with or without a flow named.
//
//   1. Read the noise (EstimateNoise, core/measure/noise.h).
//   2. Prepare: where more than impulsive_share of the fits find an outlier, move the outliers
//      back onto their fitted surfaces and read the noise again.
//   3. Run by the risk estimate (SmoothByRisk, choice.h): each candidate flow to its least
//      estimated error (RiskStop, rules.h), the least of them kept.
//   4. Check: where the noise turns the faces visibly but that result turned them by less than
//      risk_turn_share of the predicted turn, the noise is not independent from vertex to vertex
//      (a fused scan's): start again from the input and run each candidate until the faces have
//      turned as far as the noise turns them (SmoothByTurn, TurnStop).
//   5. Finish (in every run, JobRule): repair folds, give a closed mesh its volume back.
//
// With per-vertex strengths (FlowParams::strength), the vertices of strength 0 are held as
// locked ones are (no outlier move, fold repair or volume correction moves them) and the noise
// is read on the others only (their fits). With a bound on displacement
// (FlowParams::max_displacement), every run keeps its vertices within it iteration by iteration, centred
// on the job's input (core/flows/driver.h, KeepWithinBound), and the edits after a run (fold
// repair, volume) and outliers moved back farther than the bound go back onto it at the end.
// With either, the result last keeps no more folded faces than the input had (KeepNoMoreFolds,
// repair.h), which puts vertices back where the input has them.
//
// A JobPolicy (policy.h) holds every number; docs/quality-method.md says why the method is this one.
#include "core/job/default_job.h"

#include <algorithm>
#include <utility>
#include <vector>

#include "core/flows/driver.h"
#include "core/flows/flow.h"
#include "core/job/choice.h"
#include "core/job/policy.h"
#include "core/job/repair.h"
#include "core/measure/metrics.h"
#include "core/measure/noise.h"
#include "core/measure/normal_turn.h"

namespace meshsmooth {
namespace job {
namespace {

// The vertices the noise estimate leaves out: those of strength 0 (null without strengths; `p`
// has them in its lock mask, SmoothWithPolicy).
const uint8_t* NotMeasured(const FlowParams& p) { return p.strength.empty() ? nullptr : p.locked.data(); }

// The share of the usable faces a run with strengths can turn: those with a vertex of strength
// above 0 (1 without strengths). The noise's turn is predicted over every face, a run's measured
// over every face too: the held ones, which never turn, would keep it below the prediction.
double TurnableShare(const Mesh& mesh, const Topology& topo, const FlowParams& p) {
  if (p.strength.empty() || topo.faces.empty()) return 1.0;
  int64_t turnable = 0;
  for (int32_t f : topo.faces) {
    const Triangle& t = mesh.triangles[f];
    turnable += p.strength[t[0]] > 0.0f || p.strength[t[1]] > 0.0f || p.strength[t[2]] > 0.0f;
  }
  return static_cast<double>(turnable) / static_cast<double>(topo.faces.size());
}

// Step 2: moves the outliers back when the noise reads impulsive; returns how many moved and
// reads `noise` again. Twice, the second time at the threshold of the noise read without the
// first pass's outliers, which had pulled their neighbours' fits and raised it.
int64_t MoveOutliersBack(Mesh& mesh, const Topology& topo, const FlowParams& p, const RunControl& control, double h,
                         const JobPolicy& policy, NoiseEstimate& noise) {
  if (!ChoosesFlow(p) || !noise.reliable || noise.outlier_share <= policy.impulsive_share) return 0;
  std::vector<uint8_t> moved(mesh.positions.size(), 0);
  for (int pass = 0; pass < 2 && noise.reliable; ++pass) {
    RemoveOutliers(mesh, topo, h, OutlierThresholdH(noise, policy.noise), policy.outlier_rounds, moved, p.threads,
                   control.stop, p.locked.empty() ? nullptr : p.locked.data(), policy.unfold_rounds, policy.noise);
    noise = EstimateNoise(mesh, topo, h, p.threads, control.stop, NotMeasured(p), policy.noise);
  }
  int64_t outliers = 0;
  for (uint8_t m : moved) outliers += m;
  return outliers;
}

// Positions kept aside through a run: as float32 when every coordinate is one (a job's mesh is
// the upload's float32 points), 12 bytes a vertex instead of 24; else as they are. Given back
// exactly either way.
class KeptPositions {
 public:
  explicit KeptPositions(const std::vector<Vec3>& p) {
    const bool floats = std::all_of(p.begin(), p.end(), [](const Vec3& v) { return RoundToFloat(v) == v; });
    if (!floats) {
      doubles_ = p;
      return;
    }
    floats_.resize(3 * p.size());
    for (size_t i = 0; i < p.size(); ++i) {
      floats_[3 * i] = static_cast<float>(p[i].x);
      floats_[3 * i + 1] = static_cast<float>(p[i].y);
      floats_[3 * i + 2] = static_cast<float>(p[i].z);
    }
  }
  std::vector<Vec3> Get() const {
    if (floats_.empty()) return doubles_;
    std::vector<Vec3> p(floats_.size() / 3);
    for (size_t i = 0; i < p.size(); ++i) p[i] = Vec3{floats_[3 * i], floats_[3 * i + 1], floats_[3 * i + 2]};
    return p;
  }

 private:
  std::vector<float> floats_;
  std::vector<Vec3> doubles_;
};

// `centre`: the bound's centres, the job's input unless the caller gave them (null without a
// bound).
absl::StatusOr<FlowResult> SmoothAutomatic(Mesh& mesh, Topology& topo, const FlowParams& p, const RunControl& control,
                                           double h, const JobPolicy& policy,
                                           const std::vector<Vec3>* centre = nullptr) {
  FlowParams q = p;
  if (!ChoosesFlow(p)) q.flow = p.flow.value_or(kDefaultFlow);
  // 1. Every thread the job may use, whatever the mesh's size: the fits are independent and costly.
  ReportPhase(control, Phase::kNoiseEstimate, q.flow.value_or(kDefaultFlow));
  NoiseEstimate noise = EstimateNoise(mesh, topo, h, p.threads, control.stop, NotMeasured(p), policy.noise);
  // 2.
  const int64_t outliers = MoveOutliersBack(mesh, topo, q, control, h, policy, noise);
  if (absl::Status s = control.stop.Check(); !s.ok()) return s;
  // The runs start from the outliers' new places; the bound stays centred on the input.
  if (outliers > 0 && centre != nullptr) q.bound_centre = *centre;
  // 3. The input is kept only where step 4 may take over (12 or 24 bytes a vertex: KeptPositions).
  const bool visible = TurnsFacesVisibly(noise, policy);
  const KeptPositions kept(visible ? mesh.positions : std::vector<Vec3>{});
  absl::StatusOr<FlowResult> result = SmoothByRisk(mesh, topo, q, control, h, noise, policy, outliers > 0);
  if (!result.ok()) return result;
  // 4. On the faces a run can turn (TurnableShare).
  const bool ran = result->iterations_run > 0 || result->stop_reason == StopReason::kNoGain;
  if (ran && visible) {
    const std::vector<Vec3> input = kept.Get();
    const double share = TurnableShare(mesh, topo, q);
    const double turned = NormalTurn(input.data(), mesh.triangles, topo).Of(mesh.positions.data());
    if (turned < policy.risk_turn_share * share * noise.normal_turn) {
      std::vector<Vec3> by_risk = std::move(mesh.positions);
      mesh.positions = input;
      absl::StatusOr<std::optional<FlowResult>> by_turn = SmoothByTurn(mesh, topo, q, control, h, noise, policy, share);
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

}  // namespace

// Large meshes whose order scatters neighbours run renumbered into Morton order (reorder.h); h is
// taken in the caller's order, so it is the same value whatever the order the run uses.
absl::StatusOr<FlowResult> SmoothWithPolicy(Mesh& mesh, Topology& topo, const FlowParams& p, const RunControl& control,
                                            const JobPolicy& policy) {
  const int32_t n = mesh.num_vertices();
  if (absl::Status s = ValidateFlowParams(p, n); !s.ok()) return s;
  if (topo.num_vertices() != n) {
    return absl::InvalidArgumentError("the topology was built for another mesh");
  }
  const double h = MeanEdgeLength(mesh, topo);
  FlowParams q = p;
  // Strength 1 everywhere is no strength: the same run, bit for bit.
  if (std::all_of(p.strength.begin(), p.strength.end(), [](float s) { return s == 1.0f; })) q.strength.clear();
  // Only the default job moves rims of its own accord (BoundaryMode::kAuto).
  if (q.boundary == BoundaryMode::kAuto && !ChoosesFlow(p)) q.boundary = BoundaryMode::kFixed;
  const double bound = DisplacementBound(q, h);
  absl::StatusOr<FlowResult> result;
  if (p.iterations != kAutoIterations) {
    q.flow = p.flow.value_or(kDefaultFlow);
    result = flows::SmoothOneFlow(mesh, topo, q, control, h);
  } else if (q.strength.empty() && bound == 0.0) {
    result = SmoothAutomatic(mesh, topo, q, control, h, policy);
  } else {
    // Strength 0 holds a vertex as the lock mask does, in every edit of the job.
    if (!q.strength.empty()) {
      if (q.locked.empty()) q.locked.assign(n, 0);
      for (int32_t v = 0; v < n; ++v) q.locked[v] |= q.strength[v] == 0.0f;
    }
    const std::vector<Vec3> input = mesh.positions;
    const std::vector<Vec3>& centre = q.bound_centre.empty() ? input : q.bound_centre;
    result = SmoothAutomatic(mesh, topo, q, control, h, policy, bound > 0.0 ? &centre : nullptr);
    if (result.ok()) {
      if (bound > 0.0) flows::KeepWithinBound(centre.data(), bound, mesh.positions.data(), 0, n);
      KeepNoMoreFolds(mesh.positions.data(), input.data(), mesh, topo);
    }
  }
  if (result.ok()) result->displacement_bound = bound;
  return result;
}

}  // namespace job

absl::StatusOr<FlowResult> Smooth(Mesh& mesh, const FlowParams& p, const RunControl& control) {
  Topology topo = BuildTopology(mesh);
  return Smooth(mesh, topo, p, control);
}

absl::StatusOr<FlowResult> Smooth(Mesh& mesh, Topology& topo, const FlowParams& p, const RunControl& control) {
  return job::SmoothWithPolicy(mesh, topo, p, control, job::kPolicy);
}

}  // namespace meshsmooth
