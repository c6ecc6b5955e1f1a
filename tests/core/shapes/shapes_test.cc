#include "core/shapes/added_noise.h"
#include "core/shapes/marching_tetrahedra.h"
#include "core/shapes/parametric.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/measure/metrics.h"
#include "core/topology.h"
#include "gtest/gtest.h"
#include "tests/topology_checks.h"

namespace meshsmooth {
namespace {

using testing::IsClosedManifold;

TEST(ShapesTest, IcosphereCountsAndUnitRadius) {
  for (int level = 0; level <= 4; ++level) {
    const Mesh m = Icosphere(level);
    EXPECT_EQ(m.positions.size(), 10u * (1u << (2 * level)) + 2);
    EXPECT_EQ(m.triangles.size(), 20u * (1u << (2 * level)));
    for (const Vec3& p : m.positions) ASSERT_NEAR(Norm(p), 1.0, 1e-15);
  }
}

TEST(ShapesTest, TwoRateTorusIsClosedGenusOneWithTwoSpacings) {
  const double R = 1.0, r = 0.25;
  int32_t dense = 0;
  const Mesh m = TwoRateTorus(32, R, r, &dense);
  ValidationReport rep;
  const Topology t = BuildTopology(m, &rep);
  EXPECT_TRUE(IsClosedManifold(rep, 0));
  EXPECT_EQ(rep.inconsistently_oriented_edges, 0);
  const MeshMetrics mm = ComputeMetrics(m, t);
  const double volume = 2.0 * std::numbers::pi * std::numbers::pi * R * r * r;
  EXPECT_NEAR(mm.signed_volume, volume, 0.03 * volume);  // outward, close to the smooth torus
  // Mean edge length in each half: the coarse half's edges are about twice as long.
  double sum[2] = {0, 0};
  int count[2] = {0, 0};
  for (int32_t v = 0; v < t.num_vertices(); ++v) {
    for (int32_t i = t.ring_offsets[v]; i < t.ring_offsets[v + 1]; ++i) {
      const int32_t w = t.ring[i];
      if (v < w && (v < dense) == (w < dense)) {
        sum[v < dense ? 0 : 1] += Norm(m.positions[v] - m.positions[w]);
        ++count[v < dense ? 0 : 1];
      }
    }
  }
  EXPECT_NEAR((sum[1] / count[1]) / (sum[0] / count[0]), 2.0, 0.1);
  EXPECT_GT(dense, m.num_vertices() / 2);
}

TEST(ShapesTest, TwoRatePlaneHasOneBoundaryLoop) {
  const Mesh m = TwoRatePlane(48, 32, 3.0);
  ValidationReport rep;
  const Topology t = BuildTopology(m, &rep);
  EXPECT_EQ(rep.boundary_loops, 1);
  EXPECT_EQ(rep.boundary_edges, 2 * (48 + 32));
  EXPECT_EQ(rep.euler_characteristic(), 1);
  const MeshMetrics mm = ComputeMetrics(m, t);
  EXPECT_NEAR(mm.area, 1.0, 1e-12);
  int interior = 0;
  for (VertexKind k : t.kind) interior += k == VertexKind::kInterior;
  EXPECT_EQ(interior, 47 * 31);
}

TEST(ShapesTest, CylinderIsAnOpenTubeOfNearEquilateralTriangles) {
  const double r = 2.0, height = 6.0;
  const int around = 64, along = CylinderRings(r, height, around);
  const Mesh m = Cylinder(r, height, around, along);
  ValidationReport rep;
  const Topology t = BuildTopology(m, &rep);
  EXPECT_EQ(m.num_vertices(), around * along);
  EXPECT_EQ(rep.boundary_loops, 2);
  EXPECT_TRUE(rep.manifold());
  EXPECT_EQ(rep.euler_characteristic(), 0);
  EXPECT_EQ(rep.inconsistently_oriented_edges, 0);
  for (const Vec3& p : m.positions) ASSERT_NEAR(std::hypot(p.x, p.y), r, 1e-12);
  const MeshMetrics mm = ComputeMetrics(m, t);
  EXPECT_GT(mm.min_angle_deg, 55.0);
  EXPECT_NEAR(mm.area, 2.0 * std::numbers::pi * r * height, 0.01 * 2.0 * std::numbers::pi * r * height);
  for (const Triangle& tri : m.triangles) {  // outward: the face normal points away from the axis
    const Vec3 a = m.positions[tri[0]], b = m.positions[tri[1]], c = m.positions[tri[2]];
    const Vec3 centre = (a + b + c) * (1.0 / 3.0);
    ASSERT_GT(Dot(Cross(b - a, c - a), Vec3{centre.x, centre.y, 0.0}), 0.0);
  }
}

TEST(ShapesTest, CosineHeightFieldHasCrestsOnRowsAndUpwardFaces) {
  const int periods = 2, rows_per_period = 24, columns = 10;
  const Mesh m = CosineHeightField(0.5, periods, rows_per_period, columns);
  ValidationReport rep;
  const Topology t = BuildTopology(m, &rep);
  EXPECT_EQ(m.num_vertices(), (periods * rows_per_period + 1) * columns);
  EXPECT_EQ(rep.boundary_loops, 1);
  EXPECT_TRUE(rep.manifold());
  EXPECT_EQ(rep.euler_characteristic(), 1);
  for (int32_t v = 0; v < m.num_vertices(); ++v) {
    const Vec3& p = m.positions[v];
    ASSERT_NEAR(p.z, 0.5 * std::cos(p.x), 1e-15);
    const int row = v / columns;
    const double on_line =
        row % rows_per_period == 0 ? 1.0 : (row % rows_per_period == rows_per_period / 2 ? -1.0 : 0.0);
    if (on_line != 0.0) {
      ASSERT_NEAR(std::cos(p.x), on_line, 1e-12) << v;  // crest and trough rows
    }
  }
  for (const Triangle& tri : m.triangles) {
    const Vec3 a = m.positions[tri[0]];
    ASSERT_GT(Cross(m.positions[tri[1]] - a, m.positions[tri[2]] - a).z, 0.0);
  }
  // Equilateral in the xy plane: the projected angles are all 60 degrees.
  Mesh flat = m;
  for (Vec3& p : flat.positions) p.z = 0.0;
  EXPECT_NEAR(ComputeMetrics(flat, t).min_angle_deg, 60.0, 1e-9);
}

TEST(ShapesTest, NoiseIsSeededAndBounded) {
  const Mesh clean = Icosphere(3);
  Mesh a = clean, b = clean, c = clean;
  AddUniformNoise(a, 0.3, 42);
  AddUniformNoise(b, 0.3, 42);
  AddUniformNoise(c, 0.3, 43);
  EXPECT_EQ(a.positions, b.positions);
  EXPECT_NE(a.positions, c.positions);
  const double h = MeanEdgeLength(clean, BuildTopology(clean));
  double max_dev = 0.0, sum = 0.0;
  for (size_t i = 0; i < clean.positions.size(); ++i) {
    const Vec3 d = a.positions[i] - clean.positions[i];
    for (double x : {d.x, d.y, d.z}) {
      max_dev = std::max(max_dev, std::abs(x));
      sum += x;
    }
  }
  EXPECT_LE(max_dev, 0.3 * h);
  EXPECT_GT(max_dev, 0.28 * h);                                      // the range is used, not a fraction of it
  EXPECT_NEAR(sum / (3.0 * clean.positions.size()), 0.0, 0.02 * h);  // zero mean
}

TEST(ShapesTest, ImpulsiveNoiseThrowsItsShareAlongTheNormals) {
  const Mesh clean = Icosphere(5);
  Mesh a = clean, b = clean;
  AddImpulsiveNoise(a, 0.1, 1.0, 7);
  AddImpulsiveNoise(b, 0.1, 1.0, 7);
  EXPECT_EQ(a.positions, b.positions);
  const double h = MeanEdgeLength(clean, BuildTopology(clean));
  int64_t thrown = 0, out = 0;
  for (size_t i = 0; i < clean.positions.size(); ++i) {
    const Vec3 d = a.positions[i] - clean.positions[i];
    if (d == Vec3{}) continue;
    ++thrown;
    const double along = Dot(d, clean.positions[i]);  // the unit sphere's normal is the position
    out += along > 0.0;
    EXPECT_NEAR(std::abs(along), Norm(d), 1e-2 * h);  // along the normal (the mesh's, close to the sphere's)
    EXPECT_GE(Norm(d), 0.999 * h);
    EXPECT_LE(Norm(d), 3.001 * h);
  }
  const auto n = static_cast<double>(clean.positions.size());
  EXPECT_NEAR(thrown / n, 0.1, 0.01);
  EXPECT_NEAR(out / static_cast<double>(thrown), 0.5, 0.05);
}

TEST(ShapesTest, MarchingTetrahedraTorusIsClosedOutwardAndOnTheSurface) {
  const double R = 1.0, r = 0.4, step = 0.05;
  auto torus = [&](const Vec3& p) { return std::hypot(std::hypot(p.x, p.y) - R, p.z) - r; };
  const Mesh m = MarchingTetrahedra(torus, Vec3{-1.5, -1.5, -0.5}, Vec3{1.5, 1.5, 0.5}, step);
  ValidationReport rep;
  const Topology t = BuildTopology(m, &rep);
  EXPECT_TRUE(IsClosedManifold(rep, 0));  // genus 1
  EXPECT_EQ(rep.inconsistently_oriented_edges, 0);
  EXPECT_EQ(rep.connected_components, 1);
  // Every vertex lies on a tetrahedron's edge (up to sqrt(3) step long), where the linear
  // interpolation of a distance function of curvature at most 1 / r is off by at most L^2 / (8 r).
  double worst = 0.0;
  for (const Vec3& p : m.positions) worst = std::max(worst, std::abs(torus(p)));
  EXPECT_LT(worst, 3.0 * step * step / (8.0 * r));
  // Outward, and the volume 2 pi^2 R r^2 within the chords' shortfall.
  const double exact = 2.0 * std::numbers::pi * std::numbers::pi * R * r * r;
  const MeshMetrics metrics = ComputeMetrics(m, t);
  EXPECT_GT(metrics.signed_volume, 0.98 * exact);
  EXPECT_LT(metrics.signed_volume, exact);
  // Iso-surface output: needles and slivers, which is why the benchmark uses it.
  EXPECT_LT(metrics.min_angle_deg, 1.0);
}

TEST(ShapesTest, HoleySphereHasOneLoopPerHole) {
  const Mesh m = HoleySphere(5, 60, 0.07, 7);
  ValidationReport rep;
  BuildTopology(m, &rep);
  EXPECT_TRUE(rep.manifold());
  EXPECT_EQ(rep.boundary_loops, 60);
  EXPECT_EQ(rep.unreferenced_vertices, 0);
  EXPECT_EQ(rep.connected_components, 1);
  EXPECT_EQ(rep.euler_characteristic(), 2 - 60);  // a sphere with 60 disks taken out
  for (const Vec3& p : m.positions) ASSERT_NEAR(Norm(p), 1.0, 1e-15);
  EXPECT_LT(m.positions.size(), Icosphere(5).positions.size() * 95 / 100);  // the holes take area
  EXPECT_EQ(HoleySphere(5, 60, 0.07, 7).positions, m.positions);            // seeded
}

TEST(ShapesTest, SliverShaftIsAClosedPartOfSlivers) {
  const int around = 128;
  const Mesh m = SliverShaft(around);
  ASSERT_EQ(m.positions.size(), 4u * around + 2);
  ASSERT_EQ(m.triangles.size(), 8u * around);
  ValidationReport rep;
  BuildTopology(m, &rep);
  EXPECT_TRUE(IsClosedManifold(rep, 2));
  const MeshMetrics metrics = ComputeMetrics(m, BuildTopology(m));
  // Two prisms on regular 128-gons (area n/2 r^2 sin(2 pi / n)), one unit high each: positive,
  // so every face faces outward.
  const double polygon = 0.5 * around * std::sin(2.0 * std::numbers::pi / around);
  EXPECT_NEAR(metrics.signed_volume, polygon * (0.25 + 0.09), 1e-12);
  // Slivers: a side's right triangles, legs the chord (0.0147 at radius 0.3) and 1: 0.84 degrees.
  EXPECT_LT(metrics.min_angle_deg, 1.0);
  EXPECT_GT(metrics.min_angle_deg, 0.5);
}

TEST(Vec3Test, RoundToFloatRoundsEveryComponent) {
  std::vector<Vec3> v(8, Vec3{0.1, 0.2, 0.3});
  for (Vec3& p : v) p = RoundToFloat(p);
  for (const Vec3& p : v) {
    EXPECT_EQ(p.x, static_cast<double>(0.1f));
    EXPECT_EQ(p.y, static_cast<double>(0.2f));
    EXPECT_EQ(p.z, static_cast<double>(0.3f));
  }
}

}  // namespace
}  // namespace meshsmooth
