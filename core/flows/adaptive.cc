// Eq. (14)'s vertex-dependent threshold T(P): the arithmetic mean of |H| over the first ring,
// or the first and second rings, of P (the paper's best strategy recomputes it every K
// iterations; the driver does that). Only interior neighbours count: boundary and
// non-manifold vertices have no mean curvature here. A vertex without interior neighbours
// gets its own |H| (or 0).
#include <omp.h>

#include <algorithm>
#include <limits>

#include "core/flows/step_loops.h"

namespace meshsmooth::flows {

void RingThresholds(const StepContext& c, const Vec3* pos, int32_t n, int rings, int threads, std::vector<double>& t) {
  // |H| per vertex, NaN where undefined (so it is skipped below). The free vertices in the
  // step's lane batches when there are some (the same bits: see MeanCurvatureLanes), the rest
  // one by one. The second ring is made unique with a mark per vertex, not a
  // search of the list so far.
  std::vector<double> h(n);
  const bool batched = c.batches != nullptr && c.batches->width == LaneWidthOf(c.isa);
  ForBlocks(n, threads, [&](int32_t block, int32_t begin, int32_t end) {
    for (int32_t v = begin; v < end; ++v) {
      if (c.kind[v] != VertexKind::kInterior) {
        h[v] = std::numeric_limits<double>::quiet_NaN();
      } else if (!batched || c.role[v] != kFree) {
        h[v] = Norm(MeanCurvatureNormal(c, pos, v).hn);
      }
    }
    if (!batched) return;
    RunWithIsa(
        c.isa, [&](auto width) __attribute__((always_inline)) {
          constexpr int W = decltype(width)::value;
          using V = typename VertexLanesOf<W>::type;
          const LaneBatches& lanes = *c.batches;
          alignas(8 * W) double norm[W];
          for (int32_t j = lanes.block_first[block]; j < lanes.block_first[block + 1]; ++j) {
            const int32_t* const rows = &lanes.data[lanes.offsets[j]];
            const auto k = MeanCurvatureLanes<W, true>(c, pos, 0, W, rows);
            const V len = LaneSqrt(k.hn.x * k.hn.x + k.hn.y * k.hn.y + k.hn.z * k.hn.z);
            std::memcpy(norm, &len, sizeof norm);
            for (int32_t l = 0; l < lanes.lanes[j]; ++l) h[rows[l]] = norm[l];
          }
          return BlockStats{};
        });
  });
  t.resize(n);
  // Per thread: seen[w] == v + 1 once w is in v's list. Blocks of one thread run in order, and
  // v + 1 differs for every vertex, so the marks never need clearing.
  std::vector<std::vector<int32_t>> seen_of(std::max(threads, 1));
  ForBlocks(n, threads, [&](int32_t, int32_t begin, int32_t end) {
    std::vector<int32_t>& seen = seen_of[omp_get_thread_num()];
    if (rings == 2 && seen.empty()) seen.assign(n, 0);
    std::vector<int32_t> near;
    for (int32_t v = begin; v < end; ++v) {
      near.clear();
      // The first ring, or the first and second rings with each vertex once, in the order met
      // (rings keep their order under reordering, ids do not).
      auto add = [&](int32_t x) {
        if (seen[x] != v + 1) seen[x] = v + 1, near.push_back(x);
      };
      for (int32_t i = c.offsets[v]; i < c.offsets[v + 1]; ++i) {
        const int32_t w = c.ring[i];
        if (rings == 1) {
          near.push_back(w);
          continue;
        }
        add(w);
        for (int32_t j = c.offsets[w]; j < c.offsets[w + 1]; ++j) add(c.ring[j]);
      }
      double sum = 0.0;
      int count = 0;
      for (int32_t w : near) {
        if (w == v || std::isnan(h[w])) continue;
        sum += h[w];
        ++count;
      }
      t[v] = count > 0 ? sum / count : (std::isnan(h[v]) ? 0.0 : h[v]);
    }
  });
}

}  // namespace meshsmooth::flows
