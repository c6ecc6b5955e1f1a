// A long run of a count chosen on a sample, as one polynomial in the flow's step (chebyshev.h):
// the series itself against s^n, and the run against the same iterations one by one.
#include "core/flows/chebyshev.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <vector>

#include "core/flows/driver.h"
#include "core/flows/flow.h"
#include "core/flows/vector_isa.h"
#include "core/job/rules.h"
#include "core/measure/metrics.h"
#include "core/measure/noise.h"
#include "core/shapes/added_noise.h"
#include "core/shapes/parametric.h"
#include "core/topology.h"
#include "gtest/gtest.h"

namespace meshsmooth {
namespace {

// sum_k c_k T_k(t) by the three-term recurrence, scalar.
double Evaluate(const flows::ChebyshevSeries& series, double s) {
  const double t = (s - series.a) / series.b;
  double before = 1.0, now = t, sum = series.c[0];
  if (series.c.size() > 1) sum += series.c[1] * t;
  for (size_t k = 2; k < series.c.size(); ++k) {
    const double next = 2.0 * t * now - before;
    sum += series.c[k] * next;
    before = now;
    now = next;
  }
  return sum;
}

TEST(ChebyshevTest, SeriesOfAPowerMatchesItOnItsInterval) {
  struct Case {
    int n;
    double s_min;
  };
  for (const Case& c : {Case{1, 0.2}, Case{2, -1.0}, Case{50, 0.2}, Case{501, 0.2}, Case{1000, 0.2}, Case{300, -0.6}}) {
    const flows::ChebyshevSeries series = flows::ChebyshevOfPower(c.n, c.s_min, 1e-15);
    double total = 0.0;
    for (double x : series.c) {
      EXPECT_GE(x, 0.0);
      total += x;
    }
    EXPECT_NEAR(total, 1.0, 1e-14) << c.n;
    double worst = 0.0;
    for (int i = 0; i <= 2000; ++i) {
      const double s = c.s_min + (1.0 - c.s_min) * i / 2000.0;
      worst = std::max(worst, std::abs(Evaluate(series, s) - std::pow(s, c.n)));
    }
    EXPECT_LT(worst, 1e-13) << c.n << " " << c.s_min;
    EXPECT_NEAR(Evaluate(series, 1.0), 1.0, 1e-13);
  }
  // What makes it pay: the degree grows like the square root of the count.
  EXPECT_LE(flows::ChebyshevOfPower(501, 0.2, 1e-15).c.size(), 130u);
  EXPECT_LE(flows::ChebyshevOfPower(1000, 0.2, 1e-15).c.size(), 180u);
  EXPECT_EQ(flows::ChebyshevOfPower(0, 0.2, 1e-15).c, std::vector<double>{1.0});
}

// The count a sample chose, run on the whole mesh (RunPlan::fixed_iterations): as one
// polynomial and iteration by iteration (KernelOptions::chebyshev off), on a closed sphere and on a
// sphere with holes (fixed rims: the step is not symmetric there), the same positions within
// 1e-9 h, the same count, and progress that rises to it.
TEST(ChebyshevTest, CountChosenOnASampleRunsAsItsIterations) {
  for (const bool holes : {false, true}) {
    Mesh noisy = holes ? HoleySphere(5, 12, 0.15, 7) : Icosphere(5);
    AddNormalNoise(noisy, 0.2, 3);
    const Topology topo = BuildTopology(noisy);
    const double h = MeanEdgeLength(noisy, topo);
    const NoiseEstimate noise = EstimateNoise(noisy, topo, h);
    job::JobRule rule(h, noise, job::kPolicy);
    FlowParams p;
    p.flow = FlowId::kBilaplacian;  // automatic iterations, the count given by the plan
    auto run = [&](bool chebyshev, Mesh& m, std::vector<int>& seen) {
      flows::KernelOptions options;
      options.chebyshev = chebyshev;
      flows::SetKernelOptions(options);
      m = noisy;
      RunControl control;
      control.on_progress = [&](const Progress& progress) { seen.push_back(progress.iteration); };
      absl::StatusOr<FlowResult> r = flows::RunIterations(m, topo, p, control, h, {300, &rule});
      flows::SetKernelOptions({});
      return r;
    };
    Mesh fast, slow;
    std::vector<int> fast_seen, slow_seen;
    const absl::StatusOr<FlowResult> a = run(true, fast, fast_seen), b = run(false, slow, slow_seen);
    ASSERT_TRUE(a.ok() && b.ok()) << a.status() << b.status();
    EXPECT_EQ(a->iterations_run, 300);
    EXPECT_EQ(b->iterations_run, 300);
    double worst = 0.0;
    for (int32_t v = 0; v < noisy.num_vertices(); ++v) {
      worst = std::max(worst, Norm(fast.positions[v] - slow.positions[v]));
    }
    EXPECT_LT(worst, 1e-9 * h) << (holes ? "holey sphere" : "sphere");
    EXPECT_GT(worst, 0.0);  // it did run as a polynomial
    // The last iteration's statistics are those of the iteration run alone.
    EXPECT_NEAR(a->last.max_displacement, b->last.max_displacement, 1e-9 * h);
    ASSERT_FALSE(fast_seen.empty());
    EXPECT_TRUE(std::is_sorted(fast_seen.begin(), fast_seen.end()));
    EXPECT_GE(fast_seen.front(), 1);
    EXPECT_EQ(fast_seen.back(), 300);
    EXPECT_LT(fast_seen.size(), slow_seen.size() / 2);  // fewer applications of the step
  }
}

// The polynomial's terms are sums per vertex over fixed blocks: the same bits on one thread and
// on two (a mesh above the size that runs on one).
TEST(ChebyshevTest, SameBitsForAnyThreadCount) {
  Mesh noisy = Icosphere(6);
  AddNormalNoise(noisy, 0.2, 5);
  const Topology topo = BuildTopology(noisy);
  const double h = MeanEdgeLength(noisy, topo);
  const NoiseEstimate noise = EstimateNoise(noisy, topo, h);
  std::vector<Mesh> results;
  for (const int threads : {1, 2}) {
    FlowParams p;
    p.flow = FlowId::kBilaplacian;
    p.threads = threads;
    job::JobRule rule(h, noise, job::kPolicy);
    Mesh m = noisy;
    int terms = 0;
    RunControl control;
    control.on_progress = [&](const Progress& progress) { terms += progress.max_displacement == 0.0; };
    const absl::StatusOr<FlowResult> r = flows::RunIterations(m, topo, p, control, h, {200, &rule});
    ASSERT_TRUE(r.ok()) << r.status();
    EXPECT_EQ(r->iterations_run, 200);
    EXPECT_GT(terms, 0);  // it ran as a polynomial
    results.push_back(std::move(m));
  }
  EXPECT_EQ(results[0].positions, results[1].positions);
}

}  // namespace
}  // namespace meshsmooth
