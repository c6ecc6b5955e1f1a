#include "core/flows/driver.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/flows/chebyshev.h"
#include "core/flows/flow_kernel.h"
#include "core/flows/flow_table.h"
#include "core/flows/implicit.h"
#include "core/flows/lane_batches.h"
#include "core/flows/step_loops.h"
#include "core/measure/metrics.h"

namespace meshsmooth::flows {
namespace {

// Explicit curvature flows are only stable for lambda ~ (local edge)^2, and real scans hold
// needles and coincident vertices whose cotangent sums are huge. A free vertex of a curvature
// flow therefore moves at most one mean edge length h per pass: this touches only such
// degenerate places (a stable step moves a vertex ~0.01-0.5 h). When the step itself is too
// large, most vertices hit the cap: the run fails as diverging when more than half of the
// movable vertices are capped in one iteration, or more than 5% in 3 iterations running (the
// dirty beetle scan caps 7% in its first median iteration at the default step, then ~2%).
constexpr double kCappedShareAtOnce = 0.5;
constexpr double kCappedSharePersistent = 0.05;
constexpr int kCappedPersistentIterations = 3;
// A count chosen on a sample, of a linear flow (FlowKernel::LinearStepFloor), runs its first
// N - 1 iterations as one polynomial in the step (chebyshev.h), cut where the coefficients left
// sum to kChebyshevTail (the positions move by at most twice that times their size: 30,000
// times below a float's rounding, which the result is written with), when
// its kChebyshevTermCost-times-an-iteration terms cost less than the iterations.
constexpr double kChebyshevTail = 1e-12;
constexpr double kChebyshevTermCost = 1.25;

BlockStats Reduce(const std::vector<BlockStats>& blocks) {
  BlockStats total;
  for (const BlockStats& b : blocks) {
    total.max_sq = std::max(total.max_sq, b.max_sq);
    total.sum += b.sum;
    total.moved += b.moved;
    total.movable += b.movable;
    total.capped += b.capped;
    total.non_finite |= b.non_finite;
  }
  return total;
}

// The diagonal of the bounding box of the vertices in use, or InvalidArgument when one of
// them is not finite or the mesh has no edge to smooth.
absl::StatusOr<double> CheckInput(const Mesh& mesh, const Topology& topo, double h) {
  BoundingBox box;
  int64_t non_finite = 0;
  for (int32_t v = 0; v < mesh.num_vertices(); ++v) {
    if (topo.kind[v] == VertexKind::kIsolated) continue;
    const Vec3& q = mesh.positions[v];
    if (!IsFinite(q)) {
      ++non_finite;
      continue;
    }
    box.Add(q);
  }
  if (non_finite > 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("the mesh has ", non_finite, " vertices with NaN or infinite coordinates"));
  }
  if (!(h > 0.0) || !std::isfinite(h)) {
    return absl::InvalidArgumentError("the mesh has no edge of non-zero length to smooth");
  }
  return box.diagonal();
}

// One run of a flow: its set-up, then one call of Iterate() per iteration.
class FlowRun {
 public:
  FlowRun(const Topology& topo, const FlowParams& p, double h, double diagonal)
      : topo_(topo), p_(p), row_(FlowOf(*p.flow)), n_(topo.num_vertices()), h_(h), diagonal_(diagonal) {}

  // The step, the kernel (not yet bound), the roles and the threads: what an automatic run
  // needs to find it has nothing to do. Bind() does the rest.
  void SetUp(FlowResult& result) {
    curvature_ = row_.kind == FlowKind::kCurvature;
    step_ = p_.step.value_or(row_.default_step);
    lambda_ = curvature_ ? step_ * h_ * h_ : step_;
    kernel_ = row_.make_kernel(p_, step_);
    result.mean_edge_length = h_;
    result.effective_step = lambda_;
    result.effective_mu = kernel_->mu();
    AssignRoles();
    threads_ = ThreadsFor(n_, p_);
  }

