// Internal to core/flows: the iteration driver Smooth() runs once the parameters are valid and
// the mesh is in the order it runs in (core/flows/reorder.h).
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "absl/status/statusor.h"
#include "core/flows/flow.h"
#include "core/measure/noise.h"

namespace meshsmooth::flows {

// Meshes smaller than this run on one thread: below it, waking threads costs more than the
// iteration.
inline constexpr int32_t kParallelThreshold = 20000;

// Threads of a run's vertex loops: one below kParallelThreshold, else FlowParams::threads
// (0 = all hardware threads).
int ThreadsFor(int32_t n, const FlowParams& p);

// The iterations of a valid `p` (its flow set) on `mesh`: roles (free, fixed, boundary curve),
// the Jacobi double buffer, eq. (14)'s threshold, stopping, progress and the divergence checks.
// When a run with automatic iterations stops, if not at its least estimated error: told the
// run's input (in the vertex order the run uses, reorder.h) before the first iteration, then
// asked after every accepted one.
class StopRule {
 public:
  virtual ~StopRule() = default;
  virtual void Start(const Mesh& input, const Topology& topo) = 0;
  // The reason to stop at iteration `iteration` (1-based) with positions `pos`, if any.
  virtual std::optional<StopReason> After(int iteration, const Vec3* pos) = 0;
};

// How a run with automatic iterations stops.
struct AutoPlan {
  // > 0: exactly this many iterations (a count chosen on a sample, choice.h), with no risk
  // estimate; the folds are repaired and the volume kept as usual.
  int fixed_iterations = 0;
  // The input's noise, read once by the caller (a job that tries several flows reads it once);
  // null: the run reads it.
  const NoiseEstimate* noise = nullptr;
  // Per vertex: non-zero where the risk estimate measures (the cores of a sample's patches,
  // away from their fixed rims); null: every free interior vertex (and see measure_rims).
  const std::vector<uint8_t>* measured = nullptr;
  // The estimated error (risk_h2) of a rival run on the same input: the run gives up once its
  // own estimate can no longer fall below it (AutoStop::SetRival).
  std::optional<double> rival_risk_h2;
  // The estimate also measures the boundary vertices (among `measured`), moved or not: candidates
  // that treat the rims differently are then compared on the same vertices.
  bool measure_rims = false;
  // The input was changed before the run (outliers moved, noise.h): a run that finds no noise
  // to remove still repairs the folds the change left (AutoStop::RepairFolds).
  bool repair_idle = false;
  // Set: the run stops when this rule says so (StopRule), not at the least estimated error: no
  // probe, no risk estimate; the folds are repaired and the volume kept as usual.
  StopRule* stop_rule = nullptr;
};

// `h` is the input's mean edge length; `plan` applies with automatic iterations. Errors as
// Smooth()'s; the mesh always gets back the positions of the last accepted iteration.
absl::StatusOr<FlowResult> RunIterations(Mesh& mesh, const Topology& topo, const FlowParams& p,
                                         const RunControl& control, double h, const AutoPlan& plan);

}  // namespace meshsmooth::flows
