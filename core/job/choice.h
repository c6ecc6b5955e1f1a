// The default job's runs once the noise is read (default_job.cc says when each is taken): every
// candidate flow (kChoiceFlows, core/flows/catalogue.h; one when the job names it) runs on a copy
// of the mesh under a stop rule (rules.h), and one result is kept.
//
// SmoothByRisk: each candidate stops at its least estimated error (RiskStop); the least of
// those wins, and a run that leaves its input rougher (repair.h) is not taken. A mesh of more
// than kMaxChoiceVertices vertices chooses on a sample of itself, patches of SampleSize(n)
// vertices in all (bilateral_normal must win there by a margin, sample_bias), and the whole mesh
// runs once, at the chosen count, with no estimate. Progress names the phase (Phase in flow.h):
// iteration numbers come only from the final run.
//
// SmoothByTurn: each candidate stops once its faces turned as far as the noise turns them
// (TurnStop); the result whose face normals vary least (NormalVariation) wins, on the whole mesh
// up to max_whole_turn_vertices, above on a sample (then the whole mesh at the chosen count).
#pragma once

#include <cstdint>
#include <optional>

#include "absl/status/statusor.h"
#include "core/flows/flow.h"
#include "core/job/policy.h"
#include "core/measure/noise.h"

namespace meshsmooth::job {

// The vertices of the sample a mesh of n vertices chooses on (n when it chooses on itself).
int32_t SampleSize(int32_t n, const JobPolicy& policy);

// True when `p` leaves the flow to the job: no flow named, automatic iterations, no step.
bool ChoosesFlow(const FlowParams& p);

// A progress report of `phase` (no iteration) for `flow`.
void ReportPhase(const RunControl& control, Phase phase, FlowId flow);

// `q` has its flow set unless the job chooses it; h is the input's mean edge length, `noise` its
// estimate; `repair_idle` when outliers were moved (JobRule).
absl::StatusOr<FlowResult> SmoothByRisk(Mesh& mesh, Topology& topo, const FlowParams& q, const RunControl& control,
                                        double h, const NoiseEstimate& noise, const JobPolicy& policy,
                                        bool repair_idle);

// As SmoothByRisk, by the turn; none (the mesh as it was) when every result's normals vary more
// than the input's. `turnable`: the share of the faces a run can turn (with strengths, those
// with a vertex free to move), which scales the turn the runs stop at.
absl::StatusOr<std::optional<FlowResult>> SmoothByTurn(Mesh& mesh, Topology& topo, const FlowParams& q,
                                                       const RunControl& control, double h, const NoiseEstimate& noise,
                                                       const JobPolicy& policy, double turnable = 1.0);

}  // namespace meshsmooth::job
