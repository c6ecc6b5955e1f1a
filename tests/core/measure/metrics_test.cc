#include "core/measure/metrics.h"

#include <cmath>
#include <numbers>

#include "core/shapes/added_noise.h"
#include "core/shapes/parametric.h"
#include "core/topology.h"
#include "gtest/gtest.h"

namespace meshsmooth {
namespace {

constexpr double kPi = std::numbers::pi;

TEST(MetricsTest, Icosphere5AreaAndVolumeWithinOnePercent) {
  const Mesh m = Icosphere(5);
  const MeshMetrics mm = ComputeMetrics(m, BuildTopology(m));
  EXPECT_NEAR(mm.area, 4.0 * kPi, 0.01 * 4.0 * kPi);
  EXPECT_NEAR(mm.signed_volume, 4.0 * kPi / 3.0, 0.01 * 4.0 * kPi / 3.0);
  EXPECT_GT(mm.signed_volume, 0.0);  // faces point outward
  EXPECT_LT(mm.edge_length_cv, 0.2);
  EXPECT_GT(mm.min_angle_deg, 40.0);
  EXPECT_EQ(mm.share_angles_below_10deg, 0.0);
}

TEST(MetricsTest, RightTriangleAnglesAndEdges) {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  m.triangles = {{0, 1, 2}};
  const MeshMetrics mm = ComputeMetrics(m, BuildTopology(m));
  EXPECT_DOUBLE_EQ(mm.area, 0.5);
  EXPECT_NEAR(mm.min_angle_deg, 45.0, 1e-12);
  EXPECT_NEAR(mm.mean_angle_deg, 45.0, 1e-12);
  const double mean = (2.0 + std::sqrt(2.0)) / 3.0;
  EXPECT_NEAR(mm.edge_length_mean, mean, 1e-12);
  const double var = (2 * (1 - mean) * (1 - mean) + (std::sqrt(2.0) - mean) * (std::sqrt(2.0) - mean)) / 3.0;
  EXPECT_NEAR(mm.edge_length_cv, std::sqrt(var) / mean, 1e-12);
}

TEST(MetricsTest, NeedleTrianglesCountBelowTenDegrees) {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0.5, 0.01, 0}, {0.5, 0, 0}};
  m.triangles = {{0, 1, 2}, {0, 3, 1}};  // a needle and a zero-area sliver
  const MeshMetrics mm = ComputeMetrics(m, BuildTopology(m));
  EXPECT_NEAR(mm.share_angles_below_10deg, 4.0 / 6.0, 1e-12);
  EXPECT_EQ(mm.min_angle_deg, 0.0);
  EXPECT_TRUE(std::isfinite(mm.mean_angle_deg));
}

// A job computes the "after" metrics beside its encoder: the blocks then run as tasks of a
// team, and must give ComputeMetrics' bits whatever thread takes them; `beside` runs once. A
// mesh below kMetricsTeamMinVertices takes the path without a team, with the same bits.
TEST(MetricsTest, MetricsBesideOtherWorkKeepTheirBits) {
  for (int level : {6, 4}) {  // 82k faces: several blocks of faces and of vertices; 2,562 vertices
    Mesh m = Icosphere(level);
    AddUniformNoise(m, 0.3, 5);
    const Topology topo = BuildTopology(m);
    EXPECT_EQ(topo.num_vertices() < kMetricsTeamMinVertices, level == 4);
    const MeshMetrics alone = ComputeMetrics(m, topo);
    for (int threads : {0, 1, 3}) {
      int ran = 0;
      double beside_sum = 0.0;
      const MeshMetrics beside = ComputeMetricsBeside(
          m, topo,
          [&] {
            ++ran;
            for (const Vec3& p : m.positions) beside_sum += p.x;
          },
          threads);
      EXPECT_EQ(ran, 1) << level << " " << threads;
      EXPECT_NE(beside_sum, 0.0);
      EXPECT_EQ(beside.area, alone.area) << level << " " << threads;
      EXPECT_EQ(beside.signed_volume, alone.signed_volume) << level << " " << threads;
      EXPECT_EQ(beside.edge_length_mean, alone.edge_length_mean) << level << " " << threads;
      EXPECT_EQ(beside.edge_length_cv, alone.edge_length_cv) << level << " " << threads;
      EXPECT_EQ(beside.min_angle_deg, alone.min_angle_deg) << level << " " << threads;
      EXPECT_EQ(beside.mean_angle_deg, alone.mean_angle_deg) << level << " " << threads;
      EXPECT_EQ(beside.share_angles_below_10deg, alone.share_angles_below_10deg) << level << " " << threads;
    }
    EXPECT_GT(alone.area, 4.0 * kPi * 0.99);  // noise wrinkles the unit sphere: more area, not less
    EXPECT_GT(alone.edge_length_cv, 0.0);
  }
}

TEST(MetricsTest, DisplacementAndFlippedNormals) {
  const Mesh a = Icosphere(2);
  Mesh b = a;
  b.positions[0] += Vec3{0.0, 0.0, 0.03};
  b.positions[1] += Vec3{0.04, 0.0, 0.0};
  absl::StatusOr<Displacement> d = CompareMeshes(a, b);
  ASSERT_TRUE(d.ok());
  EXPECT_NEAR(d->max, 0.04, 1e-15);
  EXPECT_NEAR(d->rms, std::sqrt((0.0009 + 0.0016) / a.positions.size()), 1e-15);
  EXPECT_EQ(d->flipped_normals, 0);

  Mesh c = a;  // pull one vertex through the sphere: its fan flips
  c.positions[0] = a.positions[0] * -0.5;
  d = CompareMeshes(a, c);
  ASSERT_TRUE(d.ok());
  EXPECT_EQ(d->flipped_normals, 5);  // vertex 0 is a valence-5 icosahedron corner

  // The positions-only form (what a job keeps of its input) gives the same figures.
  absl::StatusOr<Displacement> p = CompareMeshes(a.positions, c);
  ASSERT_TRUE(p.ok());
  EXPECT_EQ(p->flipped_normals, 5);
  EXPECT_EQ(p->max, d->max);
  EXPECT_EQ(p->rms, d->rms);
  std::vector<Vec3> fewer = a.positions;
  fewer.pop_back();
  EXPECT_EQ(CompareMeshes(fewer, c).status().code(), absl::StatusCode::kInvalidArgument);

  Mesh e = a;
  e.triangles.pop_back();
  EXPECT_EQ(CompareMeshes(a, e).status().code(), absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace meshsmooth
