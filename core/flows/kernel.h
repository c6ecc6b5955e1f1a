// Internal to core/flows: the per-vertex operators and the fused Jacobi step shared by the
// flow files. Everything here is inline so each flow's vertex loop compiles into one tight
// loop (no virtual call, no allocation per vertex).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "core/flows/flow.h"

namespace meshsmooth::flows {

// Loops over vertices run in fixed blocks of this many vertices (see ForBlocks).
inline constexpr int32_t kBlock = 4096;

// The instruction set the arithmetic-bound loops are compiled for (RunWithIsa).
enum class VectorIsa : uint8_t { kSse2, kAvx2, kAvx512 };

// The widest this CPU has, or a narrower one named by MESHSMOOTH_VECTOR_ISA (sse2, avx2; for
// tests and measurements).
VectorIsa BestVectorIsa();

// What a vertex does in an iteration.
enum Role : uint8_t {
  kFixed = 0,  // copies its position
  kFree = 1,   // interior vertex: moves by the flow
  kCurve = 2,  // boundary vertex in BoundaryMode::kCurve: 1-D umbrella along its loop
};

// Everything a step needs besides positions; built once per run.
struct StepContext {
  const int32_t* offsets = nullptr;  // Topology::ring_offsets
  const int32_t* ring = nullptr;     // Topology::ring
  const uint8_t* role = nullptr;
  const uint8_t* all_free = nullptr;  // per block of kBlock vertices: 1 when every role is kFree
  const VertexKind* kind = nullptr;  // Topology::kind
  double lambda = 0.0;          // effective step of this pass (negative for taubin's mu pass)
  double curve_lambda = 0.0;    // step of the boundary-curve umbrella in this pass
  const double* threshold = nullptr;  // eq. (14): per-vertex T in the flow's speed units, or null
  double h = 1.0;               // mean edge length of the input
  // Curvature flows: a free vertex moves at most this far (squared) in one pass; see smooth.cc.
  double max_step_sq = std::numeric_limits<double>::infinity();
  double inv_h2 = 1.0;          // 1 / h^2
  VectorIsa isa = VectorIsa::kSse2;  // see RunWithIsa
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

// Cotangents of needle triangles are clamped to this magnitude (NOTES.md, degenerate places).
inline constexpr double kCotMax = 1e3;

// Two doubles in one SSE2 register (GCC vector extension): the arithmetic-bound loops below
// take two ring neighbours or two triangles at a time. SSE2 is the x86-64 baseline, so every
// build computes the same bits and nothing needs dispatching.
using Lanes = double __attribute__((vector_size(16)));

// U0, eq. (3). Two running sums halve the chain of dependent additions (the loads of the
// neighbours then overlap); the order is fixed, so results do not depend on threads.
inline Vec3 UmbrellaU0(const StepContext& c, const Vec3* pos, int32_t v) {
  const int32_t b = c.offsets[v], e = c.offsets[v + 1];
  Vec3 even, odd;
  int32_t i = b;
  for (; i + 1 < e; i += 2) {
    even += pos[c.ring[i]];
    odd += pos[c.ring[i + 1]];
  }
  if (i < e) even += pos[c.ring[i]];
  return (even + odd) * (1.0 / (e - b)) - pos[v];
}

// U1, eq. (4): weights 1/|P - Q|, with coincident neighbours given the weight of a 1e-9 h edge.
// Two neighbours at a time: one sqrtpd and one divpd per pair.
__attribute__((always_inline)) inline Vec3 UmbrellaU1(const StepContext& c, const Vec3* pos, int32_t v) {
  const int32_t b = c.offsets[v], e = c.offsets[v + 1];
  const Vec3 p = pos[v];
  const Lanes floor = Lanes{} + 1e-9 * c.h;
  Lanes sx{}, sy{}, sz{}, wsum{};
  for (int32_t i = b; i < e; i += 2) {
    const Vec3 d0 = pos[c.ring[i]] - p;
    const Vec3 d1 = i + 1 < e ? pos[c.ring[i + 1]] - p : Vec3{};
    const Lanes dx{d0.x, d1.x}, dy{d0.y, d1.y}, dz{d0.z, d1.z};
    const Lanes len = __builtin_ia32_maxpd(__builtin_ia32_sqrtpd(dx * dx + dy * dy + dz * dz), floor);
    const Lanes live{1.0, i + 1 < e ? 1.0 : 0.0};  // the padding lane weighs nothing
    const Lanes w = live / len;
    sx += dx * w, sy += dy * w, sz += dz * w;
    wsum += w;
  }
  return Vec3{sx[0] + sx[1], sy[0] + sy[1], sz[0] + sz[1]} * (1.0 / (wsum[0] + wsum[1]));
}

// The 1-D umbrella of a boundary vertex: midpoint of its two loop neighbours minus P.
inline Vec3 CurveUmbrella(const StepContext& c, const Vec3* pos, int32_t v) {
  return (pos[c.ring[c.offsets[v]]] + pos[c.ring[c.offsets[v + 1] - 1]]) * 0.5 - pos[v];
}

struct Curvature {
  Vec3 hn;      // mean-curvature normal H n: |hn| = H, pointing to the centre of curvature
  Vec3 normal;  // area-weighted face normal (not normalised; orientation of the ring)
  Vec3 u0;      // U0 of eq. (3), mean of Q_k - P, from the same pass over the ring
};

// Eq. (8) with the mixed Voronoi area of Meyer et al. in place of A/3 (NOTES.md): on a sphere
// of radius r, |H n| = 1/r. Zero-area triangles contribute nothing; cotangents are clamped.
// Only for interior vertices (closed ring). The ring's triangles (P, Q_{k-1}, Q_k) go two at
// a time through the lanes (the cotangent flows are arithmetic-bound: ~70 operations per
// triangle); a padding lane is a zero triangle and contributes nothing.
__attribute__((always_inline)) inline Curvature MeanCurvatureNormal(const StepContext& c, const Vec3* pos, int32_t v) {
  const int32_t b = c.offsets[v], e = c.offsets[v + 1], n = e - b;
  const Vec3 p = pos[v];
  const Lanes zero{}, one = zero + 1.0, cot_max = zero + kCotMax;
  Lanes sx{}, sy{}, sz{}, nx{}, ny{}, nz{}, ux{}, uy{}, uz{}, area{};
  Vec3 prev = pos[c.ring[e - 1]] - p;  // Q_{k-1} - P, wrapping around the closed ring
  for (int32_t k = 0; k < n; k += 2) {
    // Edges a = Q_{k-1} - P and q = Q_k - P of the two triangles.
    const Vec3 q0 = pos[c.ring[b + k]] - p;
    const Vec3 q1 = k + 1 < n ? pos[c.ring[b + k + 1]] - p : Vec3{};
    const Lanes ax{prev.x, q0.x}, ay{prev.y, q0.y}, az{prev.z, q0.z};
    const Lanes qx{q0.x, q1.x}, qy{q0.y, q1.y}, qz{q0.z, q1.z};
    prev = q1;
    ux += qx, uy += qy, uz += qz;
    const Lanes cx = ay * qz - az * qy, cy = az * qx - ax * qz, cz = ax * qy - ay * qx;
    nx += cx, ny += cy, nz += cz;
    const Lanes dbl_area = __builtin_ia32_sqrtpd(cx * cx + cy * cy + cz * cz);
    const Lanes la = ax * ax + ay * ay + az * az, lq = qx * qx + qy * qy + qz * qz;
    // Angle at Q_{k-1} is opposite edge P-Q_k, angle at Q_k opposite edge P-Q_{k-1}; with
    // d = q - a their dot products are -a.d = la - a.q and q.d = lq - a.q.
    const Lanes dot_p = ax * qx + ay * qy + az * qz, dot_a = la - dot_p, dot_q = lq - dot_p;
    const auto ok = dbl_area > 1e-12 * (la + lq);
    const Lanes inv = ok ? one / dbl_area : zero;  // a degenerate triangle gets cotangents 0
    const Lanes cot_a = __builtin_ia32_maxpd(__builtin_ia32_minpd(dot_a * inv, cot_max), -cot_max);
    const Lanes cot_q = __builtin_ia32_maxpd(__builtin_ia32_minpd(dot_q * inv, cot_max), -cot_max);
    sx += qx * cot_a + ax * cot_q, sy += qy * cot_a + ay * cot_q, sz += qz * cot_a + az * cot_q;
    // Voronoi region of a non-obtuse triangle, else half (obtuse at P) or a quarter of its area.
    const auto acute = (dot_p >= 0.0) & (dot_a >= 0.0) & (dot_q >= 0.0);
    const Lanes voronoi = (lq * cot_a + la * cot_q) * 0.125;
    const Lanes part = dbl_area * (dot_p < 0.0 ? zero + 0.25 : zero + 0.125);
    area += ok ? (acute ? voronoi : part) : zero;
  }
  Curvature k;
  k.normal = {nx[0] + nx[1], ny[0] + ny[1], nz[0] + nz[1]};
  k.u0 = Vec3{ux[0] + ux[1], uy[0] + uy[1], uz[0] + uz[1]} * (1.0 / n);
  const double total_area = area[0] + area[1];
  if (total_area > 0.0) k.hn = Vec3{sx[0] + sx[1], sy[0] + sy[1], sz[0] + sz[1]} * (0.25 / total_area);
  return k;
}

// Eq. (14): shortens F by T, or stops the vertex when |F| <= T.
inline Vec3 Threshold(const Vec3& f, double t) {
  const double len = Norm(f);
  return len > t ? f * ((len - t) / len) : Vec3{};
}

// The fused Jacobi step over vertices [begin, end): next = cur + lambda F for free vertices,
// the boundary-curve umbrella for curve vertices, a copy for fixed ones, with the block's
// displacement statistics. kAllFree: every vertex of the range is free (most blocks of a
// closed mesh), so the role branch goes. Non-finite results are caught once per block: a NaN
// or infinite position makes its step, hence the block's displacement sum, non-finite (the
// positions going in are finite).
template <bool kAllFree, typename SpeedFn>
__attribute__((always_inline)) inline BlockStats StepRange(const StepContext& c, const Vec3* cur, Vec3* next,
                                                           int32_t begin, int32_t end, SpeedFn&& speed) {
  // Locals, not c's fields or the returned struct: the stores to next[] could alias those
  // doubles, which would force a reload or store of each per vertex.
  const double lambda = c.lambda, curve_lambda = c.curve_lambda, max_step_sq = c.max_step_sq;
  const double* const threshold = c.threshold;
  const uint8_t* const role_of = c.role;
  double max_sq = 0.0, sum = 0.0;
  int64_t moved = 0, movable = 0, capped = 0;
  for (int32_t v = begin; v < end; ++v) {
    const uint8_t role = kAllFree ? uint8_t{kFree} : role_of[v];
    if (role == kFixed) {
      next[v] = cur[v];
      continue;
    }
    Vec3 step;
    if (role == kFree) {
      Vec3 f = speed(v);
      if (threshold != nullptr) f = Threshold(f, threshold[v]);
      step = f * lambda;
      const double len2 = SquaredNorm(step);
      if (len2 > max_step_sq) {
        step *= std::sqrt(max_step_sq / len2);
        ++capped;
      }
    } else {
      step = CurveUmbrella(c, cur, v) * curve_lambda;
    }
    next[v] = cur[v] + step;
    const double d2 = SquaredNorm(step);
    max_sq = std::max(max_sq, d2);
    sum += std::sqrt(d2);
    moved += d2 > 0.0;
    if (!kAllFree) ++movable;
  }
  BlockStats s;
  s.max_sq = max_sq;
  s.sum = sum;
  s.moved = moved;
  s.movable = kAllFree ? end - begin : movable;
  s.capped = capped;
  s.non_finite = !std::isfinite(sum);
  return s;
}

template <typename SpeedFn>
__attribute__((always_inline)) inline BlockStats ApplyStep(const StepContext& c, const Vec3* cur, Vec3* next,
                                                           int32_t begin, int32_t end, SpeedFn&& speed) {
  if (c.all_free != nullptr && c.all_free[begin / kBlock]) return StepRange<true>(c, cur, next, begin, end, speed);
  return StepRange<false>(c, cur, next, begin, end, speed);
}

// fn() compiled for `isa`. The code is the same SSE2 lane code in every case; compiled for
// AVX2 or AVX-512 it gets three-operand instructions and, with AVX-512VL, 32 registers instead
// of 16, which removes the cotangent kernel's spills (~15% faster, docs/performance.md). The
// entry points are flattened, so fn and everything it calls is compiled into them. No FMA is
// ever formed (core is built with -ffp-contract=off): the same bits whichever runs.
template <class Fn>
__attribute__((target("avx512f,avx512vl"), flatten)) BlockStats RunAvx512(const Fn& fn) {
  return fn();
}
template <class Fn>
__attribute__((target("avx2"), flatten)) BlockStats RunAvx2(const Fn& fn) {
  return fn();
}
template <class Fn>
__attribute__((always_inline)) inline BlockStats RunWithIsa(VectorIsa isa, const Fn& fn) {
  if (isa == VectorIsa::kAvx512) return RunAvx512(fn);
  if (isa == VectorIsa::kAvx2) return RunAvx2(fn);
  return fn();
}

// ApplyStep compiled for c.isa (RunWithIsa). `speed` should be always_inline: GCC's flatten
// stops at a lambda whose inlined body would grow the stack frame too much, and that lambda
// would then run as baseline code called from the wide entry point.
template <typename SpeedFn>
__attribute__((always_inline)) inline BlockStats ApplyStepWithIsa(const StepContext& c, const Vec3* cur, Vec3* next,
                                                                  int32_t begin, int32_t end, SpeedFn&& speed) {
  return RunWithIsa(c.isa, [&]() __attribute__((always_inline)) { return ApplyStep(c, cur, next, begin, end, speed); });
}

// One flow: how one pass moves the vertices of a block. Flow files implement it.
class FlowKernel {
 public:
  virtual ~FlowKernel() = default;
  // Passes per iteration and each pass's step factor (taubin: 1 and -mu/lambda).
  virtual int passes() const { return 1; }
  virtual double pass_factor(int /*pass*/) const { return 1.0; }
  // True for the curvature flows: step relative to h^2, speed in 1/length.
  virtual bool curvature_units() const = 0;
  // Work over all vertices before a pass's blocks (bilaplacian: U at every vertex).
  virtual void Prepare(const StepContext& /*c*/, const Vec3* /*cur*/, int32_t /*n*/, int /*threads*/) {}
  virtual BlockStats Step(const StepContext& c, const Vec3* cur, Vec3* next, int32_t begin, int32_t end) const = 0;
};

std::unique_ptr<FlowKernel> MakeLaplacian(const FlowParams& p);
std::unique_ptr<FlowKernel> MakeTaubin(const FlowParams& p, double lambda, double mu);
std::unique_ptr<FlowKernel> MakeBilaplacian(const FlowParams& p);
std::unique_ptr<FlowKernel> MakeMcf(const FlowParams& p);
std::unique_ptr<FlowKernel> MakeMcfTangential(const FlowParams& p);
std::unique_ptr<FlowKernel> MakeMedian(const FlowParams& p);

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