  // The step context, lane batches, the kernel's own set-up on `mesh` (a normal filter's face
  // graph) and the constant threshold.
  void Bind(const Mesh& mesh) {
    MakeContext();
    kernel_->Bind(mesh, topo_, threads_);
    // Curvature flows move a boundary curve like the curve-shortening flow with the same time
    // step (kappa ~ 2 U / h^2), capped at the stable umbrella step 0.5.
    curve_step_ = curvature_ ? std::min(2.0 * step_, 0.5) : step_;
    // Eq. (14): T in the flow's speed units (see FlowParams).
    t_scale_ = p_.adaptive == AdaptiveMode::kConstant ? (curvature_ ? 1.0 : h_) : (curvature_ ? 1.0 : 0.5 * h_ * h_);
    if (p_.adaptive == AdaptiveMode::kConstant) threshold_.assign(n_, p_.adaptive_threshold * t_scale_);
    stats_.resize(blocks_);
    if (p_.integration == Integration::kImplicit) {
      implicit_ = std::make_unique<ImplicitStepper>(topo_, p_, role_.data(),
                                                    ImplicitWeights{p_.theta * lambda_, -lambda_}, h_, threads_);
    }
  }

  int passes() const { return kernel_->passes(); }
  const uint8_t* roles() const { return role_.data(); }
  // The kernel and its buffers (bilaplacian's field, a normal filter's face graph), once the
  // last iteration has run: what the run does after it needs only the roles.
  void Release() {
    kernel_.reset();
    implicit_.reset();
    batches_ = {};
    std::vector<double>().swap(threshold_);
  }
  int threads() const { return threads_; }

  // FlowParams::max_displacement: every iteration's last pass puts the movable vertices back
  // within `bound` of centre[v] (KeepWithinBound). `centre` outlives the run.
  void SetBound(const Vec3* centre, double bound) {
    centre_ = centre;
    bound_ = bound;
  }

  // The floor of the step's eigenvalues when it is linear (FlowKernel::LinearStepFloor): one
  // pass, no threshold, no cap on a vertex's move, no strength or bound, no boundary curve (its
  // umbrella is not covered by the floor).
  std::optional<double> LinearStepFloor() const {
    if (kernel_->passes() != 1 || p_.adaptive != AdaptiveMode::kNone || partial_ || bound_ > 0.0) return std::nullopt;
    if (implicit_) return std::nullopt;
    if (!std::isinf(ctx_.max_step_sq)) return std::nullopt;
    if (std::any_of(role_.begin(), role_.end(), [](uint8_t r) { return r == kCurve; })) return std::nullopt;
    return kernel_->LinearStepFloor(lambda_);
  }

  // One term of the Chebyshev recurrence (chebyshev.h) with M = (S - a) / b, S the step: with
  // `first`, w = M v (w's old values unused), else w = 2 M v - w; then y += c w (with `first`,
  // y = c0 v + c w). S v is written over w a block at a time, the block's old w kept aside.
  void ChebyshevTerm(const Vec3* v, Vec3* w, Vec3* y, const ChebyshevSeries& series, int k) {
    ctx_.lambda = lambda_;
    ctx_.threshold = nullptr;
    kernel_->Prepare(ctx_, v, n_, threads_);
    const FlowKernel& kernel = *kernel_;
    const bool first = k == 1;
    const double a = series.a, scale = (first ? 1.0 : 2.0) / series.b, c = series.c[k];
    const double c0 = series.c[0];
    ForBlocks(n_, threads_, [&](int32_t, int32_t begin, int32_t end) {
      thread_local std::vector<Vec3> kept;
      if (!first) kept.assign(w + begin, w + end);
      kernel.Step(ctx_, v, w, begin, end);
      for (int32_t i = begin; i < end; ++i) {
        Vec3 term = (w[i] - v[i] * a) * scale;
        if (!first) term -= kept[i - begin];
        w[i] = term;
        y[i] = first ? v[i] * c0 + term * c : y[i] + term * c;
      }
    });
  }

