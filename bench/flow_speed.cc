#include "bench/flow_speed.h"

#include <algorithm>
#include <cstdio>
#include <string>

#include "bench/bench_common.h"
#include "core/flows/reorder.h"
#include "core/shapes/added_noise.h"
#include "core/shapes/parametric.h"

namespace meshsmooth::bench {

std::vector<Variant> Variants() {
  FlowParams u1 = DefaultParams("laplacian"), taubin_u1 = DefaultParams("taubin");
  u1.weights = taubin_u1.weights = UmbrellaWeights::kInverseDistance;
  FlowParams adaptive = DefaultParams("median");
  adaptive.adaptive = AdaptiveMode::kRing2;
  return {{"laplacian U0", DefaultParams("laplacian")},
          {"laplacian U1", u1},
          {"taubin U0", DefaultParams("taubin")},
          {"taubin U1", taubin_u1},
          {"bilaplacian", DefaultParams("bilaplacian")},
          {"mcf", DefaultParams("mcf")},
          {"mcf_tangential", DefaultParams("mcf_tangential")},
          {"median", DefaultParams("median")},
          {"median + adaptive ring2", adaptive}};
}

OurTiming TimeOurs(const Mesh& mesh, const Topology& topology, FlowParams p, int iterations, int threads, int runs) {
  Topology topo = topology;  // lent to each run (Smooth())
  p.threads = threads;
  // T(1) in the layout Smooth() picks for `iterations`, so that T(K) - T(1) is the iterations.
  p.reorder = MortonOrderPaysOff(topo, iterations) ? ReorderMode::kAlways : ReorderMode::kNever;
  auto once = [&](int k) {
    p.iterations = k;
    Mesh m = mesh;
    const auto t0 = Clock::now();
    absl::StatusOr<FlowResult> res = Smooth(m, topo, p);
    const double ms = Ms(t0, Clock::now());
    if (!res.ok()) {
      std::fprintf(stderr, "bench: %s failed: %s\n", std::string(FlowName(p.flow.value_or(kDefaultFlow))).c_str(),
                   std::string(res.status().message()).c_str());
      return -1.0;
    }
    return ms;
  };
  // One untimed call first: otherwise the first run's T(K) pays for memory the allocator had
  // not yet taken from the system, and T(K) - T(1) overstates an iteration (most for a large
  // mesh run after a smaller one; docs/performance.md).
  if (once(1) < 0) return {};
  std::vector<double> per, setup;
  for (int r = 0; r < runs; ++r) {
    const double tk = once(iterations), t1 = once(1);
    if (tk < 0 || t1 < 0) return {};
    const double it = (tk - t1) / std::max(1, iterations - 1);
    per.push_back(it);
    setup.push_back(t1 - it);
  }
  return {Median(per), Median(setup)};
}

double PlainU0Ms(const Mesh& mesh, const Topology& topo, int iterations, int threads, int runs) {
  // The very arrays Smooth() runs on when it reorders, whatever the mesh's size.
  Mesh ordered = mesh;
  Topology ordered_topo = topo;
  Renumber(MortonOrder(ordered.positions, threads), ordered, ordered_topo, threads);
  const int32_t n = ordered.num_vertices();
  const int32_t* off = ordered_topo.ring_offsets.data();
  const int32_t* ring = ordered_topo.ring.data();
  std::vector<Vec3> cur = ordered.positions, next(n);
  std::vector<double> t;
  for (int run = 0; run < runs; ++run) {
    const auto t0 = Clock::now();
    for (int k = 0; k < iterations; ++k) {
      const Vec3* p = cur.data();
      Vec3* q = next.data();
#pragma omp parallel for schedule(static) num_threads(threads)
      for (int32_t v = 0; v < n; ++v) {
        Vec3 sum;
        for (int32_t i = off[v]; i < off[v + 1]; ++i) sum += p[ring[i]];
        const int32_t d = off[v + 1] - off[v];
        q[v] = d > 0 ? p[v] + (sum * (1.0 / d) - p[v]) * 0.5 : p[v];
      }
      cur.swap(next);
    }
    t.push_back(Ms(t0, Clock::now()) / iterations);
  }
  return Median(t);
}

int IterationsFor(int32_t n) { return std::clamp(static_cast<int>(40'000'000 / std::max(n, 1)), 3, 200); }

Mesh NoisyIcosphere(int level) {
  Mesh m = Icosphere(level);
  AddUniformNoise(m, 0.3, 1);
  return m;
}

}  // namespace meshsmooth::bench
