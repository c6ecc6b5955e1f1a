// The smoothing flows behind one small interface: Smooth(mesh, params, control). The flows, their
// names, kinds and parameters are in the catalogue (core/flows/catalogue.h, ListFlows); equation
// numbers are the paper's, and docs/paper.md says where it slips and what we chose where it is
// silent.
//
// Every flow is an explicit Jacobi iteration: each iteration reads the old positions and
// writes new ones, so the result is bit-identical whatever the number of threads. laplacian,
// bilaplacian and mcf can also step implicitly (FlowParams::integration, core/flows/implicit.h):
// one sparse linear solve per iteration, stable for any step, also bit-identical for any number
// of threads.
//
// The front door is one rule: FlowParams{} (no flow, automatic iterations, no step) is the
// default job, the same as an empty JobSpec and `meshsmooth smooth IN -o OUT` (see
// FlowParams::flow).
//
// Units, by flow kind (FlowKind): umbrella flows take a dimensionless step; curvature flows take
// the step relative to the squared mean edge length h^2 of the input (effective lambda =
// step * h^2), so the same parameters work on a mesh in millimetres and in metres;
// normal-filtering flows take a dimensionless step <= 1. FlowResult reports the effective step.
// The adaptive threshold of eq. (14) wraps any flow (AdaptiveMode).
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "core/flows/catalogue.h"
#include "core/mesh.h"
#include "core/topology.h"
#include "core/util/stop_token.h"

namespace meshsmooth {

enum class UmbrellaWeights {
  kUniform,          // U0, eq. (3)
  kInverseDistance,  // U1, eq. (4)
};

enum class BoundaryMode {
  kFixed,  // boundary vertices do not move
  kCurve,  // boundary loops are smoothed as polygonal curves (1-D umbrella along the loop)
  // The default job (ChoosesFlow()): its boundary vertices take the normal filter's vertex
  // update when it tries or chooses bilateral_normal (kCurve for that flow: the planes of their
  // faces, so a rim loses its noise without its hole shrinking) and stay fixed with
  // bilaplacian (but for small holes' vertices: FlowParams::small_hole_edges), and the error
  // estimate counts them, so the choice sees the noise a fixed rim keeps. Any other job:
  // kFixed. The default.
  kAuto,
};

enum class AdaptiveMode {
  kNone,      // plain flow
  kConstant,  // eq. (14) with a constant T (in the flow's speed units, see below)
  kRing1,     // T(P) = mean |H| over the first ring of P
  kRing2,     // T(P) = mean |H| over the first and second rings of P
};

// Whether Smooth() runs a large mesh with its vertices renumbered into Morton order
// (MortonOrder()), undone on return. Positions are identical either way.
enum class ReorderMode {
  kAuto,    // when MortonOrderPaysOff(topology, iterations)
  kAlways,  // for every mesh of 100k .. 2^25 vertices (tests and measurements)
  kNever,
};

// The normal-filtering flows (FlowKind::kNormalFilter; docs/normal-filtering.md).
// One iteration of the job is one round: `normal_iterations` passes of the filter over the
// face normals, then `vertex_iterations` updates that move the vertices so that the faces fit
// the filtered normals.
struct NormalFilterParams {
  int normal_iterations = 1;  // 1 .. 100
  int vertex_iterations = 5;  // 1 .. 100
  // The spatial Gaussian's sigma, relative to the mean distance between the centroids of
  // faces that share an edge (measured once, on the input): scale-free.
  double sigma_spatial = 1.0;  // (0, 10]
  // The range Gaussian's sigma on |n_i - n_j| between unit normals (0 .. 2).
  double sigma_range = 0.35;  // (0, 2]
};

// How a run steps in time (FlowParams::integration; docs/paper.md, "Implicit steps").
enum class Integration {
  kExplicit,  // the paper's forward-Euler Jacobi iteration. The default.
  // One linear solve per iteration: (M/s + theta lambda K) d = -lambda K P, P <- P + d, with K
  // the flow's symmetric operator, M its diagonal and s the vertex's strength (flows that
  // HasImplicitForm). Stable for any step; theta 1 is backward Euler, 0.5 Crank-Nicolson.
  kImplicit,
};

// The linear solver of an implicit run (FlowParams::implicit_solver).
enum class ImplicitSolver {
  kAuto,    // kDirect up to kMaxDirectVertices free vertices, kCg above (docs/paper.md, "Implicit steps")
  kDirect,  // sparse LDL^T (Eigen's SimplicialLDLT), factored once where the matrix is constant
  kCg,      // Jacobi-preconditioned conjugate gradients, warm-started from the last step's move
};

// True for the flows with an implicit step (laplacian U0/U1, bilaplacian, mcf).
bool HasImplicitForm(FlowId id);

// An implicit step may be this large (the flow's units: dimensionless or relative to h^2).
inline constexpr double kMaxImplicitStep = 1e6;

inline constexpr int kMaxIterations = 100000;
inline constexpr int kAutoIterations = 0;
// Automatic stopping runs at most this many iterations (or the server's limit, if lower).
inline constexpr int kMaxAutoIterations = 1000;

struct FlowParams {
  // Unset: the job names no flow. With automatic iterations and no step it chooses: the input's
  // noise is estimated, the candidate flows each run to their least estimated error and the
  // least of them wins (core/job/choice.h; FlowResult::flow says which; on large meshes the
  // choice and the count are made on patches of the mesh). Otherwise unset is kDefaultFlow.
  std::optional<FlowId> flow;
  // 1 .. kMaxIterations, or kAutoIterations: estimate the input's noise (core/measure/noise.h)
  // and return the iteration whose estimated error to the noise-free surface is least (Stein's
  // unbiased risk estimate, core/job/rules.h; FlowResult says why the run stopped).
  int iterations = kAutoIterations;
  // The most iterations automatic stopping may run (1 .. kMaxAutoIterations; a server sets
  // its own limit here).
  int max_auto_iterations = kMaxAutoIterations;
  // The paper's lambda: dimensionless for the umbrella flows, relative to h^2 for the
  // curvature flows. Unset = the flow's default (DefaultStep); set, it must be > 0.
  std::optional<double> step;

