// Internal to core/flows: the fused Jacobi step loops a flow's Step runs (ApplyStep for a
// speed per vertex, ApplyCurvatureStep for the cotangent flows' lanes), with their
// instruction-set dispatch (RunWithIsa).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <type_traits>

#include "core/flows/flow_kernel.h"
#include "core/flows/lane_batches.h"
#include "core/flows/lanes.h"
#include "core/flows/operators.h"

namespace meshsmooth::flows {

// The speed of a cotangent flow at vertex v, for StepRange: F = finish(CurvatureLanes<V>), a
// function of lanes like MeanCurvatureLanes (so its divisions and selects run W vertices at a
// time, without a branch per vertex), computed W vertices at a time. StepRange asks for
// increasing v, so one batch serves the next W vertices.
template <int W, typename FinishFn>
class CurvatureSpeed {
 public:
  CurvatureSpeed(const StepContext& c, const Vec3* pos, int32_t begin, int32_t end, FinishFn& finish)
      : c_(c), pos_(pos), end_(end), first_(begin - W), finish_(finish) {}
  __attribute__((always_inline)) Vec3 operator()(int32_t v) {
    if (v - first_ >= W) {
      first_ = v;
      PrefetchRingsAhead(c_, pos_, v, W, end_);
      const int32_t count = std::min<int32_t>(W, end_ - v);
      // Whole-register stores, read back per vertex: taking lanes out one by one lets GCC
      // turn finish's selects into one branch per lane.
      const auto f = finish_(MeanCurvatureLanes<W>(c_, pos_, v, count));
      std::memcpy(x_, &f.x, sizeof(x_));
      std::memcpy(y_, &f.y, sizeof(y_));
      std::memcpy(z_, &f.z, sizeof(z_));
    }
    const int32_t l = v - first_;
    return {x_[l], y_[l], z_[l]};
  }

 private:
  const StepContext& c_;
  const Vec3* pos_;
  int32_t end_, first_;
  FinishFn& finish_;
  alignas(8 * W) double x_[W], y_[W], z_[W];
};

// Eq. (14): shortens F by T, or stops the vertex when |F| <= T.
inline Vec3 Threshold(const Vec3& f, double t) {
  const double len = Norm(f);
  return len > t ? f * ((len - t) / len) : Vec3{};
}

// Loops reading positions at the neighbours of each vertex (StepRange, bilaplacian's U0 field)
// prefetch the positions this many vertices ahead of the one they compute. In Morton
// order most neighbours lie within a few thousand vertices of a vertex, on either side; those
// behind were read recently, those ahead are not yet in cache and the hardware prefetcher
// (which follows the sequential stream only a few lines ahead) does not fetch them. 4096 is
// the best distance measured (docs/decisions.md, "Speed").
inline constexpr int32_t kPositionPrefetchAhead = 4096;

// Called for every vertex v of a loop over [0, n) reading pos at v's neighbours: one prefetch
// of 8 positions (192 bytes, three cache lines) every 8 vertices.
__attribute__((always_inline)) inline void PrefetchPositionsAhead(const Vec3* pos, int32_t v, int32_t n) {
  if ((v & 7) == 0 && v < n - kPositionPrefetchAhead - 8) {
    const char* ahead = reinterpret_cast<const char*>(pos + v + kPositionPrefetchAhead);
    __builtin_prefetch(ahead);
    __builtin_prefetch(ahead + 64);
    __builtin_prefetch(ahead + 128);
  }
}

// The fused Jacobi step over vertices [begin, end): next = cur + lambda F for free vertices,
// the boundary-curve umbrella for curve vertices, a copy for fixed ones, with the block's
// displacement statistics. kAllFree: every vertex of the range is free (most blocks of a
// closed mesh), so the role branch goes. Non-finite results are caught once per block
// (FinishBlock).
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
  // The lengths of the steps are summed in vertex order, but square-rooted two at a time (one
  // sqrtpd instead of two sqrtsd: the same bits). `held` is the squared length waiting for its
  // pair, or negative.
  double held = -1.0;
  const int32_t n = c.num_vertices;
  for (int32_t v = begin; v < end; ++v) {
    PrefetchPositionsAhead(cur, v, n);
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
    if (held < 0.0) {
      held = d2;
    } else {
      const Lanes root = __builtin_ia32_sqrtpd(Lanes{held, d2});
      sum += root[0];
      sum += root[1];
      held = -1.0;
    }
    moved += d2 > 0.0;
    if (!kAllFree) ++movable;
  }
  if (held >= 0.0) sum += std::sqrt(held);
  return FinishBlock(max_sq, sum, moved, kAllFree ? end - begin : movable, capped);
}

