#include "gtest/gtest.h"
#include "tests/flow_fixtures.h"

namespace meshsmooth {
namespace {

using namespace meshsmooth::testing;

TEST(TaubinTest, MuFromPassBandAsInThePaper) {
  Mesh m = NoisySphere(2);
  FlowParams p = Params("taubin", 1, 0.3);
  p.taubin_pass_band = 0.1;  // paper: lambda 0.3, 1/lambda - 1/mu = 0.1
  absl::StatusOr<FlowResult> r = Smooth(m, p);
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_NEAR(r->effective_mu, 1.0 / (1.0 / 0.3 - 0.1), 1e-15);
  EXPECT_NEAR(r->effective_mu, 0.3093, 1e-4);
}

// One iteration = a lambda pass then a mu pass (each over the whole mesh).
TEST(TaubinTest, OneIterationIsLambdaPassThenMuPass) {
  Mesh m;
  m.positions = {{0.1, 0.2, 0.3}, {1, 0, 0},       {0.5, 0.9, 0},    {-0.5, 0.8, 0.1},
                 {-1, 0, 0},      {-0.5, -0.9, 0}, {0.6, -0.8, -0.2}};
  for (int k = 0; k < 6; ++k) m.triangles.push_back({0, 1 + k, 1 + (k + 1) % 6});
  const Vec3 mean{0.1 / 6.0, 0.0, -0.1 / 6.0};  // the fixed ring's mean
  const Vec3 p1 = m.positions[0] + (mean - m.positions[0]) * 0.5;
  const Vec3 p2 = p1 - (mean - p1) * 0.6;
  FlowParams p = Params("taubin", 1, 0.5);
  p.taubin_mu = 0.6;
  ASSERT_TRUE(Smooth(m, p).ok());
  EXPECT_NEAR(m.positions[0].x, p2.x, 1e-15);
  EXPECT_NEAR(m.positions[0].y, p2.y, 1e-15);
  EXPECT_NEAR(m.positions[0].z, p2.z, 1e-15);
}

TEST(TaubinTest, KeepsVolumeWhereLaplacianShrinks) {
  const Mesh noisy = NoisySphere(4);
  const double v0 = Volume(Icosphere(4));
  FlowParams p = Params("taubin", 20, 0.5);
  for (UmbrellaWeights w : {UmbrellaWeights::kUniform, UmbrellaWeights::kInverseDistance}) {
    p.weights = w;
    const Mesh t = Smoothed(noisy, p);
    EXPECT_LT(std::abs(Volume(t) / v0 - 1.0), 0.01);
    EXPECT_LT(RadiusError(t), 0.5 * RadiusError(noisy));
  }
  EXPECT_GT(1.0 - Volume(Smoothed(noisy, Params("laplacian", 20, 0.5))) / v0, 0.02);
}

TEST(TaubinTest, MuNotAboveLambdaIsRefused) {
  Mesh m = Icosphere(1);
  FlowParams p = Params("taubin", 1, 0.5);
  p.taubin_mu = 0.4;
  absl::Status s = Smooth(m, p).status();
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("mu > lambda"), std::string::npos) << s;
  p.taubin_mu = 0.0;
  p.taubin_pass_band = -0.1;
  s = Smooth(m, p).status();
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("pass band"), std::string::npos) << s;
}

}  // namespace
}  // namespace meshsmooth
