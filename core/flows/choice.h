// Internal to core/flows: the default job's choice. A job whose FlowParams name no flow, with
// automatic iterations and no step, runs every candidate flow with automatic stopping and keeps
// the one whose estimated error to the noise-free surface is least; meshes above
// kMaxChoiceVertices (catalogue.h) make that choice, and automatic stopping's count, on patches of themselves
// and then run once. Smooth() (smooth.cc) is the only caller.
#pragma once

#include <cstdint>

#include "absl/status/statusor.h"
#include "core/flows/flow.h"

namespace meshsmooth::flows {

// The patches of a mesh above kMaxChoiceVertices (catalogue.h) hold this many vertices in all.
inline constexpr int32_t kSampleVertices = 20000;

// True when `p` leaves the flow to the estimated error: no flow named, automatic iterations, no
// step.
bool ChoosesFlow(const FlowParams& p);

// Every candidate on a copy of the input with automatic stopping; the least estimated error
// gives the result (the first candidate's estimate decides whether there is anything to do).
// `p` is valid; h is the input's mean edge length.
absl::StatusOr<FlowResult> SmoothChoosing(Mesh& mesh, const Topology& topo, const FlowParams& p,
                                          const RunControl& control, double h);

// Automatic stopping on a large mesh: the flow (if ChoosesFlow) and the count from its patches,
// then one run of the whole mesh at that count.
absl::StatusOr<FlowResult> SmoothSampled(Mesh& mesh, const Topology& topo, const FlowParams& p,
                                         const RunControl& control, double h);

// One flow (p.flow set, p valid) in the vertex order that pays (reorder.h). With automatic
// iterations, `fixed_auto_iterations` > 0 runs exactly that many (a count chosen on a sample)
// with no risk estimate, then repairs folds and keeps the volume as usual. Defined in smooth.cc.
absl::StatusOr<FlowResult> SmoothOneFlow(Mesh& mesh, const Topology& topo, const FlowParams& p,
                                         const RunControl& control, double h, int fixed_auto_iterations);

}  // namespace meshsmooth::flows