  UmbrellaWeights weights = UmbrellaWeights::kUniform;  // umbrella flows that list it
  double taubin_mu = 0.0;                               // taubin: mu > lambda; 0 = derive from the pass band
  double taubin_pass_band = 0.1;                        // taubin: k_PB = 1/lambda - 1/mu (> 0), used when mu is 0
  double tangential_weight = 5.0;                       // mcf_tangential: C; the tangential term moves by step*C*U0t
  double epsilon = 0.1;                                 // median: eq. (13)'s epsilon, in (0, 1)
  NormalFilterParams normal_filter;                     // the normal-filtering flows

  // Eq. (14). The threshold compares with |F|. For kConstant, T is in the flow's speed units:
  // curvature (1/length) for the curvature flows, and for the umbrella flows length relative
  // to h (|U|/h). kRing1/kRing2 compute T(P) from |H| and, for the umbrella flows, convert it
  // with |U0| ~ h^2 |H| / 2 (a regular mesh's umbrella).
  AdaptiveMode adaptive = AdaptiveMode::kNone;
  double adaptive_threshold = 0.0;    // T for kConstant
  int adaptive_recompute_every = 10;  // K: T(P) is recomputed every K iterations

  BoundaryMode boundary = BoundaryMode::kAuto;
  // Under BoundaryMode::kFixed: the vertices of boundary loops of at most this many edges
  // (SmallHoleVertices) move as interior ones do, with their open fans; 0: none. The default
  // job sets it (kSmallHoleEdges) for the runs that keep their rims fixed.
  int32_t small_hole_edges = 0;
  // Optional per-vertex lock mask (non-zero = keep fixed); empty = none. Vertices on
  // non-manifold edges or vertices and isolated vertices are always fixed.
  std::vector<uint8_t> locked;
  // Optional per-vertex strength in [0, 1]; empty = 1 everywhere. 0 keeps the vertex where it
  // is (as `locked` does); a value between scales the vertex's move in every pass of an
  // iteration (for the normal-filtering flows, each vertex update), 1 is the flow as it is.
  // The default job also leaves the vertices of strength 0 out of its noise estimate and its
  // outlier and fold edits, and gives back no more folded faces than the input had
  // (core/job/default_job.cc).
  std::vector<float> strength;
  // A bound on displacement: no vertex ends farther than this from where the job found it
  // (mesh units); 0 = no bound. Every iteration of a run, once its passes are done (taubin's two,
  // a normal filter's vertex updates), puts a movable vertex that would leave the ball of this
  // radius around its start back onto the ball, along the line to the start, so the next
  // iteration goes on from a position within the bound and may slide along it. The default job also keeps its own edits
  // (outliers moved back, fold repair, volume) within the bound and gives back no more folded faces than the input had
  // (core/job/default_job.cc). FlowResult::displacement_bound reports the bound applied.
  double max_displacement = 0.0;
  // The same bound in mean edge lengths h of the input (0 = none); at most one of the two is set.
  double max_displacement_h = 0.0;
  // Where the bound is measured from, one position per vertex; empty = the positions the run
  // starts from. The default job sets it when it moved outliers before its runs.
  std::vector<Vec3> bound_centre;