template <typename SpeedFn>
__attribute__((always_inline)) inline BlockStats ApplyStep(const StepContext& c, const Vec3* cur, Vec3* next,
                                                           int32_t begin, int32_t end, SpeedFn&& speed) {
  if (AllFreeBlock(c, begin)) return StepRange<true>(c, cur, next, begin, end, speed);
  return StepRange<false>(c, cur, next, begin, end, speed);
}

// fn(width) compiled for `isa`, with width a std::integral_constant<int, W>: the number of
// doubles in one register of that instruction set (2 for the SSE2 baseline, 4 for AVX2, 8 for
// AVX-512). The entry points are flattened, so fn and everything it calls is compiled into
// them. No FMA is ever formed (core is built with -ffp-contract=off), and the cotangent kernel
// computes each vertex in its own lane: the same bits whichever runs.
template <int W>
using LaneWidth = std::integral_constant<int, W>;
template <class Fn>
__attribute__((target("avx512f,avx512vl,avx512dq"), flatten)) BlockStats RunAvx512(const Fn& fn) {
  return fn(LaneWidth<8>{});
}
template <class Fn>
__attribute__((target("avx2"), flatten)) BlockStats RunAvx2(const Fn& fn) {
  return fn(LaneWidth<4>{});
}
template <class Fn>
__attribute__((always_inline)) inline BlockStats RunWithIsa(VectorIsa isa, const Fn& fn) {
#if MESHSMOOTH_WIDE_LANES
  if (isa == VectorIsa::kAvx512) return RunAvx512(fn);
  if (isa == VectorIsa::kAvx2) return RunAvx2(fn);
#else
  (void)isa;
#endif
  return fn(LaneWidth<2>{});
}

// The W that RunWithIsa passes for `isa` (the cotangent kernel's lanes).
inline int LaneWidthOf(VectorIsa isa) { return isa == VectorIsa::kAvx512 ? 8 : isa == VectorIsa::kAvx2 ? 4 : 2; }

