// The flow catalogue: which flows there are, their names, kinds and parameters with defaults
// and valid ranges. The one source for the service's ListFlows, the CLI's choices and help, the
// fuzzers' seeds and bounds. A name is resolved into a FlowId once, where a request enters
// (ParseFlowName). How a flow runs (its kernel and checks) is internal to core/flows
// (flow_table.h).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"

namespace meshsmooth {

// Every flow, in the order ListFlows and the CLI list them: X(enumerator, Name), where Name's
// own file (core/flows/<name>.cc) defines flows::NameRow(), the flow's row of the table. Adding a
// flow adds one line here (docs/development.md, "Adding a flow").
#define MESHSMOOTH_FLOWS(X)            \
  X(kLaplacian, Laplacian)             \
  X(kTaubin, Taubin)                   \
  X(kBilaplacian, Bilaplacian)         \
  X(kMcf, Mcf)                         \
  X(kMcfTangential, McfTangential)     \
  X(kMedian, Median)                   \
  X(kBilateralNormal, BilateralNormal) \
  X(kGuidedNormal, GuidedNormal)

enum class FlowId : uint8_t {
#define MESHSMOOTH_FLOW_ENUMERATOR(id, name) id,
  MESHSMOOTH_FLOWS(MESHSMOOTH_FLOW_ENUMERATOR)
#undef MESHSMOOTH_FLOW_ENUMERATOR
};

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

// The flow of a job that names none but gives an iteration count or a step: the benchmark's
// best on scans (docs/quality-method.md). A job that names none and gives neither chooses
// (FlowParams::flow).
inline constexpr FlowId kDefaultFlow = FlowId::kBilaplacian;
// The candidates of a job that chooses, by their estimated error: bilaplacian is the best on
// scans, bilateral_normal on CAD parts and smooth shapes (docs/quality-method.md).
inline constexpr FlowId kChoiceFlows[] = {FlowId::kBilaplacian, FlowId::kBilateralNormal};
// The default job's umbrella runs keep their rims fixed but move the vertices of holes at most
// this many edges around as interior ones (FlowParams::small_hole_edges): such a hole (one to
// three missing triangles: a decimated scan has hundreds) is a gap in the sampling, and its
// fixed noisy vertices fold the faces around them. On `dragon-8k` (407 holes, 383 of them 3-5
// edges) at sigma = 0.2 h: 312 -> 183 flipped faces, RMS 0.102 -> 0.090 h. A hole of 6 edges or
// more may be a rim of the shape (a coarse round hole): freeing the perforated sphere's 6- and
// 8-edge holes made the error estimate prefer bilaplacian at sigma = 0.7 h and its result 2.4
// times as far from the surface; docs/decisions.md.
inline constexpr int32_t kSmallHoleEdges = 5;
// Above this many vertices automatic iterations choose the flow and the count on patches of the
// mesh and run the whole mesh once, at that count: the candidates and their probes on the whole
// mesh would cost several times the run itself.
inline constexpr int32_t kMaxChoiceVertices = 15000;

// "bilaplacian and bilateral_normal": the candidates' names, for help texts.
std::string ChoiceFlowNames();

struct ParameterInfo {
  std::string name;  // the JobSpec field
  std::string description;
  double default_value = 0.0;
  double min_value = 0.0;
  double max_value = 0.0;
  bool min_exclusive = false;
  bool max_exclusive = false;
  std::vector<std::string> choices;  // for enumerations
};

struct FlowInfo {
  std::string name;
  std::string description;
  std::string equations;
  std::vector<ParameterInfo> parameters;  // flow-specific, step first
  std::vector<std::string> constraints;   // between parameters, beyond their ranges
};

// The flow's name (JobSpec.flow, --flow); `id` must be one of FlowId's enumerators.
std::string_view FlowName(FlowId id);

// The flow's kind.
FlowKind KindOf(FlowId id);

// The flow's default step: dimensionless, or relative to h^2 for FlowKind::kCurvature.
double DefaultStep(FlowId id);

// The flow called `name`, or InvalidArgument naming it and listing the flows.
absl::StatusOr<FlowId> ParseFlowName(std::string_view name);

// The flows' names, in FlowId order.
const std::vector<std::string>& FlowNames();

// Every flow, in FlowId order, with its parameters (the step first).
std::vector<FlowInfo> DescribeFlows();

// Parameters every flow takes: iterations, adaptive mode/threshold/interval, boundary,
// tolerance. `max_iterations` is the caller's limit.
std::vector<ParameterInfo> CommonParameters(int max_iterations);

}  // namespace meshsmooth
