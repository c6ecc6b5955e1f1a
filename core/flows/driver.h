// Internal to core/flows and the default job (core/job/): the iteration driver a run goes to
// once its parameters are valid and the mesh is in the order it runs in (core/flows/reorder.h).
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "absl/status/statusor.h"
#include "core/flows/flow.h"

namespace meshsmooth::flows {

// Meshes smaller than this run on one thread: below it, waking threads costs more than the
// iteration.
inline constexpr int32_t kParallelThreshold = 20000;

// Threads of a run's vertex loops: one below kParallelThreshold, else FlowParams::threads
// (0 = all hardware threads).
int ThreadsFor(int32_t n, const FlowParams& p);

// FlowParams::max_displacement: puts each vertex v of pos[begin, end) farther than `bound` from
// centre[v] back onto the sphere of radius `bound` around it, along the line to centre[v]
// (skipping vertices whose role, flow_kernel.h, is kFixed when `role` is not null). Returns how
// many it moved. A vertex at or within the bound keeps its bits.
int64_t KeepWithinBound(const Vec3* centre, double bound, Vec3* pos, int32_t begin, int32_t end,
                        const uint8_t* role = nullptr);

// How a run with automatic iterations stops and what it does with its result: a rule the
// caller gives (the default job's: core/job/). The driver calls Start before the first
// iteration; unless it says the run has nothing to do, ProbeStart once (when the rule wants a
// probe) and After once per accepted iteration (unless the count was chosen beforehand:
// RunPlan::fixed_iterations); last, always, Finish on the positions the run returns.
class StopRule {
 public:
  // best_iteration() of a rule that keeps the last iteration.
  static constexpr int kLastIteration = -1;

  virtual ~StopRule() = default;
  // The run's input (in the vertex order the run uses, reorder.h), its vertices' roles
  // (flow_kernel.h) and the run's threads. A reason when the run has nothing to do: it then does
  // no iteration.
  virtual std::optional<StopReason> Start(const Mesh& input, const Topology& topo, const uint8_t* role,
                                          int threads) = 0;
  // True when After() reads a probe: a second run of the same flow, beside the first, from
  // ProbeStart(the input).
  virtual bool wants_probe() const { return false; }
  virtual std::vector<Vec3> ProbeStart(const std::vector<Vec3>& start) { return start; }
  // After accepted iteration `it` (1-based) with positions `pos` (the probe's: `probe`, null
  // without one): the reason to stop now, if any.
  virtual std::optional<StopReason> After(int it, const Vec3* pos, const Vec3* probe) = 0;
  // The iteration the run returns: kLastIteration, or an earlier one, which the driver keeps a
  // copy of from the iteration after it.
  virtual int best_iteration() const { return kLastIteration; }
  // On the positions the run returns (its own buffers released first) and its result.
  virtual void Finish(Vec3* /*pos*/, FlowResult& /*result*/) {}
};

// How a run with automatic iterations stops: after exactly `fixed_iterations` when > 0 (a count
// chosen beforehand; a linear flow then runs its first N - 1 iterations as one polynomial,
// chebyshev.h, and the rule is not asked after iterations), else when `rule` says so, else at
// the cap (FlowParams::max_auto_iterations).
struct RunPlan {
  int fixed_iterations = 0;
  StopRule* rule = nullptr;
};

// The iterations of a valid `p` (its flow set) on `mesh`: roles (free, fixed, boundary curve),
// the Jacobi double buffer, eq. (14)'s threshold, stopping, progress and the divergence checks.
// `h` is the input's mean edge length; `plan` applies with automatic iterations. Errors as
// Smooth()'s; the mesh always gets back the positions of the last accepted iteration.
absl::StatusOr<FlowResult> RunIterations(Mesh& mesh, const Topology& topo, const FlowParams& p,
                                         const RunControl& control, double h, const RunPlan& plan);

// One flow (p.flow set, p valid) in the vertex order that pays (reorder.h), with `plan` for
// automatic iterations; h is the input's mean edge length; `topo` is lent as Smooth()'s is.
// Defined in smooth.cc.
absl::StatusOr<FlowResult> SmoothOneFlow(Mesh& mesh, Topology& topo, const FlowParams& p, const RunControl& control,
                                         double h, const RunPlan& plan = {});

}  // namespace meshsmooth::flows
