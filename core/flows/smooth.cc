// The driver shared by every flow: parameters, roles (free, fixed, boundary curve), the Jacobi
// double buffer, threads, eq. (14)'s threshold, stopping, progress and divergence checks.
#include <omp.h>

#include <chrono>
#include <cstdlib>
#include <cmath>
#include <limits>
#include <numeric>
#include <string_view>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/flows/flow.h"
#include "core/flows/kernel.h"
#include "core/flows/lane_batches.h"
#include "core/radix_sort.h"
#include "core/metrics.h"

namespace meshsmooth {
namespace {

using flows::BlockStats;
using flows::FlowKernel;
using flows::StepContext;

// Meshes smaller than this run on one thread: below it, waking threads costs more than the
// iteration (a 20k-vertex U0 iteration takes ~0.1 ms).
constexpr int32_t kParallelThreshold = 20000;

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

// Threads of a run's vertex loops: one below kParallelThreshold, else FlowParams::threads
// (0 = all hardware threads).
int ThreadsFor(int32_t n, const FlowParams& p) {
  return n < kParallelThreshold ? 1 : (p.threads > 0 ? p.threads : omp_get_max_threads());
}

bool IsCurvatureFlow(const std::string& flow) {
  return flow == "mcf" || flow == "mcf_tangential" || flow == "median";
}

double StepUpperBound(const std::string& flow) {
  if (flow == "bilaplacian") return 0.5;
  if (IsCurvatureFlow(flow)) return 10.0;
  return 1.0;
}

double TaubinMu(const FlowParams& p, double lambda) {
  return p.taubin_mu > 0.0 ? p.taubin_mu : 1.0 / (1.0 / lambda - p.taubin_pass_band);
}

absl::StatusOr<std::unique_ptr<FlowKernel>> MakeKernel(const FlowParams& p, double lambda, double mu) {
  if (p.flow == "laplacian") return flows::MakeLaplacian(p);
  if (p.flow == "taubin") return flows::MakeTaubin(p, lambda, mu);
  if (p.flow == "bilaplacian") return flows::MakeBilaplacian(p);
  if (p.flow == "mcf") return flows::MakeMcf(p);
  if (p.flow == "mcf_tangential") return flows::MakeMcfTangential(p);
  if (p.flow == "median") return flows::MakeMedian(p);
  return absl::InvalidArgumentError(absl::StrCat("unknown flow '", p.flow, "'"));
}

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

}  // namespace

namespace flows {

VectorIsa BestVectorIsa() {
  VectorIsa best = VectorIsa::kSse2;
  if (__builtin_cpu_supports("avx2")) best = VectorIsa::kAvx2;
  if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512dq")) {
    best = VectorIsa::kAvx512;
  }
  if (const char* want = std::getenv("MESHSMOOTH_VECTOR_ISA")) {  // never wider than the CPU
    const std::string w = want;
    if (w == "sse2") best = VectorIsa::kSse2;
    if (w == "avx2" && best == VectorIsa::kAvx512) best = VectorIsa::kAvx2;
  }
  return best;
}

}  // namespace flows

const std::vector<std::string>& FlowNames() {
  static const std::vector<std::string> kNames = {"laplacian", "taubin", "bilaplacian",
                                                  "mcf",       "mcf_tangential", "median"};
  return kNames;
}

double DefaultStep(const std::string& flow) {
  if (flow == "bilaplacian") return 0.2;
  if (IsCurvatureFlow(flow)) return 0.1;
  return 0.5;
}

