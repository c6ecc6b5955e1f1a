#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Tools/Smoother/JacobiLaplaceSmootherT.hh>

#include "gtest/gtest.h"
#include "tests/flow_fixtures.h"

namespace meshsmooth {
namespace {

using namespace meshsmooth::testing;

// An interior vertex P with an irregular hexagonal ring (ring vertices are boundary: fixed).
Mesh HexFixture() {
  Mesh m;
  m.positions = {{0.1, 0.2, 0.3}, {1, 0, 0},       {0.5, 0.9, 0},    {-0.5, 0.8, 0.1},
                 {-1, 0, 0},      {-0.5, -0.9, 0}, {0.6, -0.8, -0.2}};
  for (int k = 0; k < 6; ++k) m.triangles.push_back({0, 1 + k, 1 + (k + 1) % 6});
  return m;
}

TEST(LaplacianTest, U0MatchesHandComputation) {
  Mesh m = HexFixture();
  // U0 = mean(ring) - P = (0.1/6, 0, -0.1/6) - (0.1, 0.2, 0.3); P + 0.5 U0 by hand:
  ASSERT_TRUE(Smooth(m, Params("laplacian", 1, 0.5)).ok());
  EXPECT_NEAR(m.positions[0].x, 0.35 / 6.0, 1e-15);
  EXPECT_NEAR(m.positions[0].y, 0.1, 1e-15);
  EXPECT_NEAR(m.positions[0].z, 0.85 / 6.0, 1e-15);
  for (int v = 1; v <= 6; ++v) EXPECT_EQ(m.positions[v], HexFixture().positions[v]);  // boundary fixed
}

TEST(LaplacianTest, U1UsesInverseDistanceWeights) {
  Mesh m = HexFixture();
  const Mesh orig = m;
  Vec3 sum;
  double wsum = 0.0;
  for (int k = 1; k <= 6; ++k) {
    const double w = 1.0 / Norm(orig.positions[k] - orig.positions[0]);
    sum += orig.positions[k] * w;
    wsum += w;
  }
  const Vec3 expected = orig.positions[0] + (sum * (1.0 / wsum) - orig.positions[0]) * 0.3;
  FlowParams p = Params("laplacian", 1, 0.3);
  p.weights = UmbrellaWeights::kInverseDistance;
  ASSERT_TRUE(Smooth(m, p).ok());
  EXPECT_NEAR(m.positions[0].x, expected.x, 1e-15);
  EXPECT_NEAR(m.positions[0].y, expected.y, 1e-15);
  EXPECT_NEAR(m.positions[0].z, expected.z, 1e-15);
}

struct DoubleTraits : OpenMesh::DefaultTraits {
  typedef OpenMesh::Vec3d Point;
  typedef OpenMesh::Vec3d Normal;
};
using OMesh = OpenMesh::TriMesh_ArrayKernelT<DoubleTraits>;

// On a closed mesh OpenMesh's JacobiLaplaceSmootherT (Tangential_and_Normal,
// C0) is a uniform Laplacian step with lambda = 0.5.
TEST(LaplacianTest, EqualsOpenMeshJacobiLaplaceOnClosedMesh) {
  Mesh m = NoisySphere(3);
  OMesh om;
  std::vector<OMesh::VertexHandle> vh;
  for (const Vec3& p : m.positions) vh.push_back(om.add_vertex({p.x, p.y, p.z}));
  for (const Triangle& t : m.triangles) om.add_face(vh[t[0]], vh[t[1]], vh[t[2]]);
  OpenMesh::Smoother::JacobiLaplaceSmootherT<OMesh> smoother(om);
  smoother.initialize(OpenMesh::Smoother::JacobiLaplaceSmootherT<OMesh>::Tangential_and_Normal,
                      OpenMesh::Smoother::JacobiLaplaceSmootherT<OMesh>::C0);
  smoother.smooth(7);
  ASSERT_TRUE(Smooth(m, Params("laplacian", 7, 0.5)).ok());
  double worst = 0.0;
  for (auto v : om.vertices()) {
    const auto& q = om.point(v);
    worst = std::max(worst, Norm(m.positions[v.idx()] - Vec3{q[0], q[1], q[2]}));
  }
  EXPECT_LT(worst, 1e-12);
}

TEST(LaplacianTest, AreaAndVolumeShrink) {
  Mesh m = NoisySphere(3);
  double area = ComputeMetrics(m, BuildTopology(m)).area;
  for (int round = 0; round < 5; ++round) {
    ASSERT_TRUE(Smooth(m, Params("laplacian", 4, 0.5)).ok());
    const double next = ComputeMetrics(m, BuildTopology(m)).area;
    EXPECT_LT(next, area);
    area = next;
  }
}

TEST(LaplacianTest, StepOutOfRangeIsRefused) {
  Mesh m = Icosphere(1);
  for (double bad : {0.0, -0.1, 1.5, std::numeric_limits<double>::quiet_NaN()}) {
    const absl::Status s = Smooth(m, Params("laplacian", 1, bad)).status();
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << bad;
    EXPECT_NE(s.message().find("step"), std::string::npos) << s;
  }
}

}  // namespace
}  // namespace meshsmooth
