#include "gtest/gtest.h"
#include "tests/flow_fixtures.h"

namespace meshsmooth {
namespace {

using namespace meshsmooth::testing;

Mesh Scaled(Mesh m, double s) {
  for (Vec3& p : m.positions) p *= s;
  return m;
}

TEST(McfTest, MeanCurvatureOfIcosphere5IsOneOverRadius) {
  for (double r : {1.0, 3.0, 0.001}) {
    const Mesh m = Scaled(Icosphere(5), r);
    const std::vector<Vec3> hn = MeanCurvatureNormals(m, BuildTopology(m));
    double worst = 0.0;
    for (size_t v = 0; v < hn.size(); ++v) {
      worst = std::max(worst, std::abs(Norm(hn[v]) * r - 1.0));
      ASSERT_LT(Dot(hn[v], m.positions[v]), 0.0);  // points to the centre
    }
    EXPECT_LT(worst, 0.02) << "r = " << r;
  }
}

// A sphere under mean curvature flow: dr/dt = -H = -1/r, so r(t)^2 = r0^2 - 2t.
TEST(McfTest, SphereFollowsClosedForm) {
  const double r0 = 1.0;
  Mesh m = Icosphere(4);
  const double step = 0.05;
  double t = 0.0;
  for (int round = 0; round < 6; ++round) {
    // Each round's step is relative to the current (shrinking) mesh: add its effective step.
    absl::StatusOr<FlowResult> r = Smooth(m, Params("mcf", 200, step));
    ASSERT_TRUE(r.ok()) << r.status();
    t += 200 * r->effective_step;
    double mean_r2 = 0.0;
    for (const Vec3& p : m.positions) mean_r2 += SquaredNorm(p);
    mean_r2 /= m.positions.size();
    const double expected = r0 * r0 - 2.0 * t;
    EXPECT_NEAR(mean_r2, expected, 0.03 * expected) << "t = " << t;
  }
}

TEST(McfTest, SameParametersWorkInMillimetresAndMetres) {
  const Mesh metres = NoisySphere(3);
  const Mesh mm = Scaled(metres, 1000.0);
  const Mesh a = Smoothed(metres, Params("mcf", 10, 0.1));
  const Mesh b = Smoothed(mm, Params("mcf", 10, 0.1));
  for (size_t v = 0; v < a.positions.size(); ++v) {
    ASSERT_LT(Norm(b.positions[v] * 1e-3 - a.positions[v]), 1e-12);
  }
}

// Zero-area triangles and needles never produce NaN or Inf.
TEST(McfTest, DegenerateTrianglesStayFinite) {
  Mesh m = Icosphere(3);
  // Collapse a few vertices onto neighbours (zero-area faces) and squash others (needles).
  m.positions[20] = m.positions[21];
  m.positions[40] = (m.positions[41] + m.positions[42]) * 0.5;
  m.positions[60] = m.positions[61] * 0.999999 + m.positions[62] * 0.000001;
  for (const char* flow : {"mcf", "mcf_tangential", "median"}) {
    Mesh s = m;
    absl::StatusOr<FlowResult> r = Smooth(s, Params(flow, 10, 0.05));
    ASSERT_TRUE(r.ok()) << flow << ": " << r.status();
    for (const Vec3& p : s.positions) ASSERT_TRUE(IsFinite(p)) << flow;
  }
}

TEST(McfTest, TooLargeStepFailsWithAClearError) {
  Mesh m = NoisySphere(3);
  const Mesh before = m;
  absl::StatusOr<FlowResult> r = Smooth(m, Params("mcf", 200, 10.0));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(r.status().message().find("diverged at iteration"), std::string::npos) << r.status();
  EXPECT_NE(r.status().message().find("smaller step"), std::string::npos) << r.status();
  for (const Vec3& p : m.positions) ASSERT_TRUE(IsFinite(p));
}

}  // namespace
}  // namespace meshsmooth
