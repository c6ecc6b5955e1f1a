// Internal to core/flows: the iteration driver Smooth() runs once the parameters are valid and
// the mesh is in the order it runs in (core/flows/reorder.h).
#pragma once

#include "absl/status/statusor.h"
#include "core/flows/flow.h"

namespace meshsmooth::flows {

// Meshes smaller than this run on one thread: below it, waking threads costs more than the
// iteration.
inline constexpr int32_t kParallelThreshold = 20000;

// Threads of a run's vertex loops: one below kParallelThreshold, else FlowParams::threads
// (0 = all hardware threads).
int ThreadsFor(int32_t n, const FlowParams& p);

// The iterations of a valid `p` (its flow set) on `mesh`: roles (free, fixed, boundary curve),
// the Jacobi double buffer, eq. (14)'s threshold, stopping, progress and the divergence checks.
// `h` is the input's mean edge length. With automatic iterations, `fixed_auto_iterations` > 0
// runs that many with no risk estimate (a count chosen on a sample, choice.h). Errors as
// Smooth()'s; the mesh always gets back the positions of the last accepted iteration.
absl::StatusOr<FlowResult> RunIterations(Mesh& mesh, const Topology& topo, const FlowParams& p,
                                         const RunControl& control, double h, int fixed_auto_iterations);

}  // namespace meshsmooth::flows
