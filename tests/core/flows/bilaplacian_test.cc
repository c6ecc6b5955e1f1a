#include <set>

#include "gtest/gtest.h"
#include "tests/flow_fixtures.h"

namespace meshsmooth {
namespace {

using namespace meshsmooth::testing;

// P <- P - lambda U0^2(P), checked against an independent computation from face lists.
TEST(BilaplacianTest, MatchesIndependentUSquared) {
  Mesh m = NoisySphere(2);
  const Mesh orig = m;
  const int n = m.num_vertices();
  std::vector<std::set<int32_t>> nb(n);
  for (const Triangle& t : m.triangles) {
    for (int i = 0; i < 3; ++i) {
      nb[t[i]].insert(t[(i + 1) % 3]);
      nb[t[i]].insert(t[(i + 2) % 3]);
    }
  }
  auto umbrella = [&](const std::vector<Vec3>& f, int v) {
    Vec3 s;
    for (int32_t w : nb[v]) s += f[w];
    return s * (1.0 / nb[v].size()) - f[v];
  };
  std::vector<Vec3> u(n);
  for (int v = 0; v < n; ++v) u[v] = umbrella(orig.positions, v);
  ASSERT_TRUE(Smooth(m, Params("bilaplacian", 1, 0.2)).ok());
  for (int v = 0; v < n; ++v) {
    const Vec3 expected = orig.positions[v] - umbrella(u, v) * 0.2;
    ASSERT_LT(Norm(m.positions[v] - expected), 1e-14) << v;
  }
}

TEST(BilaplacianTest, StableAndSmoothing) {
  const Mesh noisy = NoisySphere(4);
  const Mesh b = Smoothed(noisy, Params("bilaplacian", 50, 0.2));
  EXPECT_LT(RadiusError(b), 0.5 * RadiusError(noisy));
  EXPECT_LT(std::abs(Volume(b) / Volume(Icosphere(4)) - 1.0), 0.02);
}

TEST(BilaplacianTest, StepAboveHalfIsRefused) {
  Mesh m = Icosphere(1);
  EXPECT_EQ(Smooth(m, Params("bilaplacian", 1, 0.6)).status().code(), absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace meshsmooth
