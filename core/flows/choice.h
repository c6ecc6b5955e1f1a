// Internal to core/flows: automatic iterations, and the default job's choice of flow. Smooth()
// (smooth.cc) hands every run with automatic iterations to SmoothAutomatic.
//
// The input's noise is read once. A mesh of more than kMaxChoiceVertices (catalogue.h) vertices then chooses on
// a sample of itself, patches of SampleSize(n) vertices in all: every candidate flow (one when
// the job names it) runs there with automatic stopping (auto_stop.h), the least estimated error
// (bilateral_normal's by a margin, kSampleBias in choice.cc) gives the flow and its count, and
// the whole mesh runs once, at that count, with no risk
// estimate. A smaller mesh is its own sample: the best candidate's run is the result. Progress
// names the phase (Phase in flow.h): iteration numbers come only from the final run, whose
// count is known before it starts.
#pragma once

#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "core/flows/driver.h"
#include "core/flows/flow.h"

namespace meshsmooth::flows {

// The vertices of the sample a mesh of n vertices chooses on (n when it chooses on itself).
int32_t SampleSize(int32_t n);

// True when `p` leaves the flow to the estimated error: no flow named, automatic iterations, no
// step.
bool ChoosesFlow(const FlowParams& p);

// How rough a surface is, for telling a run that made its input worse: the area of its usable
// faces and its folded edges (the two faces of an edge at an interior vertex facing more than
// kFoldAngleDeg apart, auto_stop.h). Noise adds area and folds; a run that removes noise takes
// both away.
struct Roughness {
  double area = 0.0;
  int64_t folds = 0;
};
Roughness RoughnessOf(const std::vector<Vec3>& pos, const Mesh& mesh, const Topology& topo);

// True when `after` is rougher than `before` (the same mesh's): more area, or more folded edges
// than kNoGainFoldShare (auto_stop.h) of the faces allows. The choice does not take such a run.
bool Rougher(const Roughness& after, const Roughness& before, size_t faces);

// A valid `p` with automatic iterations (flow named or not); h is the input's mean edge length.
absl::StatusOr<FlowResult> SmoothAutomatic(Mesh& mesh, const Topology& topo, const FlowParams& p,
                                           const RunControl& control, double h);

// One flow (p.flow set, p valid) in the vertex order that pays (reorder.h), with `plan` for
// automatic iterations. Defined in smooth.cc.
absl::StatusOr<FlowResult> SmoothOneFlow(Mesh& mesh, const Topology& topo, const FlowParams& p,
                                         const RunControl& control, double h, const AutoPlan& plan);

}  // namespace meshsmooth::flows
