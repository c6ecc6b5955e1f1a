// The bound on displacement (FlowParams::max_displacement): every flow and the default job keep
// every vertex within it of its input position, with no more flipped faces than without it and
// no more folded faces than the input; a
// bound no vertex reaches changes no bit; the bounded runs give the same bits on any thread count
// and in the Morton order; the count of vertices at the bound (CompareMeshes) is the one a
// recount finds; bad bounds are refused naming the field.
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "core/flows/catalogue.h"
#include "core/flows/flow.h"
#include "core/measure/folded_faces.h"
#include "core/measure/metrics.h"
#include "core/shapes/added_noise.h"
#include "core/shapes/parametric.h"
#include "gtest/gtest.h"
#include "tests/flow_fixtures.h"

namespace meshsmooth {
namespace {

using namespace meshsmooth::testing;

bool SameBytes(const Mesh& a, const Mesh& b) {
  return a.positions.size() == b.positions.size() &&
         std::memcmp(a.positions.data(), b.positions.data(), a.positions.size() * sizeof(Vec3)) == 0;
}

// Every flow for `iterations` iterations, and the default job.
std::vector<std::pair<std::string, FlowParams>> Jobs(int iterations) {
  std::vector<std::pair<std::string, FlowParams>> jobs;
  for (const std::string& flow : FlowNames()) jobs.emplace_back(flow, Params(flow, iterations));
  jobs.emplace_back("the default job", FlowParams{});
  return jobs;
}

// The largest distance of a vertex of `out` from its place in `in`.
double LargestMove(const Mesh& in, const Mesh& out) {
  double largest = 0.0;
  for (int32_t v = 0; v < in.num_vertices(); ++v) largest = std::max(largest, Norm(out.positions[v] - in.positions[v]));
  return largest;
}

// The vertices of `out` at least (1 - 1e-3) * bound from their place in `in`, each coordinate of
// `out` rounded to float32 first (what the service writes), counted here on their own.
int64_t RecountAtBound(const Mesh& in, const Mesh& out, double bound) {
  int64_t count = 0;
  for (int32_t v = 0; v < in.num_vertices(); ++v) {
    double sq = 0.0;
    for (int axis = 0; axis < 3; ++axis) {
      const double a = static_cast<float>((&out.positions[v].x)[axis]);
      const double d = a - (&in.positions[v].x)[axis];
      sq += d * d;
    }
    count += std::sqrt(sq) >= 0.999 * bound;
  }
  return count;
}

// A sphere with Gaussian noise of 0.3 h along random directions and a bound of 0.15 h: every
// flow and the default job would move most vertices farther (the noise's own size), so the
// bound holds many of them at it.
TEST(DisplacementBoundTest, EveryFlowAndTheDefaultJobKeepTheBound) {
  Mesh noisy = Icosphere(4);
  AddRandomDirectionNoise(noisy, 0.3, 7);
  Topology topo = BuildTopology(noisy);
  const double h = MeanEdgeLength(noisy, topo);
  const double bound = 0.15 * h;
  const FaceFolds folds(noisy, topo);
  for (auto [name, p] : Jobs(10)) {
    SCOPED_TRACE(name);
    Mesh free = noisy, bounded = noisy;
    ASSERT_TRUE(Smooth(free, topo, p).ok());
    ASSERT_GT(LargestMove(noisy, free), 1.5 * bound) << "the bound would not bind";
    p.max_displacement = bound;
    const absl::StatusOr<FlowResult> r = Smooth(bounded, topo, p);
    ASSERT_TRUE(r.ok()) << r.status();
    EXPECT_EQ(r->displacement_bound, bound);
    EXPECT_LE(LargestMove(noisy, bounded), bound * (1.0 + 1e-12));
    const absl::StatusOr<Displacement> d = CompareMeshes(noisy.positions, bounded, bound);
    ASSERT_TRUE(d.ok());
    const int64_t at_bound = RecountAtBound(noisy, bounded, bound);
    EXPECT_EQ(d->at_bound, at_bound);
    EXPECT_GT(at_bound, noisy.num_vertices() / 20) << "too few vertices reached the bound to show it holds";
    // A bound below the noise leaves some of the noise's folds (the run without it removes them
    // all), never more than the input had (taubin projected after each of its two passes left
    // 75 against the input's 63); and no more faces turn over from the input than without it.
    EXPECT_LE(folds.Count(bounded.positions.data()), folds.Count(noisy.positions.data()));
    EXPECT_LE(d->flipped_normals, CompareMeshes(noisy.positions, free)->flipped_normals);
  }
}

// The bound in mean edge lengths is the same run as the bound in mesh units it stands for.
TEST(DisplacementBoundTest, BoundInMeanEdgeLengthsIsTheSameRun) {
  const Mesh noisy = NoisySphere(4);
  Topology topo = BuildTopology(noisy);
  const double h = MeanEdgeLength(noisy, topo);
  for (auto [name, p] : Jobs(5)) {
    SCOPED_TRACE(name);
    Mesh units = noisy, edges = noisy;
    p.max_displacement_h = 0.1;
    const absl::StatusOr<FlowResult> r = Smooth(edges, topo, p);
    ASSERT_TRUE(r.ok());
    EXPECT_DOUBLE_EQ(r->displacement_bound, 0.1 * h);
    p.max_displacement_h = 0.0;
    p.max_displacement = r->displacement_bound;
    ASSERT_TRUE(Smooth(units, topo, p).ok());
    EXPECT_TRUE(SameBytes(units, edges));
  }
}

// The projection is the bound's only effect on a flow's run: a bound no vertex reaches gives
// the bits of the run without it.
TEST(DisplacementBoundTest, BoundNoVertexReachesChangesNoBit) {
  const Mesh noisy = NoisySphere(4);
  Topology topo = BuildTopology(noisy);
  for (const std::string& flow : FlowNames()) {
    SCOPED_TRACE(flow);
    FlowParams p = Params(flow, 5);
    Mesh plain = noisy, bounded = noisy;
    ASSERT_TRUE(Smooth(plain, topo, p).ok());
    p.max_displacement = 10.0 * LargestMove(noisy, plain);
    ASSERT_TRUE(Smooth(bounded, topo, p).ok());
    EXPECT_TRUE(SameBytes(plain, bounded));
  }
}

// The default job moves outliers back before its runs: the bound stays centred on the input, not
// on where the outliers went.
TEST(DisplacementBoundTest, DefaultJobMeasuresFromTheInputAfterMovingOutliers) {
  Mesh noisy = Icosphere(4);
  AddNormalNoise(noisy, 0.1, 3);
  AddImpulsiveNoise(noisy, 0.1, 3.0, 4);
  Topology topo = BuildTopology(noisy);
  const double h = MeanEdgeLength(noisy, topo);
  FlowParams p;
  p.max_displacement = 0.5 * h;
  Mesh out = noisy;
  const absl::StatusOr<FlowResult> r = Smooth(out, topo, p);
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_GT(r->outliers_moved, 0) << "no outliers were moved: the test shows nothing";
  EXPECT_LE(LargestMove(noisy, out), p.max_displacement * (1.0 + 1e-12));
  EXPECT_GT(RecountAtBound(noisy, out, p.max_displacement), r->outliers_moved / 2);
  const FaceFolds folds(noisy, topo);
  EXPECT_LE(folds.Count(out.positions.data()), folds.Count(noisy.positions.data()));
}

// Projections are made block by block after each pass: the same bytes on 1 and 2 threads (a mesh
// above the parallel threshold, whose default job chooses on patches) and in the Morton order.
TEST(DisplacementBoundTest, BoundedRunsAreTheSameOnAnyThreadCountAndOrder) {
  const Mesh noisy = NoisySphere(6);  // 40,962 vertices: two threads
  Topology topo = BuildTopology(noisy);
  const double h = MeanEdgeLength(noisy, topo);
  for (auto [name, p] : Jobs(3)) {
    SCOPED_TRACE(name);
    p.max_displacement = 0.1 * h;
    Mesh one = noisy, two = noisy;
    p.threads = 1;
    ASSERT_TRUE(Smooth(one, topo, p).ok());
    p.threads = 2;
    ASSERT_TRUE(Smooth(two, topo, p).ok());
    EXPECT_TRUE(SameBytes(one, two));
    EXPECT_LE(LargestMove(noisy, two), p.max_displacement * (1.0 + 1e-12));
  }
  Mesh large = Icosphere(7);  // 163,842 vertices: reorderable
  AddUniformNoise(large, 0.3, 2);
  Topology large_topo = BuildTopology(large);
  FlowParams p = Params("taubin", 3);
  p.max_displacement_h = 0.1;
  p.reorder = ReorderMode::kNever;
  Mesh never = large, always = large;
  ASSERT_TRUE(Smooth(never, large_topo, p).ok());
  p.reorder = ReorderMode::kAlways;
  ASSERT_TRUE(Smooth(always, large_topo, p).ok());
  EXPECT_TRUE(SameBytes(never, always));
}

TEST(DisplacementBoundTest, BadBoundsAreRefusedNamingTheField) {
  const Mesh noisy = NoisySphere(2);
  const double inf = std::numeric_limits<double>::infinity();
  for (double bad : {-0.5, std::nan(""), inf}) {
    for (const std::string field : {"max_displacement", "max_displacement_h"}) {
      SCOPED_TRACE(field + " " + std::to_string(bad));
      for (FlowParams p : {FlowParams{}, Params("taubin", 2)}) {
        (field == "max_displacement" ? p.max_displacement : p.max_displacement_h) = bad;
        Mesh out = noisy;
        const absl::StatusOr<FlowResult> r = Smooth(out, p);
        ASSERT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
        EXPECT_NE(r.status().message().find(field + " must be"), std::string::npos) << r.status();
        EXPECT_TRUE(SameBytes(out, noisy));
      }
    }
  }
  FlowParams both;
  both.max_displacement = 0.1;
  both.max_displacement_h = 0.1;
  Mesh out = noisy;
  const absl::StatusOr<FlowResult> r = Smooth(out, both);
  ASSERT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(r.status().message().find("both set"), std::string::npos) << r.status();
}

}  // namespace
}  // namespace meshsmooth
