#include "gtest/gtest.h"
#include "tests/flow_fixtures.h"

namespace meshsmooth {
namespace {

using namespace meshsmooth::testing;

TEST(McfTangentialTest, WithoutTangentialWeightItIsMcf) {
  const Mesh noisy = NoisySphere(3);
  FlowParams p = Params("mcf_tangential", 10, 0.1);
  p.tangential_weight = 0.0;
  EXPECT_EQ(Smoothed(noisy, p).positions, Smoothed(noisy, Params("mcf", 10, 0.1)).positions);
}

// Eq. (11): the same smoothing as mcf, with the sampling made regular (Fig. 4g vs 4h).
TEST(McfTangentialTest, SmoothsLikeMcfAndRegularises) {
  const Mesh noisy = NoisySphere(4);
  const Mesh mcf = Smoothed(noisy, Params("mcf", 20, 0.1));
  const Mesh tan = Smoothed(noisy, Params("mcf_tangential", 20, 0.1));
  EXPECT_LT(RadiusError(tan), 1.2 * RadiusError(mcf));
  EXPECT_LT(EdgeCv(tan), 0.5 * EdgeCv(mcf));
  // The tangential part does not change the shape: volume as mcf's within 1%.
  EXPECT_NEAR(Volume(tan) / Volume(mcf), 1.0, 0.01);
}

TEST(McfTangentialTest, TangentialStepAboveOneIsRefused) {
  Mesh m = Icosphere(1);
  FlowParams p = Params("mcf_tangential", 1, 0.5);
  p.tangential_weight = 5.0;
  const absl::Status s = Smooth(m, p).status();
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("step * C"), std::string::npos) << s;
}

}  // namespace
}  // namespace meshsmooth
