#include "gtest/gtest.h"
#include "tests/flow_fixtures.h"

namespace meshsmooth {
namespace {

using namespace meshsmooth::testing;

TEST(AdaptiveTest, ThresholdAboveEverySpeedFreezesTheMesh) {
  const Mesh noisy = NoisySphere(3);
  for (const char* flow : {"laplacian", "median"}) {
    FlowParams p = Params(flow, 5);
    p.adaptive = AdaptiveMode::kConstant;
    p.adaptive_threshold = 1e9;
    Mesh m = noisy;
    absl::StatusOr<FlowResult> r = Smooth(m, p);
    ASSERT_TRUE(r.ok());
    EXPECT_EQ(m.positions, noisy.positions) << flow;
    EXPECT_EQ(r->last.moved_share, 0.0);
  }
}

// Eq. (14) with a constant T: the vertex moves by lambda (|F| - T) along F.
TEST(AdaptiveTest, ConstantThresholdShortensTheSpeed) {
  Mesh m;
  m.positions = {{0.1, 0.2, 0.3}, {1, 0, 0},       {0.5, 0.9, 0},    {-0.5, 0.8, 0.1},
                 {-1, 0, 0},      {-0.5, -0.9, 0}, {0.6, -0.8, -0.2}};
  for (int k = 0; k < 6; ++k) m.triangles.push_back({0, 1 + k, 1 + (k + 1) % 6});
  const Vec3 u = Vec3{0.1 / 6.0, 0.0, -0.1 / 6.0} - m.positions[0];
  const double h = MeanEdgeLength(m, BuildTopology(m));
  FlowParams p = Params("laplacian", 1, 0.5);
  p.adaptive = AdaptiveMode::kConstant;
  p.adaptive_threshold = 0.1;  // relative to h for the umbrella flows
  const Vec3 expected = m.positions[0] + u * (0.5 * (Norm(u) - 0.1 * h) / Norm(u));
  ASSERT_TRUE(Smooth(m, p).ok());
  EXPECT_LT(Norm(m.positions[0] - expected), 1e-15);
}

TEST(AdaptiveTest, RingThresholdsSlowTheFlowDown) {
  const Mesh noisy = NoisySphere(4);
  auto last_mean_displacement = [&noisy](FlowParams p) {
    double last = 0.0;
    RunControl control;
    control.on_progress = [&](const Progress& pr) { last = pr.mean_displacement; };
    Mesh m = noisy;
    EXPECT_TRUE(Smooth(m, p, control).ok());
    EXPECT_LT(RadiusError(m), 0.5 * RadiusError(noisy));
    return last;
  };
  const double plain = last_mean_displacement(Params("median", 60, 0.1));
  for (AdaptiveMode mode : {AdaptiveMode::kRing1, AdaptiveMode::kRing2}) {
    FlowParams p = Params("median", 60, 0.1);
    p.adaptive = mode;
    EXPECT_LT(last_mean_displacement(p), 0.5 * plain);
  }
}

TEST(AdaptiveTest, BadThresholdParametersAreRefused) {
  Mesh m = Icosphere(1);
  FlowParams p = Params("median", 1);
  p.adaptive = AdaptiveMode::kConstant;
  p.adaptive_threshold = -1.0;
  EXPECT_EQ(Smooth(m, p).status().code(), absl::StatusCode::kInvalidArgument);
  p.adaptive = AdaptiveMode::kRing2;
  p.adaptive_recompute_every = 0;
  EXPECT_EQ(Smooth(m, p).status().code(), absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace meshsmooth