absl::Status ValidateFlowParams(const FlowParams& p, int32_t num_vertices) {
  // The cotangent kernel addresses coordinates as int32 3 * vertex (kernel.h, MeanCurvatureLanes).
  if (num_vertices > std::numeric_limits<int32_t>::max() / 3) {
    return absl::InvalidArgumentError(absl::StrCat("the mesh has ", num_vertices, " vertices; at most ",
                                                   std::numeric_limits<int32_t>::max() / 3, " can be smoothed"));
  }
  const auto& names = FlowNames();
  if (std::find(names.begin(), names.end(), p.flow) == names.end()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "unknown flow '", p.flow, "' (laplacian, taubin, bilaplacian, mcf, mcf_tangential, median)"));
  }
  if (p.iterations < 1 || p.iterations > kMaxIterations) {
    return absl::InvalidArgumentError(
        absl::StrCat("iterations must be in 1..", kMaxIterations, ", got ", p.iterations));
  }
  const double step = p.step.value_or(DefaultStep(p.flow));
  const double upper = StepUpperBound(p.flow);
  if (!(step > 0.0) || !(step <= upper)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "step must be in (0, %g] for %s, got %g%s", upper, p.flow, step,
        IsCurvatureFlow(p.flow) ? " (relative to the squared mean edge length)" : ""));
  }
  if (p.flow == "taubin") {
    if (p.taubin_mu > 0.0) {
      if (!(p.taubin_mu > step) || !(p.taubin_mu <= 1.0)) {
        return absl::InvalidArgumentError(
            absl::StrFormat("taubin needs mu > lambda and mu <= 1 (lambda %g, mu %g)", step, p.taubin_mu));
      }
    } else if (!(p.taubin_pass_band > 0.0) || !(p.taubin_pass_band < 1.0 / step - 1.0)) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "taubin pass band k_PB must be in (0, 1/lambda - 1) = (0, %g) so that lambda < mu <= 1, got %g",
          1.0 / step - 1.0, p.taubin_pass_band));
    }
  }
  if (!std::isfinite(p.taubin_mu) || p.taubin_mu < 0.0) {
    return absl::InvalidArgumentError(absl::StrFormat("taubin mu must be >= 0 (0 = from the pass band), got %g", p.taubin_mu));
  }
  if (p.flow == "mcf_tangential" && (!(p.tangential_weight >= 0.0) || !(step * p.tangential_weight <= 1.0))) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "mcf_tangential needs C >= 0 and step * C <= 1 (the tangential umbrella step), got C %g, step %g",
        p.tangential_weight, step));
  }
  if (!(p.epsilon > 0.0) || !(p.epsilon < 1.0)) {
    return absl::InvalidArgumentError(absl::StrFormat("epsilon must be in (0, 1), got %g", p.epsilon));
  }
  if (p.adaptive == AdaptiveMode::kConstant && (!(p.adaptive_threshold >= 0.0) || !std::isfinite(p.adaptive_threshold))) {
    return absl::InvalidArgumentError(
        absl::StrFormat("the adaptive threshold T must be finite and >= 0, got %g", p.adaptive_threshold));
  }
  if (p.adaptive_recompute_every < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("the adaptive recompute interval must be >= 1, got ", p.adaptive_recompute_every));
  }
  if (!(p.tolerance >= 0.0) || !std::isfinite(p.tolerance)) {
    return absl::InvalidArgumentError(absl::StrFormat("tolerance must be finite and >= 0, got %g", p.tolerance));
  }
  if (!p.locked.empty() && p.locked.size() != static_cast<size_t>(num_vertices)) {
    return absl::InvalidArgumentError(absl::StrCat("the lock mask has ", p.locked.size(),
                                                   " entries for ", num_vertices, " vertices"));
  }
  if (p.threads < 0) return absl::InvalidArgumentError(absl::StrCat("threads must be >= 0, got ", p.threads));
  return absl::OkStatus();
}

absl::StatusOr<FlowResult> Smooth(Mesh& mesh, const FlowParams& p, const RunControl& control) {
  const Topology topo = BuildTopology(mesh);
  return Smooth(mesh, topo, p, control);
}

