// Internal to core/flows: the flow table, one row per flow (catalogue.h lists them). Each row is
// defined in its flow's own file (flows::<Name>Row()), beside the kernel it makes and the checks
// it runs; this table only collects them in FlowId order. Everything after a request's entry
// (validation, the kernel, ListFlows, the CLI's choices and help) reads the row.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "core/flows/catalogue.h"

namespace meshsmooth {

struct FlowParams;
namespace flows {
class FlowKernel;
}

// How far one pass of a flow may move a vertex: what bounds where a result can lie (the job
// fuzzer checks every result against it).
enum class PassReach : uint8_t {
  kConvex,    // to a convex combination of its neighbours: the bounding box never grows
  kExtent,    // by at most the mesh's current extent on each axis
  kMeanEdge,  // by at most h, the input's mean edge length (boundary curves: a convex combination)
};

struct FlowRow {
  FlowId id;
  std::string_view name;  // JobSpec.flow and --flow
  FlowKind kind;
  double default_step;           // dimensionless, or relative to h^2 (kCurvature)
  double max_step;               // valid steps are (0, max_step]
  std::string_view description;  // one line, for ListFlows and --help
  std::string_view equations;    // where in the paper (docs/paper.md)
  // Parameters of this flow besides the step (which DescribeFlows() lists first).
  std::vector<ParameterInfo> parameters;
  // Constraints between parameters that their ranges cannot express, as ListFlows states them.
  std::vector<std::string> constraints;
  // Checks those constraints for a step already in range; null when there are none.
  absl::Status (*validate)(const FlowParams& p, double step);
  // The flow's kernel for valid parameters; `step` before the scaling by h^2.
  std::unique_ptr<flows::FlowKernel> (*make_kernel)(const FlowParams& p, double step);
  // What one of its passes that moves vertices may do (PassesPerIteration counts them, or more).
  PassReach reach;
};

// Every flow, in FlowId order.
const std::vector<FlowRow>& FlowTable();

// The row of `id`, which must be one of FlowId's enumerators.
const FlowRow& FlowOf(FlowId id);

// How many passes over the mesh one iteration of `p` (its flow set) makes: 1 for an umbrella
// or curvature flow, the filter passes plus the vertex passes for a normal-filtering one (what
// MortonOrderPaysOff weighs).
int PassesPerIteration(const FlowParams& p);

namespace flows {

// Each flow's row, defined in the flow's own file.
#define MESHSMOOTH_FLOW_ROW(id, name) FlowRow name##Row();
MESHSMOOTH_FLOWS(MESHSMOOTH_FLOW_ROW)
#undef MESHSMOOTH_FLOW_ROW

// Parameters that several rows share, for their `parameters`.
ParameterInfo WeightsParameter();                     // laplacian, taubin: U0 or U1
std::vector<ParameterInfo> NormalFilterParameters();  // the normal-filtering flows

}  // namespace flows
}  // namespace meshsmooth
