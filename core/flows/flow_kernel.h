// What a flow author reads: the interface a flow implements (FlowKernel), what a step gets
// (StepContext), and the block loop. A flow file also defines the flow's row of the table
// (core/flows/flow_table.h): its name, kind, steps, parameters, checks and kernel factory. A flow file
// implements FlowKernel::Step with ApplyStep (a speed per vertex) or ApplyCurvatureStep (a
// speed from the cotangent kernel's lanes), both in core/flows/step_loops.h; the operators it
// can use (U0, U1, the mean-curvature normal) are in core/flows/operators.h.
// docs/development.md ("Adding a flow") lists the files a new flow touches.
#pragma once

#include <algorithm>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <vector>

#include "absl/status/status.h"
#include "core/flows/flow.h"
#include "core/flows/vector_isa.h"

namespace meshsmooth::flows {

struct LaneBatches;  // core/flows/lane_batches.h

// Loops over vertices run in fixed blocks of this many vertices (see ForBlocks).
inline constexpr int32_t kBlock = 4096;
static_assert(kBlock % 8 == 0, "blocks start at whole batches of the cotangent kernel");

// What a vertex does in an iteration.
enum Role : uint8_t {
  kFixed = 0,  // copies its position
  kFree = 1,   // interior vertex: moves by the flow
  kCurve = 2,  // boundary vertex in BoundaryMode::kCurve: 1-D umbrella along its loop
};

// Everything a step needs besides positions; built once per run.
struct StepContext {
  int32_t num_vertices = 0;          // size of the position arrays (0: StepRange prefetches nothing)
  const int32_t* offsets = nullptr;  // Topology::ring_offsets
  const int32_t* ring = nullptr;     // Topology::ring
  const uint8_t* role = nullptr;
  const uint8_t* all_free = nullptr;  // per block of kBlock vertices: 1 when every role is kFree
  const VertexKind* kind = nullptr;   // Topology::kind
  double lambda = 0.0;                // effective step of this pass (negative for taubin's mu pass)
  double curve_lambda = 0.0;          // step of the boundary-curve umbrella in this pass
  const double* threshold = nullptr;  // eq. (14): per-vertex T in the flow's speed units, or null
  double h = 1.0;                     // mean edge length of the input
  // Curvature flows: a free vertex moves at most this far (squared) in one pass; see smooth.cc.
  double max_step_sq = std::numeric_limits<double>::infinity();
  double inv_h2 = 1.0;               // 1 / h^2
  VectorIsa isa = VectorIsa::kSse2;  // see RunWithIsa
  // The cotangent kernel's batches of free vertices (core/flows/lane_batches.h), or null.
  const LaneBatches* batches = nullptr;
};

// Displacement statistics of one block of vertices; reduced in block order, so the totals do
// not depend on the number of threads.
struct BlockStats {
  double max_sq = 0.0;
  double sum = 0.0;
  int64_t moved = 0;
  int64_t movable = 0;
  int64_t capped = 0;  // vertices whose step was capped at max_step_sq
  bool non_finite = false;
};

// A block's statistics from its step loop's running sums. Non-finite results are caught here:
// a NaN or infinite position makes its step, hence the displacement sum, non-finite (the
// positions going in are finite).
inline BlockStats FinishBlock(double max_sq, double sum, int64_t moved, int64_t movable, int64_t capped) {
  BlockStats s;
  s.max_sq = max_sq;
  s.sum = sum;
  s.moved = moved;
  s.movable = movable;
  s.capped = capped;
  s.non_finite = !std::isfinite(sum);
  return s;
}

// True when every vertex of the kBlock block starting at `begin` is free.
inline bool AllFreeBlock(const StepContext& c, int32_t begin) {
  return c.all_free != nullptr && c.all_free[begin / kBlock];
}

// One flow: how one pass moves the vertices of a block. Flow files implement it; Smooth()
// calls Prepare once per pass, then Step on every block (possibly on several threads at once,
// so Step must not write the kernel's state).
class FlowKernel {
 public:
  virtual ~FlowKernel() = default;
  // Passes per iteration and each pass's step factor (taubin: 1 and -mu/lambda).
  virtual int passes() const { return 1; }
  virtual double pass_factor(int /*pass*/) const { return 1.0; }
  // Taubin's mu (the second pass's step), reported in FlowResult; 0 for one-pass flows.
  virtual double mu() const { return 0.0; }
  // Called once per run, before the first pass, with the mesh as it enters the run (flows
  // that work on faces take them here; the positions then move with each pass).
  virtual void Bind(const Mesh& /*mesh*/, const Topology& /*topo*/, int /*threads*/) {}
  // Work over all vertices before a pass's blocks (bilaplacian: U at every vertex).
  virtual void Prepare(const StepContext& /*c*/, const Vec3* /*cur*/, int32_t /*n*/, int /*threads*/) {}
  virtual BlockStats Step(const StepContext& c, const Vec3* cur, Vec3* next, int32_t begin, int32_t end) const = 0;
  // For a flow whose step at `lambda` is one fixed matrix S (linear in the positions, nothing
  // capped, on free and fixed vertices alone) with real eigenvalues: a floor of them (they lie in
  // [floor, 1]). N iterations may then run as one polynomial in S (chebyshev.h). Empty for the
  // others.
  virtual std::optional<double> LinearStepFloor(double /*lambda*/) const { return std::nullopt; }
};

// Eq. (14)'s T(P): mean |H| over the first ring (rings = 1) or the first and second rings
// (rings = 2) of every vertex, over interior neighbours only; written to `t`.
void RingThresholds(const StepContext& c, const Vec3* pos, int32_t n, int rings, int threads, std::vector<double>& t);

// Runs fn(block, begin, end) over [0, n) in fixed blocks of kBlock vertices on up to
// `threads` threads. Block boundaries do not depend on the thread count, so per-block results
// reduced in block order are deterministic.
template <typename Fn>
void ForBlocks(int32_t n, int threads, Fn&& fn) {
  const int32_t blocks = (n + kBlock - 1) / kBlock;
#pragma omp parallel for schedule(static) num_threads(threads) if (threads > 1 && blocks > 1)
  for (int32_t b = 0; b < blocks; ++b) fn(b, b * kBlock, std::min(n, (b + 1) * kBlock));
}

}  // namespace meshsmooth::flows