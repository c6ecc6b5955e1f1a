#include "bench/bandwidth.h"

#include <omp.h>

#include <algorithm>
#include <cstdio>
#include <vector>

#include "bench/bench_common.h"

namespace meshsmooth::bench {

double Triad(size_t bytes, int threads) {
  const size_t n = bytes / sizeof(double);
  std::vector<double> a(n), b(n), c(n);
#pragma omp parallel for num_threads(threads) schedule(static)
  for (size_t i = 0; i < n; ++i) {
    a[i] = 0.0;
    b[i] = 1.0;
    c[i] = 2.0;
  }
  const int reps = std::max<int>(5, static_cast<int>((1 << 28) / std::max<size_t>(n, 1)));
  double best = 0.0;
  for (int r = 0; r < 5; ++r) {
    const auto t0 = Clock::now();
    for (int k = 0; k < reps; ++k) {
      const double s = 1.0 + 1e-9 * k;
#pragma omp parallel for num_threads(threads) schedule(static)
      for (size_t i = 0; i < n; ++i) a[i] = b[i] + s * c[i];
    }
    const double sec = Ms(t0, Clock::now()) / 1000.0;
    best = std::max(best, 24.0 * static_cast<double>(n) * reps / sec / 1e9);
  }
  if (a[n / 2] < 0) std::printf(" ");  // keep the loop observable
  return best;
}

// The positions read (24), ring offsets (4), neighbour indices (4 x valence), role (1),
// positions written (24); neighbour positions are assumed to hit cache. Taubin and bilaplacian
// make two such passes; taubin also a displacement pass over the iteration start (48).
double BytesPerVertex(FlowId flow, double mean_valence) {
  const double pass = 24 + 4 + 4 * mean_valence + 1 + 24;
  if (flow == FlowId::kTaubin) return 2 * pass + 48;
  if (flow == FlowId::kBilaplacian) return 2 * pass;
  return pass;
}

}  // namespace meshsmooth::bench