  // Iteration `it` from `cur` into `*out` (one of next / mid): its displacement statistics.
  BlockStats Iterate(int it, const std::vector<Vec3>& cur, std::vector<Vec3>& next, std::vector<Vec3>& mid,
                     std::vector<Vec3>*& out) {
    if (implicit_) return ImplicitIteration(it, cur, next, out);
    UpdateRingThresholds(it, cur);
    ctx_.threshold = threshold_.empty() ? nullptr : threshold_.data();
    const Vec3* in = cur.data();
    const int passes = kernel_->passes();
    for (int pass = 0; pass < passes; ++pass) {
      out = pass % 2 == 0 ? &next : &mid;
      const double factor = kernel_->pass_factor(pass);
      ctx_.lambda = lambda_ * factor;
      ctx_.curve_lambda = curve_step_ * factor;
      kernel_->Prepare(ctx_, in, n_, threads_);
      const FlowKernel& k = *kernel_;
      Vec3* const dst = out->data();
      ForBlocks(n_, threads_, [&](int32_t b, int32_t begin, int32_t end) {
        stats_[b] = k.Step(ctx_, in, dst, begin, end);
        if (partial_) ScaleMoves(in, dst, begin, end);
        // Once an iteration: taubin's second pass undoes the first's shrinking only from where
        // that left the vertices (docs/decisions.md, "A bound on displacement").
        if (bound_ > 0.0 && pass == passes - 1) KeepWithinBound(centre_, bound_, dst, begin, end, role_.data());
      });
      in = dst;
    }
    // Scaled and bounded moves are measured anew: the kernel's statistics are of its own moves.
    if (passes > 1 || partial_ || bound_ > 0.0) MeasureWholeIteration(cur.data(), in);
    return Reduce(stats_);
  }

  // The progress report of an iteration from its statistics.
  Progress ToProgress(int it, const BlockStats& total, int iterations) const {
    Progress progress;
    progress.flow = row_.id;
    progress.iteration = it;
    progress.total = iterations;
    progress.max_displacement = std::sqrt(total.max_sq);
    progress.mean_displacement = movable_ > 0 ? total.sum / static_cast<double>(movable_) : 0.0;
    progress.moved_share = movable_ > 0 ? static_cast<double>(total.moved) / static_cast<double>(movable_) : 0.0;
    return progress;
  }

  // FailedPrecondition when iteration `it` diverged (a non-finite coordinate, a vertex moved
  // further than the mesh's size, or too many vertices capped) or its implicit solve failed,
  // else OK.
  absl::Status CheckDivergence(int it, const BlockStats& total, const Progress& progress) {
    if (!solve_status_.ok()) {
      return absl::Status(solve_status_.code(),
                          absl::StrFormat("%s, implicit iteration %d: %s", row_.name, it, solve_status_.message()));
    }
    const double capped_share = movable_ > 0 ? static_cast<double>(total.capped) / static_cast<double>(movable_) : 0.0;
    capped_run_ = capped_share > kCappedSharePersistent ? capped_run_ + 1 : 0;
    const bool too_many_capped = capped_share > kCappedShareAtOnce || capped_run_ >= kCappedPersistentIterations;
    if (!total.non_finite && progress.max_displacement <= diagonal_ && !too_many_capped) return absl::OkStatus();
    return absl::FailedPreconditionError(absl::StrFormat(
        "%s diverged at iteration %d (%s); try a smaller step than %g", row_.name, it,
        total.non_finite ? "a coordinate became NaN or infinite"
        : too_many_capped
            ? absl::StrFormat("%d of %d vertices tried to move more than a mean edge length", total.capped, movable_)
            : absl::StrFormat("a vertex moved %g, more than the mesh's size %g", progress.max_displacement, diagonal_),
        step_));
  }