  // Stop early when the largest displacement of an iteration falls below tolerance * h
  // (0 = run every iteration).
  double tolerance = 0.0;

  // Explicit (the default) or implicit steps (Integration). An implicit run takes any step in
  // (0, kMaxImplicitStep], fixed boundaries (kFixed or kAuto), no adaptive threshold, and a flow
  // that HasImplicitForm; a job that chooses its flow (no flow, automatic iterations, no step)
  // cannot be implicit.
  Integration integration = Integration::kExplicit;
  // Implicit: the weight of the new positions, in [0.5, 1]: 1 = backward Euler (first order,
  // damps every frequency), 0.5 = Crank-Nicolson (second order in the step).
  double theta = 1.0;
  ImplicitSolver implicit_solver = ImplicitSolver::kAuto;
  // Implicit, kCg: stop once every coordinate's residual is below this share of its right-hand
  // side, in (0, 0.1] (the bound on the move's error grows with the system's condition number).
  double cg_tolerance = 1e-8;

  int threads = 0;  // worker threads for the per-vertex loops; 0 = all hardware threads
  // Large meshes whose own vertex order leaves neighbours far apart in memory run renumbered
  // into Morton order, when the run is long enough to repay the renumbering (ReorderMode).
  ReorderMode reorder = ReorderMode::kAuto;
};

// What a run is doing when it reports progress. A job with automatic iterations reads the
// noise, chooses the flow (when none is named) and the count, on a sample of the mesh or on all
// of it, then runs the chosen flow at that count; the server then writes the result.
enum class Phase {
  kSmoothing,      // the chosen (or named) flow; `iteration` rises to `total`
  kNoiseEstimate,  // reading the input's noise
  kChoosing,       // trying `flow` to choose the flow and the count; no iteration numbers
  kWriting,        // encoding the result (reported by the server)
  kEnhancing,      // shape enhancement's solve (core/job/enhance.h)
};

// "smoothing", "noise estimate", "choosing the flow", "writing", "enhancing".
std::string_view PhaseName(Phase phase);

struct Progress {
  Phase phase = Phase::kSmoothing;
  FlowId flow = kDefaultFlow;      // the flow running (kSmoothing) or tried (kChoosing)
  int iteration = 0;               // 1-based, iterations done so far (kSmoothing)
  int total = 0;                   // the iterations the run will do: asked for, or chosen (automatic)
  double max_displacement = 0.0;   // largest |P_new - P_old| of this iteration (mesh units)
  double mean_displacement = 0.0;  // over the vertices that may move
  double moved_share = 0.0;        // share of movable vertices that moved (adaptive: < 1)
};

struct RunControl {
  // Called after every iteration, on the calling thread. The mesh's positions are held by the
  // run until Smooth() returns: do not read the mesh from here.
  std::function<void(const Progress&)> on_progress;
  // Checked every iteration: once cancelled the run ends with Cancelled; past its deadline the
  // run stops with StopReason::kTimeBudget and returns the last iteration. (Iterations run as
  // one polynomial, core/flows/chebyshev.h, check cancellation at every term and the deadline
  // once they are done.)
  StopToken stop;
};

enum class StopReason {
  kIterations,  // ran the iterations asked for (or automatic stopping's cap)
  kTolerance,   // the largest displacement fell below tolerance * h
  kTimeBudget,
  kNoiseRemoved,  // automatic: the vertices moved as far as the estimated noise
  kNoNoise,       // automatic: the input's noise is below what the estimate can tell from its shape
  kConverged,     // automatic: the flow stopped moving before it removed the estimated noise
  kNoEstimate,    // automatic: no noise estimate (too few fits, or a mesh all creases); nothing was done
  kNoGain,        // automatic: every candidate's run left the input rougher; the input came back
};

// "iterations", "tolerance", "time_budget", "noise_removed", "no_noise", "converged",
// "no_estimate", "no_gain".
std::string_view StopReasonName(StopReason reason);

// What automatic stopping measured (FlowParams::iterations == kAutoIterations).
struct AutoStopReport {
  double noise_sigma_h = 0.0;      // EstimateNoise() of the input, in h
  double noise_to_remove_h = 0.0;  // the part of it taken for noise (see driver.cc), in h
  double detail_free_h = 0.0;      // NoiseEstimate::detail_free_h of the input, in h
  double displacement_h = 0.0;     // RMS normal displacement from the input when it stopped, in h
  // The run's estimated mean squared error to the noise-free surface, a vertex, less the
  // noise's variance (core/job/rules.h): comparable between flows run on the same input, in h^2.
  double risk_h2 = 0.0;
};

struct FlowResult {
  FlowId flow = kDefaultFlow;  // the flow that ran (chosen when FlowParams::flow is unset)
  int iterations_run = 0;
  StopReason stop_reason = StopReason::kIterations;
  double effective_step = 0.0;    // lambda actually used (mesh units for the curvature flows)
  double effective_mu = 0.0;      // taubin's mu
  double mean_edge_length = 0.0;  // h of the input
  // kCurve when some boundary vertex moved with the run (BoundaryMode::kCurve on a mesh with a
  // boundary), else kFixed.
  BoundaryMode boundary = BoundaryMode::kFixed;
  // The default job's outliers moved onto their fitted surfaces before the run
  // (core/job/default_job.cc); 0 for any other job.
  int64_t outliers_moved = 0;
  // The bound on displacement applied (DisplacementBound), mesh units; 0 = none.
  double displacement_bound = 0.0;
  Progress last;
  std::optional<AutoStopReport> auto_stop;  // set when the run stopped automatically
};

// InvalidArgument with a message naming the parameter when `p` is out of range for `mesh`.
absl::Status ValidateFlowParams(const FlowParams& p, int32_t num_vertices);

// InvalidArgument naming the vertex unless `strength` is empty or holds one value in [0, 1]
// (not NaN) per vertex (FlowParams::strength).
absl::Status ValidateStrength(const std::vector<float>& strength, int32_t num_vertices);

// The bound on displacement of `p` in mesh units for an input of mean edge length h:
// max_displacement, or max_displacement_h * h; 0 = none.
double DisplacementBound(const FlowParams& p, double h);

// Runs the flow on `mesh` (positions change in place; connectivity never does).
// Errors: InvalidArgument for bad parameters or non-finite input coordinates; Cancelled when
// the cancel flag is set (the mesh holds the last completed iteration, except while a count
// chosen on a sample runs as one polynomial, core/flows/chebyshev.h: its positions are then
// no iteration's); FailedPrecondition,
// naming the iteration and suggesting a smaller step, when the flow diverges (the mesh holds
// the last iteration before it). `topo` is lent, not changed: a run in Morton order
// (FlowParams::reorder) renumbers it and the mesh's faces in place and gives both back exactly
// as they were (core/flows/reorder.h), so no copy of them is held beside the caller's.
absl::StatusOr<FlowResult> Smooth(Mesh& mesh, Topology& topo, const FlowParams& p, const RunControl& control = {});

// Same, building the topology itself.
absl::StatusOr<FlowResult> Smooth(Mesh& mesh, const FlowParams& p, const RunControl& control = {});

// Per-vertex mean-curvature normal H n (eq. 8 with the mixed Voronoi area, so |H| = 1/r on a
// sphere; points towards the centre of curvature). Zero for vertices that are not interior.
std::vector<Vec3> MeanCurvatureNormals(const Mesh& mesh, const Topology& topo);

}  // namespace meshsmooth