namespace {

// The iterations themselves, on a mesh whose vertices may have been reordered by Smooth().
absl::StatusOr<FlowResult> Run(Mesh& mesh, const Topology& topo, const FlowParams& p, const RunControl& control,
                               double h) {
  const int32_t n = mesh.num_vertices();
  BoundingBox box;
  int64_t non_finite = 0;
  for (int32_t v = 0; v < n; ++v) {
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
  const double diagonal = box.diagonal();

  FlowResult result;
  result.mean_edge_length = h;
  const double step = p.step.value_or(DefaultStep(p.flow));
  const bool curvature = IsCurvatureFlow(p.flow);
  const double lambda = curvature ? step * h * h : step;
  const double mu = p.flow == "taubin" ? TaubinMu(p, step) : 0.0;
  result.effective_step = lambda;
  result.effective_mu = mu;
  absl::StatusOr<std::unique_ptr<FlowKernel>> kernel = MakeKernel(p, step, mu);
  if (!kernel.ok()) return kernel.status();

  std::vector<uint8_t> role(n, flows::kFixed);
  int64_t movable = 0;
  for (int32_t v = 0; v < n; ++v) {
    if (!p.locked.empty() && p.locked[v] != 0) continue;
    if (topo.kind[v] == VertexKind::kInterior) {
      role[v] = flows::kFree;
    } else if (topo.kind[v] == VertexKind::kBoundary && p.boundary == BoundaryMode::kCurve) {
      role[v] = flows::kCurve;
    }
    movable += role[v] != flows::kFixed;
  }

  const int32_t blocks = (n + flows::kBlock - 1) / flows::kBlock;
  std::vector<uint8_t> all_free(blocks, 1);
  for (int32_t v = 0; v < n; ++v) {
    if (role[v] != flows::kFree) all_free[v / flows::kBlock] = 0;
  }

  const int threads = ThreadsFor(n, p);
  StepContext ctx;
  ctx.num_vertices = n;
  ctx.offsets = topo.ring_offsets.data();
  ctx.ring = topo.ring.data();
  ctx.role = role.data();
  ctx.all_free = all_free.data();
  ctx.kind = topo.kind.data();
  ctx.h = h;
  ctx.inv_h2 = 1.0 / (h * h);
  ctx.isa = flows::BestVectorIsa();
  if (curvature) ctx.max_step_sq = h * h;
  // The cotangent flows run their free vertices in batches (lane_batches.h);
  // MESHSMOOTH_LANE_BATCHES=0 makes them go vertex by vertex (for tests and measurements).
  flows::LaneBatches batches;
  const char* want_batches = std::getenv("MESHSMOOTH_LANE_BATCHES");
  if (curvature && (want_batches == nullptr || std::string_view(want_batches) != "0")) {
    batches = flows::BuildLaneBatches(topo, role.data(), flows::LaneWidthOf(ctx.isa), threads);
    if (!batches.data.empty()) ctx.batches = &batches;
  }
  // Curvature flows move a boundary curve like the curve-shortening flow with the same time
  // step (kappa ~ 2 U / h^2), capped at the stable umbrella step 0.5.
  const double curve_step = curvature ? std::min(2.0 * step, 0.5) : step;

  // Eq. (14): T in the flow's speed units (see FlowParams).
  std::vector<double> threshold;
  const double t_scale = p.adaptive == AdaptiveMode::kConstant ? (curvature ? 1.0 : h)
                                                               : (curvature ? 1.0 : 0.5 * h * h);
  if (p.adaptive == AdaptiveMode::kConstant) threshold.assign(n, p.adaptive_threshold * t_scale);

  // The positions move into `cur` for the run (no copy; the mesh gets them back on every return
  // below). `cur` keeps the iteration's start until the iteration is accepted; passes write
  // `next`, then alternate with `mid` (taubin: cur -> next -> mid), so measuring the
  // displacement of a whole iteration needs no copy of the start.
  std::vector<Vec3> cur = std::move(mesh.positions), next(n), mid;
  const int passes = (*kernel)->passes();
  if (passes > 1) mid.resize(n);
  std::vector<BlockStats> stats(blocks);
  const auto t0 = std::chrono::steady_clock::now();
  int capped_run = 0;  // consecutive iterations with more than kCappedSharePersistent capped

  for (int it = 1; it <= p.iterations; ++it) {
    if (control.cancel != nullptr && control.cancel->load(std::memory_order_relaxed)) {
      mesh.positions = std::move(cur);
      return absl::CancelledError(absl::StrCat("cancelled after ", it - 1, " iterations"));
    }
    if (p.adaptive == AdaptiveMode::kRing1 || p.adaptive == AdaptiveMode::kRing2) {
      if ((it - 1) % p.adaptive_recompute_every == 0) {
        flows::RingThresholds(ctx, cur.data(), n, p.adaptive == AdaptiveMode::kRing1 ? 1 : 2, threads, threshold);
        for (double& t : threshold) t *= t_scale;
      }
    }
    ctx.threshold = threshold.empty() ? nullptr : threshold.data();
    const Vec3* in = cur.data();
    std::vector<Vec3>* out = &next;
    for (int pass = 0; pass < passes; ++pass) {
      out = pass % 2 == 0 ? &next : &mid;
      const double factor = (*kernel)->pass_factor(pass);
      ctx.lambda = lambda * factor;
      ctx.curve_lambda = curve_step * factor;
      (*kernel)->Prepare(ctx, in, n, threads);
      const FlowKernel& k = **kernel;
      Vec3* const dst = out->data();
      flows::ForBlocks(n, threads, [&](int32_t b, int32_t begin, int32_t end) {
        stats[b] = k.Step(ctx, in, dst, begin, end);
      });
      in = dst;
    }
    const Vec3* const end_pos = in;
    if (passes > 1) {  // displacement over the whole iteration, not the last pass
      flows::ForBlocks(n, threads, [&](int32_t b, int32_t begin, int32_t end) {
        BlockStats s;
        for (int32_t v = begin; v < end; ++v) {
          if (role[v] == flows::kFixed) continue;
          const double d2 = SquaredNorm(end_pos[v] - cur[v]);
          s.max_sq = std::max(s.max_sq, d2);
          s.sum += std::sqrt(d2);
          s.moved += d2 > 0.0;
          ++s.movable;
          s.non_finite |= !IsFinite(end_pos[v]);
        }
        stats[b] = s;
      });
    }
    const BlockStats total = Reduce(stats);
    Progress progress;
    progress.iteration = it;
    progress.total = p.iterations;
    progress.max_displacement = std::sqrt(total.max_sq);
    progress.mean_displacement = movable > 0 ? total.sum / static_cast<double>(movable) : 0.0;
    progress.moved_share = movable > 0 ? static_cast<double>(total.moved) / static_cast<double>(movable) : 0.0;
    const double capped_share = movable > 0 ? static_cast<double>(total.capped) / static_cast<double>(movable) : 0.0;
    capped_run = capped_share > kCappedSharePersistent ? capped_run + 1 : 0;
    const bool too_many_capped = capped_share > kCappedShareAtOnce || capped_run >= kCappedPersistentIterations;
    if (total.non_finite || !(progress.max_displacement <= diagonal) || too_many_capped) {
      mesh.positions = std::move(cur);  // the last iteration before the failure
      return absl::FailedPreconditionError(absl::StrFormat(
          "%s diverged at iteration %d (%s); try a smaller step than %g", p.flow, it,
          total.non_finite ? "a coordinate became NaN or infinite"
          : too_many_capped
              ? absl::StrFormat("%d of %d vertices tried to move more than a mean edge length", total.capped, movable)
              : absl::StrFormat("a vertex moved %g, more than the mesh's size %g", progress.max_displacement, diagonal),
          step));
    }
    cur.swap(*out);  // the iteration is accepted
    result.iterations_run = it;
    result.last = progress;
    if (control.on_progress) control.on_progress(progress);
    if (p.tolerance > 0.0 && progress.max_displacement < p.tolerance * h) {
      result.stop_reason = StopReason::kTolerance;
      break;
    }
    if (control.time_budget_seconds > 0.0 &&
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() > control.time_budget_seconds) {
      result.stop_reason = StopReason::kTimeBudget;
      break;
    }
  }
  mesh.positions = std::move(cur);
  return result;
}

// Spreads the low 21 bits of x so that two zero bits follow each one (for Morton codes).
uint64_t Spread3(uint64_t x) {
  x &= 0x1fffff;
  x = (x | x << 32) & 0x1f00000000ffffULL;
  x = (x | x << 16) & 0x1f0000ff0000ffULL;
  x = (x | x << 8) & 0x100f00f00f00f00fULL;
  x = (x | x << 4) & 0x10c30c30c30c30c3ULL;
  x = (x | x << 2) & 0x1249249249249249ULL;
  return x;
}

// Reordering pays off once the positions outgrow the caches; below this it is skipped.
constexpr int32_t kReorderThreshold = 100000;
// Morton keys hold 25 bits of vertex index.
constexpr int32_t kReorderMaxVertices = 1 << 25;

// Sizes Smooth() may reorder: large enough to outgrow the caches, small enough for the keys.
bool ReorderableSize(int32_t n) { return n >= kReorderThreshold && n <= kReorderMaxVertices; }

// MortonOrderPaysOff(): neighbours further than kNearIndices from their vertex count as far;
// one in kLocalitySampleStride vertices is counted, in runs of kLocalitySampleRun consecutive
// ones (contiguous reads: single vertices measured 1.2-1.7 ms on the dragon). Shares of far
// neighbours measured: generated icospheres (the benchmark's meshes) 0.51, their Morton order
// 0.016-0.019, the Stanford dragon in file order 0.049.
constexpr int32_t kNearIndices = 4096;
constexpr int32_t kLocalitySampleStride = 32;
constexpr int32_t kLocalitySampleRun = 64;
// Up to this share an order is as local as a Morton order would make it.
constexpr double kLocalFarShare = 0.03;
// Reordering repays itself after about this many iterations divided by the share. Measured
// (laplacian U0, 2 threads) with half the neighbours far: after 12 iterations at 655k vertices
// and 7 at 2.6M (mcf: 18 at 655k); on the dragon after 140 in one hour and ~20 in another (the
// machine's memory was slower), so this is the middle: the dragon reorders from 52 iterations.
constexpr double kRepayingFarShareIterations = 2.5;

}  // namespace

// Keys pack a 39-bit Morton code (13 bits per axis) above a 25-bit vertex index and are
// sorted by three 13-bit LSD radix passes (RadixSortBits, stable: ties keep index order).
std::vector<int32_t> MortonOrder(const std::vector<Vec3>& pos, int threads) {
  const int32_t n = static_cast<int32_t>(pos.size());
  if (n > kReorderMaxVertices) {  // the keys have no room for the index: keep the order
    std::vector<int32_t> identity(n);
    std::iota(identity.begin(), identity.end(), 0);
    return identity;
  }
  BoundingBox box;
  for (const Vec3& q : pos) {
    if (IsFinite(q)) box.Add(q);
  }
  const Vec3 lo = box.lo;
  const double extent = std::max(box.max_extent(), 1e-300);
  const double scale = 8191.0 / extent;
  auto cell = [&](double v, double origin) {
    const double c = (v - origin) * scale;
    return static_cast<uint64_t>(std::clamp(std::isfinite(c) ? c : 0.0, 0.0, 8191.0));
  };
  std::vector<uint64_t> keys(n);
#pragma omp parallel for schedule(static) num_threads(threads)
  for (int32_t i = 0; i < n; ++i) {
    const uint64_t code = Spread3(cell(pos[i].x, lo.x)) | Spread3(cell(pos[i].y, lo.y)) << 1 |
                          Spread3(cell(pos[i].z, lo.z)) << 2;
    keys[i] = code << 25 | static_cast<uint64_t>(i);
  }
  const int chunks = threads > 1 && n >= kReorderThreshold ? threads : 1;
  RadixSortBits(keys, 25, 13, 3, chunks);
  std::vector<int32_t> order(n);
#pragma omp parallel for schedule(static) num_threads(chunks)
  for (int32_t i = 0; i < n; ++i) order[i] = static_cast<int32_t>(keys[i] & 0x1ffffff);
  return order;
}

bool MortonOrderPaysOff(const Topology& topo, int iterations) {
  const int32_t n = topo.num_vertices();
  if (!ReorderableSize(n)) return false;
  int64_t far = 0, sampled = 0;
  for (int32_t block = 0; block < n; block += kLocalitySampleStride * kLocalitySampleRun) {
    for (int32_t v = block; v < std::min(n, block + kLocalitySampleRun); ++v) {
      for (int32_t k = topo.ring_offsets[v]; k < topo.ring_offsets[v + 1]; ++k) {
        far += std::abs(topo.ring[k] - v) > kNearIndices;
      }
      sampled += topo.valence(v);
    }
  }
  if (sampled == 0) return false;
  const double share = static_cast<double>(far) / static_cast<double>(sampled);
  return share > kLocalFarShare && share * iterations >= kRepayingFarShareIterations;
}

// Validates, then runs the iterations, on a Morton-reordered copy for large meshes (undone on
// return, so indices stay stable). Each ring keeps its order and h is taken in the caller's
// order, so every vertex sums the same terms in the same order: reordering changes no position
// (only the summation order of the reported mean displacement).
absl::StatusOr<FlowResult> Smooth(Mesh& mesh, const Topology& topo, const FlowParams& p, const RunControl& control) {
  const int32_t n = mesh.num_vertices();
  if (absl::Status s = ValidateFlowParams(p, n); !s.ok()) return s;
  if (topo.num_vertices() != n) {
    return absl::InvalidArgumentError("the topology was built for another mesh");
  }
  // h from the caller's order: the same value whatever the internal order.
  const double h = MeanEdgeLength(mesh, topo);
  const bool reorder = p.reorder == ReorderMode::kAlways
                           ? ReorderableSize(n)
                           : p.reorder == ReorderMode::kAuto && MortonOrderPaysOff(topo, p.iterations);
  if (!reorder) return Run(mesh, topo, p, control, h);

  // A pure permutation, so it runs on the job's threads without changing a bit.
  const int threads = ThreadsFor(n, p);
  const std::vector<int32_t> order = MortonOrder(mesh.positions, threads);  // new -> old
  std::vector<int32_t> rank(n);                                    // old -> new
#pragma omp parallel for schedule(static) num_threads(threads)
  for (int32_t i = 0; i < n; ++i) rank[order[i]] = i;
  Mesh local;
  local.positions.resize(n);
  Topology t;
  t.kind.resize(n);
  t.ring_offsets.resize(static_cast<size_t>(n) + 1);
  t.ring.resize(topo.ring.size());
  FlowParams q = p;
  if (!p.locked.empty()) q.locked.resize(n);
  // The loops below read the caller's arrays in the new order, scattered: they prefetch what
  // vertex i + 16 reads and the ring of vertex i + 8 (whose offset is then in cache). At 655k
  // and 2.6M vertices in the icosphere's order the copy took 9-10 -> 5.5 ms and 39-40 -> 24 ms.
  constexpr int32_t kAhead = 16;
  t.ring_offsets[0] = 0;
  for (int32_t i = 0; i < n; ++i) {
    if (i + kAhead < n) __builtin_prefetch(&topo.ring_offsets[order[i + kAhead]]);
    t.ring_offsets[i + 1] = t.ring_offsets[i] + topo.valence(order[i]);
  }
#pragma omp parallel for schedule(static) num_threads(threads)
  for (int32_t i = 0; i < n; ++i) {
    if (i + kAhead < n) {
      __builtin_prefetch(&mesh.positions[order[i + kAhead]]);
      __builtin_prefetch(&topo.ring_offsets[order[i + kAhead]]);
    }
    if (i + kAhead / 2 < n) __builtin_prefetch(&topo.ring[topo.ring_offsets[order[i + kAhead / 2]]]);
    const int32_t old = order[i];
    local.positions[i] = mesh.positions[old];
    t.kind[i] = topo.kind[old];
    if (!p.locked.empty()) q.locked[i] = p.locked[old];
    int32_t out = t.ring_offsets[i];
    for (int32_t k = topo.ring_offsets[old]; k < topo.ring_offsets[old + 1]; ++k) t.ring[out++] = rank[topo.ring[k]];
  }
  absl::StatusOr<FlowResult> result = Run(local, t, q, control, h);
  // The positions as Run left them (the last good iteration on failure), in the caller's order.
#pragma omp parallel for schedule(static) num_threads(threads)
  for (int32_t i = 0; i < n; ++i) mesh.positions[order[i]] = local.positions[i];
  return result;
}

std::vector<Vec3> MeanCurvatureNormals(const Mesh& mesh, const Topology& topo) {
  StepContext ctx;
  ctx.offsets = topo.ring_offsets.data();
  ctx.ring = topo.ring.data();
  ctx.kind = topo.kind.data();
  std::vector<Vec3> hn(mesh.positions.size());
  for (int32_t v = 0; v < topo.num_vertices(); ++v) {
    if (topo.kind[v] == VertexKind::kInterior) hn[v] = flows::MeanCurvatureNormal(ctx, mesh.positions.data(), v).hn;
  }
  return hn;
}

}  // namespace meshsmooth
