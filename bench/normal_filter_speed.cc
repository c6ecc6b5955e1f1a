#include "bench/normal_filter_speed.h"

#include <algorithm>
#include <cstdio>
#include <vector>

#include "bench/bench_common.h"
#include "core/flows/flow.h"
#include "core/flows/flow_table.h"
#include "core/flows/reorder.h"

namespace meshsmooth::bench {

void NormalFilterRows(const Mesh& mesh, const Topology& topo, const double u0_ms[2], int hw, int runs) {
  constexpr int kIterations = 4;
  auto total_ms = [&](const FlowParams& p) {
    std::vector<double> t;
    for (int r = 0; r < runs; ++r) {
      Mesh m = mesh;
      const auto t0 = Clock::now();
      absl::StatusOr<FlowResult> res = Smooth(m, topo, p);
      t.push_back(res.ok() ? Ms(t0, Clock::now()) : -1.0);
    }
    return Median(t);
  };
  double filter[2], vertex[2], round[2], setup[2];
  for (int k = 0; k < 2; ++k) {
    FlowParams base;
    base.flow = FlowId::kBilateralNormal;
    base.threads = k == 0 ? 1 : std::min(2, hw);
    base.iterations = kIterations;
    // In the layout a job of 20 iterations runs in, whatever the count here.
    base.reorder = MortonOrderPaysOff(topo, 20 * PassesPerIteration(base)) ? ReorderMode::kAlways : ReorderMode::kNever;
    FlowParams one = base;  // one filter pass and one vertex pass per iteration
    one.normal_filter.normal_iterations = one.normal_filter.vertex_iterations = 1;
    FlowParams two_filters = one, two_updates = one, single = base;
    two_filters.normal_filter.normal_iterations = 2;
    two_updates.normal_filter.vertex_iterations = 2;
    single.iterations = 1;
    const double t_one = total_ms(one), t_base = total_ms(base), t_single = total_ms(single);
    filter[k] = (total_ms(two_filters) - t_one) / kIterations;
    vertex[k] = (total_ms(two_updates) - t_one) / kIterations;
    round[k] = (t_base - t_single) / (kIterations - 1);
    setup[k] = t_single - round[k];
  }
  std::printf(
      "\n| bilateral_normal (default parameters) | ms, 1 thread | 2 threads | / laplacian U0 iteration, 1 thread | "
      "2 threads |\n|---|---|---|---|---|\n");
  auto row = [&](const char* what, const double* t) {
    std::printf("| %s | %.2f | %.2f | %.2fx | %.2fx |\n", what, t[0], t[1], t[0] / u0_ms[0], t[1] / u0_ms[1]);
  };
  row("one filter pass over the face normals", filter);
  row("one vertex pass (update and guards)", vertex);
  row("one iteration (1 filter pass, 5 vertex passes, face geometry)", round);
  row("set-up (face graph, any Morton copy) and first touch of the buffers", setup);
}

}  // namespace meshsmooth::bench
