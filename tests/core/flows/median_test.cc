#include "gtest/gtest.h"
#include "tests/flow_fixtures.h"

namespace meshsmooth {
namespace {

using namespace meshsmooth::testing;

// Eq. (13) moves each vertex so that its speed along the mean-curvature direction equals |H|,
// in both the convex (cos > eps) and the saddle (cos < -eps) case, or not at all.
TEST(MedianTest, NormalSpeedEqualsMeanCurvature) {
  Mesh m = NoisySphere(3);
  Topology topo = BuildTopology(m);
  const std::vector<Vec3> hn = MeanCurvatureNormals(m, topo);
  const Mesh before = m;
  absl::StatusOr<FlowResult> r = Smooth(m, topo, Params("median", 1, 0.01));
  ASSERT_TRUE(r.ok());
  int moved = 0, still = 0;
  for (size_t v = 0; v < hn.size(); ++v) {
    const Vec3 f = (m.positions[v] - before.positions[v]) * (1.0 / r->effective_step);
    if (SquaredNorm(f) == 0.0) {
      ++still;
      continue;
    }
    ++moved;
    const double h = Norm(hn[v]);
    ASSERT_NEAR(Dot(f, hn[v]) / h, h, 1e-6 * h) << v;
  }
  EXPECT_GT(moved, 0.8 * hn.size());
  EXPECT_GT(still, 0);  // |cos| <= eps happens on a noisy mesh
}

// On a clean sphere the normal speed is the mean curvature flow's: the radius shrinks alike.
// (The tangential part is not small even there: U0 leans up to ~70 degrees from the normal on
// icosphere(4), whose triangles differ in size; that part regularises the sampling.)
TEST(MedianTest, OnACleanSphereTheRadiusFollowsTheMeanCurvatureFlow) {
  const Mesh sphere = Icosphere(4);
  const Mesh med = Smoothed(sphere, Params("median", 5, 0.1));
  const Mesh mcf = Smoothed(sphere, Params("mcf", 5, 0.1));
  auto mean_radius = [](const Mesh& m) {
    double s = 0.0;
    for (const Vec3& p : m.positions) s += Norm(p);
    return s / static_cast<double>(m.positions.size());
  };
  const double shrink_mcf = 1.0 - mean_radius(mcf), shrink_med = 1.0 - mean_radius(med);
  EXPECT_GT(shrink_mcf, 0.0);
  EXPECT_NEAR(shrink_med, shrink_mcf, 0.05 * shrink_mcf);
}

TEST(MedianTest, EpsilonOutsideTheOpenUnitIntervalIsRefused) {
  Mesh m = Icosphere(1);
  for (double eps : {0.0, 1.0, -0.2, 2.0}) {
    FlowParams p = Params("median", 1);
    p.epsilon = eps;
    const absl::Status s = Smooth(m, p).status();
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << eps;
    EXPECT_NE(s.message().find("epsilon"), std::string::npos) << s;
  }
}

}  // namespace
}  // namespace meshsmooth