 private:
  // An implicit iteration (implicit.h): one solve, the strength inside it, then the bound. `next`
  // holds the positions before `cur` from the second iteration on (the driver's swap): CG starts
  // from that move.
  BlockStats ImplicitIteration(int it, const std::vector<Vec3>& cur, std::vector<Vec3>& next, std::vector<Vec3>*& out) {
    out = &next;
    solve_status_ = implicit_->Step(cur.data(), next.data(), it > 1);
    if (!solve_status_.ok()) return {};
    if (bound_ > 0.0) {
      ForBlocks(n_, threads_, [&](int32_t, int32_t begin, int32_t end) {
        KeepWithinBound(centre_, bound_, next.data(), begin, end, role_.data());
      });
    }
    MeasureWholeIteration(cur.data(), next.data());
    return Reduce(stats_);
  }

  // Free (interior), curve (boundary in BoundaryMode::kCurve) or fixed, and which blocks are
  // all free.
  void AssignRoles() {
    role_.assign(n_, kFixed);
    std::vector<uint8_t> small_hole;
    if (p_.boundary == BoundaryMode::kFixed && p_.small_hole_edges > 0) {
      small_hole = SmallHoleVertices(topo_, p_.small_hole_edges);
    }
    const bool strength = !p_.strength.empty();
    for (int32_t v = 0; v < n_; ++v) {
      if (!p_.locked.empty() && p_.locked[v] != 0) continue;
      if (strength && p_.strength[v] == 0.0f) continue;
      if (topo_.kind[v] == VertexKind::kInterior || (!small_hole.empty() && small_hole[v] != 0)) {
        role_[v] = kFree;
      } else if (topo_.kind[v] == VertexKind::kBoundary && p_.boundary == BoundaryMode::kCurve) {
        role_[v] = kCurve;
      }
      movable_ += role_[v] != kFixed;
      partial_ |= strength && role_[v] != kFixed && p_.strength[v] < 1.0f;
    }
    blocks_ = (n_ + kBlock - 1) / kBlock;
    all_free_.assign(blocks_, 1);
    for (int32_t v = 0; v < n_; ++v) {
      if (role_[v] != kFree) all_free_[v / kBlock] = 0;
    }
  }

  void MakeContext() {
    ctx_.num_vertices = n_;
    ctx_.offsets = topo_.ring_offsets.data();
    ctx_.ring = topo_.ring.data();
    ctx_.role = role_.data();
    ctx_.all_free = all_free_.data();
    ctx_.kind = topo_.kind.data();
    ctx_.h = h_;
    ctx_.inv_h2 = 1.0 / (h_ * h_);
    ctx_.isa = BestVectorIsa();
    if (row_.kind != FlowKind::kUmbrella) ctx_.max_step_sq = h_ * h_;
    // The cotangent flows run their free vertices in batches (lane_batches.h), unless the
    // kernel options say vertex by vertex.
    if (curvature_ && GetKernelOptions().lane_batches) {
      batches_ = BuildLaneBatches(topo_, role_.data(), LaneWidthOf(ctx_.isa), threads_);
      if (!batches_.data.empty()) ctx_.batches = &batches_;
    }
  }

  // Eq. (14)'s T(P), every K iterations from the first.
  void UpdateRingThresholds(int it, const std::vector<Vec3>& cur) {
    if (p_.adaptive != AdaptiveMode::kRing1 && p_.adaptive != AdaptiveMode::kRing2) return;
    if ((it - 1) % p_.adaptive_recompute_every != 0) return;
    RingThresholds(ctx_, cur.data(), n_, p_.adaptive == AdaptiveMode::kRing1 ? 1 : 2, threads_, threshold_);
    for (double& t : threshold_) t *= t_scale_;
  }

  // FlowParams::strength: a pass's move of each movable vertex of strength s < 1 in
  // [begin, end), from `in` to `out`, scaled by s. Strength 1 is left as the kernel wrote it.
  void ScaleMoves(const Vec3* in, Vec3* out, int32_t begin, int32_t end) const {
    const float* const strength = p_.strength.data();
    for (int32_t v = begin; v < end; ++v) {
      if (role_[v] == kFixed || strength[v] == 1.0f) continue;
      out[v] = in[v] + (out[v] - in[v]) * static_cast<double>(strength[v]);
    }
  }

