// Smooth() (core/flows/flow.h) with a policy other than today's (kPolicy): for the benchmark's
// ablations, which run the default job with one number or one rule changed.
#pragma once

#include "absl/status/statusor.h"
#include "core/flows/flow.h"
#include "core/job/policy.h"

namespace meshsmooth::job {

absl::StatusOr<FlowResult> SmoothWithPolicy(Mesh& mesh, Topology& topo, const FlowParams& p, const RunControl& control,
                                            const JobPolicy& policy);

}  // namespace meshsmooth::job
