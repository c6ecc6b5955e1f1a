// The flow table: one row per flow, the one place that knows the flows by name. A flow's name
// is resolved into a FlowId once, where a request enters (ParseFlowName); everything after
// that (validation, the kernel, ListFlows, the CLI's choices and help) reads the row.
// Adding a flow: an enumerator here, its row in flow_table.cc, its file and its tests
// (docs/development.md, "Adding a flow").
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/flows/flow_info.h"

namespace meshsmooth {

struct FlowParams;
namespace flows {
class FlowKernel;
}

// The flows, in the order ListFlows and the CLI list them.
enum class FlowId : uint8_t {
  kLaplacian,
  kTaubin,
  kBilaplacian,
  kMcf,
  kMcfTangential,
  kMedian,
  kBilateralNormal,
  kGuidedNormal,
};

// The flow of a job that names none: the benchmark's best on scans at its automatic stop
// (docs/quality.md, "How the defaults were chosen").
inline constexpr FlowId kDefaultFlow = FlowId::kBilaplacian;
// The flows a job that names none chooses from by their estimated error (FlowParams::choose_flow):
// bilaplacian is the best on scans, bilateral_normal on CAD parts and smooth shapes.
inline constexpr FlowId kChoiceFlows[] = {FlowId::kBilaplacian, FlowId::kBilateralNormal};
// Above this many vertices automatic stopping chooses the flow and the count on patches of the
// mesh, kSampleVertices vertices in all, and runs the whole mesh once, at that count: the
// candidates and their probes would cost several times the run itself (docs/quality.md).
inline constexpr int32_t kMaxChoiceVertices = 100000;
inline constexpr int32_t kSampleVertices = 20000;

// What a flow's step and speed are measured in, and which machinery the driver gives it.
enum class FlowKind : uint8_t {
  // Umbrella flows: a dimensionless step; the speed |U| is a length (eq. (14)'s T relative to h).
  kUmbrella,
  // Curvature flows: the step is relative to h^2 and the speed is a curvature (1/length); each
  // free vertex's step is capped at h, boundary curves move with min(2 step, 0.5), and the
  // cotangent kernel runs in lane batches (core/flows/lane_batches.h).
  kCurvature,
  // Normal-filtering flows: the face normals are filtered, then the vertices follow them. The
  // step (dimensionless, <= 1) scales each vertex update; a step is capped at h as for the
  // curvature flows; boundary vertices in BoundaryMode::kCurve take the same vertex update as
  // interior ones. They run on the mesh in its own order (they need its faces).
  kNormalFilter,
};

struct FlowRow {
  FlowId id;
  std::string_view name;  // JobSpec.flow and --flow
  FlowKind kind;
  double default_step;  // dimensionless, or relative to h^2 (kCurvature)
  double max_step;      // valid steps are (0, max_step]
  std::string_view description;  // one line, for ListFlows and --help
  std::string_view equations;     // where in the paper (docs/paper.md)
  // Parameters of this flow besides the step (which DescribeFlows() lists first).
  std::vector<ParameterInfo> parameters;
  // Constraints between parameters that their ranges cannot express, as ListFlows states them.
  std::vector<std::string> constraints;
  // Checks those constraints for a step already in range; null when there are none.
  absl::Status (*validate)(const FlowParams& p, double step);
  // The flow's kernel for valid parameters; `step` before the scaling by h^2.
  std::unique_ptr<flows::FlowKernel> (*make_kernel)(const FlowParams& p, double step);
};

// Every flow, in FlowId order.
const std::vector<FlowRow>& FlowTable();

// The row of `id`, which must be one of FlowId's enumerators.
const FlowRow& FlowOf(FlowId id);

// The flow called `name`, or InvalidArgument naming it and listing the flows.
absl::StatusOr<FlowId> ParseFlowName(std::string_view name);

// The flows' names, in FlowId order.
const std::vector<std::string>& FlowNames();

// The default step of a flow (dimensionless or relative to h^2, see FlowKind).
double DefaultStep(FlowId flow);

// How many passes over the mesh one iteration of `p` makes: 1 for an umbrella or curvature
// flow, the filter passes plus the vertex passes for a normal-filtering one (what
// MortonOrderPaysOff weighs).
int PassesPerIteration(const FlowParams& p);

}  // namespace meshsmooth
