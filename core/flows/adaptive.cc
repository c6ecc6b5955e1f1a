// Eq. (14)'s vertex-dependent threshold T(P): the arithmetic mean of |H| over the first ring,
// or the first and second rings, of P (the paper's best strategy recomputes it every K
// iterations; the driver does that). Only interior neighbours count: boundary and
// non-manifold vertices have no mean curvature here. A vertex without interior neighbours
// gets its own |H| (or 0).
#include <algorithm>
#include <limits>

#include "core/flows/kernel.h"

namespace meshsmooth::flows {

void RingThresholds(const StepContext& c, const Vec3* pos, int32_t n, int rings, int threads, std::vector<double>& t) {
  // |H| per vertex, NaN where undefined (so it is skipped below).
  std::vector<double> h(n);
  ForBlocks(n, threads, [&](int32_t, int32_t begin, int32_t end) {
    for (int32_t v = begin; v < end; ++v) {
      h[v] = c.kind[v] == VertexKind::kInterior ? Norm(MeanCurvatureNormal(c, pos, v).hn)
                                                : std::numeric_limits<double>::quiet_NaN();
    }
  });
  t.resize(n);
  ForBlocks(n, threads, [&](int32_t, int32_t begin, int32_t end) {
    std::vector<int32_t> near;
    for (int32_t v = begin; v < end; ++v) {
      near.clear();
      for (int32_t i = c.offsets[v]; i < c.offsets[v + 1]; ++i) {
        const int32_t w = c.ring[i];
        near.push_back(w);
        if (rings == 2) {
          for (int32_t j = c.offsets[w]; j < c.offsets[w + 1]; ++j) near.push_back(c.ring[j]);
        }
      }
      if (rings == 2) {
        // Unique, in the order met (rings keep their order under reordering, ids do not).
        size_t kept = 0;
        for (size_t i = 0; i < near.size(); ++i) {
          if (std::find(near.begin(), near.begin() + kept, near[i]) == near.begin() + kept) near[kept++] = near[i];
        }
        near.resize(kept);
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
