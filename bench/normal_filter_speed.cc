#include "bench/normal_filter_speed.h"

#include <algorithm>
#include <cstdio>
#include <vector>

#include "bench/bench_common.h"
#include "bench/flow_speed.h"
#include "core/flows/flow.h"
#include "core/flows/flow_table.h"
#include "core/flows/reorder.h"

namespace meshsmooth::bench {

void NormalFilterRows(const Mesh& mesh, const Topology& topology, const double u0_ms[2], int hw, int runs) {
  Topology topo = topology;  // lent to each run (Smooth())
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
  row("set-up (face graph, any Morton renumbering) and first touch of the buffers", setup);
}

void NormalFilterIterationHeader() {
  std::printf(
      "\n| mesh | faces | laplacian U0 ms/iteration, 1 thread | 2 threads | bilateral_normal ms/iteration, 1 thread "
      "| 2 threads | / U0, 1 thread | 2 threads | ns per face, 1 thread | 2 threads |\n"
      "|---|---|---|---|---|---|---|---|---|---|\n");
}

void NormalFilterIterationRow(const std::string& name, const Mesh& mesh, const Topology& topology, int hw, int runs) {
  Topology topo = topology;  // lent to each run (Smooth())
  const int32_t faces = static_cast<int32_t>(topo.faces.size());
  FlowParams u0 = DefaultParams("laplacian"), bn = DefaultParams("bilateral_normal");
  // Both in the layout a 20-iteration bilateral_normal job runs in.
  u0.reorder = bn.reorder =
      MortonOrderPaysOff(topo, 20 * PassesPerIteration(bn)) ? ReorderMode::kAlways : ReorderMode::kNever;
  // About the same time per run for both: an iteration of bilateral_normal costs tens of U0's.
  const int k_u0 = IterationsFor(mesh.num_vertices());
  const int k_bn = std::clamp(k_u0 / 8, 4, 25);
  auto once = [&](FlowParams p, int iterations) {
    p.iterations = iterations;
    Mesh m = mesh;
    const auto t0 = Clock::now();
    const absl::StatusOr<FlowResult> res = Smooth(m, topo, p);
    return res.ok() ? Ms(t0, Clock::now()) : -1.0;
  };
  double t_u0[2], t_bn[2];
  for (int k = 0; k < 2; ++k) {
    u0.threads = bn.threads = k == 0 ? 1 : std::min(2, hw);
    once(u0, 1), once(bn, 1);  // untimed: the allocator takes its memory from the system
    std::vector<double> per_u0, per_bn;
    for (int r = 0; r < runs; ++r) {
      per_u0.push_back((once(u0, k_u0) - once(u0, 1)) / (k_u0 - 1));
      per_bn.push_back((once(bn, k_bn) - once(bn, 1)) / (k_bn - 1));
    }
    t_u0[k] = Median(per_u0), t_bn[k] = Median(per_bn);
  }
  std::printf("| %s | %d | %.3f | %.3f | %.2f | %.2f | %.1fx | %.1fx | %.0f | %.0f |\n", name.c_str(), faces, t_u0[0],
              t_u0[1], t_bn[0], t_bn[1], t_bn[0] / t_u0[0], t_bn[1] / t_u0[1], 1e6 * t_bn[0] / faces,
              1e6 * t_bn[1] / faces);
}

}  // namespace meshsmooth::bench