  // The statistics of a several-pass iteration are of its whole displacement, not its last
  // pass's; so are those of scaled (ScaleMoves) and bounded (KeepWithinBound) moves, which keep
  // the count of capped moves.
  void MeasureWholeIteration(const Vec3* start, const Vec3* end_pos) {
    ForBlocks(n_, threads_, [&](int32_t b, int32_t begin, int32_t end) {
      BlockStats s;
      if (partial_ || bound_ > 0.0) s.capped = stats_[b].capped;
      for (int32_t v = begin; v < end; ++v) {
        if (role_[v] == kFixed) continue;
        const double d2 = SquaredNorm(end_pos[v] - start[v]);
        s.max_sq = std::max(s.max_sq, d2);
        s.sum += std::sqrt(d2);
        s.moved += d2 > 0.0;
        ++s.movable;
        s.non_finite |= !IsFinite(end_pos[v]);
      }
      stats_[b] = s;
    });
  }

  const Topology& topo_;
  const FlowParams& p_;
  const FlowRow& row_;
  const int32_t n_;
  const double h_, diagonal_;
  bool curvature_ = false;
  double step_ = 0.0, lambda_ = 0.0, curve_step_ = 0.0, t_scale_ = 1.0;
  std::unique_ptr<FlowKernel> kernel_;
  std::unique_ptr<ImplicitStepper> implicit_;  // FlowParams::integration kImplicit
  absl::Status solve_status_;                  // of the last implicit iteration
  std::vector<uint8_t> role_, all_free_;
  int64_t movable_ = 0;
  bool partial_ = false;          // some movable vertex has a strength below 1 (ScaleMoves)
  const Vec3* centre_ = nullptr;  // FlowParams::max_displacement's centres (SetBound)
  double bound_ = 0.0;            // its radius; 0 = none
  int32_t blocks_ = 0;
  int threads_ = 1;
  StepContext ctx_;
  LaneBatches batches_;
  std::vector<double> threshold_;
  std::vector<BlockStats> stats_;
  int capped_run_ = 0;  // consecutive iterations with more than kCappedSharePersistent capped
};

}  // namespace

int ThreadsFor(int32_t n, const FlowParams& p) {
  return n < kParallelThreshold ? 1 : (p.threads > 0 ? p.threads : omp_get_max_threads());
}

int64_t KeepWithinBound(const Vec3* centre, double bound, Vec3* pos, int32_t begin, int32_t end, const uint8_t* role) {
  const double bound_sq = bound * bound;
  int64_t moved = 0;
  for (int32_t v = begin; v < end; ++v) {
    if (role != nullptr && role[v] == kFixed) continue;
    const Vec3 offset = pos[v] - centre[v];
    const double d2 = SquaredNorm(offset);
    if (!(d2 > bound_sq)) continue;  // NaN too: the divergence check sees it
    pos[v] = centre[v] + offset * (bound / std::sqrt(d2));
    ++moved;
  }
  return moved;
}