// StepRange for a cotangent flow, over the block's batches of free vertices
// (c.batches, BuildLaneBatches; W = its width): the speed, the step, its cap and the
// displacement statistics in lanes, stored per vertex; then one loop over the block in vertex
// order copies the fixed vertices, moves the curve vertices and adds the statistics. Per
// vertex the operations are those of StepRange (the cap as a factor min(1, sqrt(max / len2)),
// which is 1 exactly when the step is not capped), in the same order, so the bits are too.
// kAllFree: every vertex of the block is free (no role to look at). Through CurvatureSpeed, the
// per-vertex step around the kernel costs about as much again as the kernel; blocks with a
// few boundary vertices (common in scans) therefore take this path too.
template <int W, bool kAllFree, typename FinishFn>
__attribute__((always_inline)) inline BlockStats CurvatureStepLanes(const StepContext& c, const Vec3* cur, Vec3* next,
                                                                    int32_t begin, int32_t end, FinishFn& finish) {
  using V = typename VertexLanesOf<W>::type;
  const double lambda = c.lambda, curve_lambda = c.curve_lambda, max_step_sq = c.max_step_sq;
  const uint8_t* const role_of = c.role;
  const int32_t n = c.num_vertices;
  const double* const threshold = c.threshold;
  const V zero{}, one = zero + 1.0, max_sq_lanes = zero + max_step_sq;
  const LaneBatches& lanes = *c.batches;
  const int32_t block = begin / kBlock, first_batch = lanes.block_first[block],
                last_batch = lanes.block_first[block + 1];
  // Per vertex of the block (offset from begin): a free vertex's squared step, its length and
  // whether it was capped.
  alignas(64) double d2_at[kBlock], root_at[kBlock];
  alignas(64) uint8_t capped_at[kBlock];
  alignas(8 * W) double sx[W], sy[W], sz[W], len2_of[W], d2_of[W], root_of[W];
  for (int32_t j = first_batch; j < last_batch; ++j) {
    // The batches run through the block's vertices out of order: prefetch as if in order.
    PrefetchPositionsAhead(cur, begin + (j - first_batch) * W, n);
    if (j + kBatchPrefetchAhead < last_batch) PrefetchBatchRing(lanes, cur, j + kBatchPrefetchAhead);
    const int32_t* const rows = &lanes.data[lanes.offsets[j]];
    const auto f = finish(MeanCurvatureLanes<W, true>(c, cur, 0, W, rows));
    V fx = f.x, fy = f.y, fz = f.z;
    if (threshold != nullptr) {  // eq. (14) as Threshold(), lane by lane
      typename IndexLanesOf<W>::type self;
      std::memcpy(&self, rows, sizeof self);
      const V t = GatherLanes<W>(threshold, self);
      const V len = LaneSqrt(fx * fx + fy * fy + fz * fz);
      const V shorten = (len - t) / len;
      const auto keep = t < len;
      fx = keep ? fx * shorten : zero, fy = keep ? fy * shorten : zero, fz = keep ? fz * shorten : zero;
    }
    V x = fx * lambda, y = fy * lambda, z = fz * lambda;
    const V len2 = x * x + y * y + z * z;
    V d2 = len2;
    // The factor is 1 in every lane whose len2 <= max_step_sq (or NaN): x * 1 == x and d2 ==
    // len2, so the division and square root are skipped unless some lane is capped (rare).
    if (AnyLaneLess(max_sq_lanes, len2)) {
      V factor = LaneSqrt(max_sq_lanes / len2);
      factor = factor < one ? factor : one;
      x = x * factor, y = y * factor, z = z * factor;
      d2 = x * x + y * y + z * z;
    }
    const V root = LaneSqrt(d2);
    std::memcpy(sx, &x, sizeof sx);
    std::memcpy(sy, &y, sizeof sy);
    std::memcpy(sz, &z, sizeof sz);
    std::memcpy(len2_of, &len2, sizeof len2_of);
    std::memcpy(d2_of, &d2, sizeof d2_of);
    std::memcpy(root_of, &root, sizeof root_of);
    for (int32_t l = 0, count = lanes.lanes[j]; l < count; ++l) {
      const int32_t v = rows[l], at = v - begin;
      next[v] = cur[v] + Vec3{sx[l], sy[l], sz[l]};
      d2_at[at] = d2_of[l];
      root_at[at] = root_of[l];
      capped_at[at] = len2_of[l] > max_step_sq;
    }
  }
  double max_sq = 0.0, sum = 0.0;
  int64_t moved = 0, movable = 0, capped = 0;
  for (int32_t v = begin; v < end; ++v) {  // StepRange's roles and statistics, in vertex order
    const int32_t at = v - begin;
    const uint8_t role = kAllFree ? uint8_t{kFree} : role_of[v];
    double d2;
    if (role == kFree) {
      d2 = d2_at[at];
      sum += root_at[at];
      capped += capped_at[at];
    } else if (role == kFixed) {
      next[v] = cur[v];
      continue;
    } else {
      const Vec3 step = CurveUmbrella(c, cur, v) * curve_lambda;
      next[v] = cur[v] + step;
      d2 = SquaredNorm(step);
      sum += std::sqrt(d2);
    }
    max_sq = std::max(max_sq, d2);
    moved += d2 > 0.0;
    ++movable;
  }
  return FinishBlock(max_sq, sum, moved, movable, capped);
}

// The step of a cotangent flow, F = finish(CurvatureLanes<V>) (see CurvatureSpeed), compiled
// for c.isa (RunWithIsa). finish is generic over V and must use only lane-wise operations,
// `<` comparisons and one comparison per select (see MeanCurvatureLanes).
// `finish` should be always_inline: GCC's flatten stops at a lambda whose inlined body would
// grow the stack frame too much, and that lambda would then run as baseline code called from
// the wide entry point.
template <typename FinishFn>
__attribute__((always_inline)) inline BlockStats ApplyCurvatureStep(const StepContext& c, const Vec3* cur, Vec3* next,
                                                                    int32_t begin, int32_t end, FinishFn&& finish) {
  return RunWithIsa(
      c.isa, [&](auto width) __attribute__((always_inline)) {
        constexpr int W = decltype(width)::value;
        if (c.batches != nullptr && c.batches->width == W) {
          if (AllFreeBlock(c, begin)) return CurvatureStepLanes<W, true>(c, cur, next, begin, end, finish);
          return CurvatureStepLanes<W, false>(c, cur, next, begin, end, finish);
        }
        CurvatureSpeed<W, FinishFn> speed(c, cur, begin, end, finish);
        return ApplyStep(c, cur, next, begin, end, speed);
      });
}

}  // namespace meshsmooth::flows