absl::StatusOr<FlowResult> RunIterations(Mesh& mesh, const Topology& topo, const FlowParams& p,
                                         const RunControl& control, double h, const RunPlan& plan) {
  const absl::StatusOr<double> diagonal = CheckInput(mesh, topo, h);
  if (!diagonal.ok()) return diagonal.status();
  FlowResult result;
  result.flow = *p.flow;
  // The rule (null: none) and whether it is asked after every iteration, with a probe run.
  const bool automatic = p.iterations == kAutoIterations;
  StopRule* const rule = automatic ? plan.rule : nullptr;
  const bool watched = rule != nullptr && plan.fixed_iterations == 0;
  const bool probed = watched && rule->wants_probe();
  // A run and its probe share only the read-only topology: they iterate side by side, each on
  // one thread, when the run would take one thread anyway (below kParallelThreshold) or the job
  // has exactly two (the default job's samples of 20,000 vertices on two cores): no per-pass
  // wait between threads, and the bits do not depend on the thread count. With more threads a
  // large run keeps them all, the probe after it.
  const int threads = p.threads > 0 ? p.threads : omp_get_max_threads();
  const bool side_by_side = probed && threads >= 2 && (mesh.num_vertices() < kParallelThreshold || threads == 2);
  FlowParams run_params = p;
  if (side_by_side) run_params.threads = 1;
  FlowRun run(topo, run_params, h, *diagonal);
  run.SetUp(result);
  const uint8_t* const roles = run.roles();
  result.boundary = std::any_of(roles, roles + topo.num_vertices(), [](uint8_t r) { return r == kCurve; })
                        ? BoundaryMode::kCurve
                        : BoundaryMode::kFixed;

  // The positions move into `cur` for the run (no copy; the mesh gets them back on every return
  // below). `cur` keeps the iteration's start until the iteration is accepted; passes write
  // `next`, then alternate with `mid` (taubin: cur -> next -> mid), so measuring the
  // displacement of a whole iteration needs no copy of the start.
  int last_iteration = p.iterations;
  if (automatic) {
    last_iteration = std::min(p.max_auto_iterations, kMaxAutoIterations);
    if (plan.fixed_iterations > 0) last_iteration = std::min(last_iteration, plan.fixed_iterations);
    result.stop_reason = StopReason::kIterations;
  }
  if (rule != nullptr) {
    if (const std::optional<StopReason> idle = rule->Start(mesh, topo, roles, run.threads())) {
      result.stop_reason = *idle;
      rule->Finish(mesh.positions.data(), result);
      return result;
    }
  }
  // Bound only now: a clean mesh (nothing to do) skips a normal filter's face graph.
  run.Bind(mesh);
  const int32_t n = mesh.num_vertices();
  // FlowParams::max_displacement: the centres are the run's start unless the caller gives them.
  const double bound = DisplacementBound(p, h);
  std::vector<Vec3> own_centre;
  if (bound > 0.0 && p.bound_centre.empty()) own_centre = mesh.positions;
  const Vec3* const centre = p.bound_centre.empty() ? own_centre.data() : p.bound_centre.data();
  if (bound > 0.0) run.SetBound(centre, bound);
  std::vector<Vec3> cur = std::move(mesh.positions), next(n), mid;
  if (run.passes() > 1) mid.resize(n);
  // The probe runs the flow a second time, beside the first, from the rule's probe input; the
  // run keeps the rule's best iteration in `best` once it has passed it.
  Mesh probe_mesh;
  std::optional<FlowRun> probe;
  std::vector<Vec3> probe_next, probe_mid, best, probe_centre;
  if (probed) {
    probe_mesh.positions = rule->ProbeStart(cur);  // `cur`: the input still
    probe_mesh.triangles = mesh.triangles;
    probe.emplace(topo, run_params, h, *diagonal);
    FlowResult unused;
    probe->SetUp(unused);
    probe->Bind(probe_mesh);
    if (bound > 0.0) {  // the run's centres, moved as the probe's start is
      probe_centre.resize(n);
      for (int32_t v = 0; v < n; ++v) probe_centre[v] = probe_mesh.positions[v] + (centre[v] - cur[v]);
      probe->SetBound(probe_centre.data(), bound);
    }
    probe_next.resize(n);
    if (probe->passes() > 1) probe_mid.resize(n);
  }
  int first_iteration = 1;
  const bool chebyshev = GetKernelOptions().chebyshev;
  if (chebyshev && automatic && plan.fixed_iterations > 0 && last_iteration > 2) {
    if (const std::optional<double> floor = run.LinearStepFloor()) {
      const ChebyshevSeries series = ChebyshevOfPower(last_iteration - 1, *floor, kChebyshevTail);
      const int terms = static_cast<int>(series.c.size()) - 1;
      if (terms >= 1 && terms * kChebyshevTermCost < last_iteration - 1) {
        // The first N - 1 iterations at once, into `cur`; the last one then runs as any other,
        // with its statistics and checks. Progress counts the terms as shares of the N - 1.
        std::vector<Vec3> sum(n);
        // v: the newest term (the input before the first), w: the one before it.
        Vec3* v = cur.data();
        Vec3* w = next.data();
        for (int k = 1; k <= terms; ++k) {
          if (control.stop.Cancelled()) {
            mesh.positions = std::move(cur);
            return absl::CancelledError(
                absl::StrCat("cancelled while iterations 1 to ", last_iteration - 1, " ran as one polynomial"));
          }
          run.ChebyshevTerm(v, w, sum.data(), series, k);
          std::swap(v, w);
          // No move: the terms are no iterations (the proto's Progress).
          const int done = static_cast<int>(static_cast<int64_t>(last_iteration - 1) * k / terms);
          if (control.on_progress && done > 0) control.on_progress(run.ToProgress(done, BlockStats{}, last_iteration));
        }
        cur.swap(sum);
        result.iterations_run = last_iteration - 1;
        first_iteration = last_iteration;
      }
    }
  }
  for (int it = first_iteration; it <= last_iteration; ++it) {
    if (control.stop.Cancelled()) {
      mesh.positions = std::move(cur);
      return absl::CancelledError(absl::StrCat("cancelled after ", it - 1, " iterations"));
    }
    std::vector<Vec3>* out = &next;
    std::vector<Vec3>* probe_out = &probe_next;
    BlockStats total;
    if (side_by_side) {  // implies a probe: automatic, no count chosen beforehand
#pragma omp parallel sections num_threads(2)
      {
#pragma omp section
        total = run.Iterate(it, cur, next, mid, out);
#pragma omp section
        probe->Iterate(it, probe_mesh.positions, probe_next, probe_mid, probe_out);
      }
    } else {
      total = run.Iterate(it, cur, next, mid, out);
      if (probed) probe->Iterate(it, probe_mesh.positions, probe_next, probe_mid, probe_out);
    }
    const Progress progress = run.ToProgress(it, total, watched ? 0 : last_iteration);
    if (absl::Status s = run.CheckDivergence(it, total, progress); !s.ok()) {
      mesh.positions = std::move(cur);  // the last iteration before the failure
      return s;
    }
    cur.swap(*out);  // the iteration is accepted
    result.iterations_run = it;
    result.last = progress;
    if (control.on_progress) control.on_progress(progress);
    if (watched) {
      if (probed) probe_mesh.positions.swap(*probe_out);
      const std::optional<StopReason> stop =
          rule->After(it, cur.data(), probed ? probe_mesh.positions.data() : nullptr);
      // The best iteration is kept only once the run moves past it: while every iteration
      // improves, it is `cur` itself; the iteration after it finds it in *out, which the swap
      // above gave the positions `cur` held, and copies it before anything overwrites it.
      if (rule->best_iteration() == it - 1) best.assign(out->begin(), out->end());
      if (stop) {
        result.stop_reason = *stop;
        break;
      }
    }
    if (p.tolerance > 0.0 && progress.max_displacement < p.tolerance * h) {
      result.stop_reason = StopReason::kTolerance;
      break;
    }
    if (control.stop.PastDeadline()) {
      result.stop_reason = StopReason::kTimeBudget;
      break;
    }
  }
  if (watched && rule->best_iteration() > 0 && rule->best_iteration() < result.iterations_run) {
    cur.swap(best);
    result.iterations_run = rule->best_iteration();
  }
  // What follows (the rule's Finish) reads only `cur`: the run's other buffers go first, so that
  // its own buffers do not add to theirs at the job's peak.
  for (std::vector<Vec3>* buffer : {&next, &mid, &best, &probe_next, &probe_mid, &probe_centre, &own_centre}) {
    std::vector<Vec3>().swap(*buffer);
  }
  probe.reset();
  probe_mesh = Mesh();
  run.Release();
  if (rule != nullptr) rule->Finish(cur.data(), result);
  mesh.positions = std::move(cur);
  return result;
}

}  // namespace meshsmooth::flows
