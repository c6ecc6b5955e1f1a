// LocalFit::RobustRingHeight, the place a rim outlier is moved back to: the median height of its ring
// along a plane through its first and second rings that resists thrown points there.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <optional>
#include <vector>

#include "core/measure/metrics.h"
#include "core/measure/noise.h"
#include "core/shapes/parametric.h"
#include "core/topology.h"
#include "gtest/gtest.h"

namespace meshsmooth {
namespace {

double DegreesBetween(const Vec3& a, const Vec3& b) {
  return std::acos(std::min(1.0, std::abs(Dot(a, b)) / (Norm(a) * Norm(b)))) * 180.0 / std::numbers::pi;
}

// The vertices two rings from v (not in its first ring, not v).
std::vector<int32_t> SecondRing(const Topology& topo, int32_t v) {
  std::vector<uint8_t> near(topo.num_vertices(), 0);
  near[v] = 1;
  for (int32_t k = topo.ring_offsets[v]; k < topo.ring_offsets[v + 1]; ++k) near[topo.ring[k]] = 1;
  std::vector<int32_t> second;
  for (int32_t k = topo.ring_offsets[v]; k < topo.ring_offsets[v + 1]; ++k) {
    const int32_t w = topo.ring[k];
    for (int32_t j = topo.ring_offsets[w]; j < topo.ring_offsets[w + 1]; ++j) {
      const int32_t u = topo.ring[j];
      if (!near[u]) second.push_back(u);
      near[u] = 1;
    }
  }
  return second;
}

// A rim vertex of a flat grid thrown 2.3 h, with three of its second ring thrown 2 h the same way
// and not flagged: a least-squares plane through its dozen points leans by 48 degrees towards
// them and leaves the vertex more than a mean edge off when moved back. The robust one stays
// within a degree of the grid's, and the vertex goes back onto the grid. (An interior vertex goes
// back along the trimmed least-squares plane, which leans 27 degrees here: docs/decisions.md says
// why.)
TEST(LocalFitTest, RobustRingHeightResistsThrownPointsInTheSecondRing) {
  const Mesh plane = TwoRatePlane(24, 16, 1.0);
  const Topology topo = BuildTopology(plane);
  const double h = MeanEdgeLength(plane, topo);
  int32_t inner = -1, rim = -1;
  for (int32_t v = 0; v < plane.num_vertices(); ++v) {
    const Vec3& p = plane.positions[v];
    if (inner < 0 && topo.kind[v] == VertexKind::kInterior && p.x > 0.4 && p.y > 0.4) inner = v;
    if (rim < 0 && topo.kind[v] == VertexKind::kBoundary && p.y == 0.0 && p.x > 0.3) rim = v;
  }
  ASSERT_GE(inner, 0);
  ASSERT_GE(rim, 0);
  LocalFit fit;
  {
    const int32_t v = rim;
    Mesh m = plane;
    m.positions[v].z += 2.3 * h;
    const std::vector<int32_t> second = SecondRing(topo, v);
    ASSERT_GE(second.size(), 3u) << v;
    // Three neighbours side by side, as a scanner's streak throws them.
    for (size_t i = 0; i < 3; ++i) m.positions[second[i]].z += 2.0 * h;
    Vec3 axis;
    const std::optional<double> height = fit.RobustRingHeight(m.positions.data(), topo, v, h, nullptr, &axis);
    ASSERT_TRUE(height.has_value()) << v;
    EXPECT_LT(DegreesBetween(axis, Vec3{0, 0, 1}), 1.0) << v;
    const Vec3 back = m.positions[v] + axis * *height;
    EXPECT_NEAR(back.z, 0.0, 0.02 * h) << v;
  }
  // Nothing thrown: the grid's own normal, and height 0.
  Vec3 axis;
  const std::optional<double> height = fit.RobustRingHeight(plane.positions.data(), topo, inner, h, nullptr, &axis);
  ASSERT_TRUE(height.has_value());
  EXPECT_LT(DegreesBetween(axis, Vec3{0, 0, 1}), 1e-6);
  EXPECT_NEAR(*height, 0.0, 1e-12);
}

// On a coarse surface the second ring sags below the tangent plane: a cylinder 12 edges around
// has a rim vertex's second ring 60 degrees either side, sagging by about a mean edge. Those
// points are the surface, not outliers: kept, the plane leans no more than a least-squares plane
// through all of them (17.8 degrees at worst: a half ring on a tube this coarse is lopsided).
// Keeping only the points within the least-median plane's robust scale leans it by 23.
TEST(LocalFitTest, RobustRingHeightKeepsACurvedSecondRing) {
  const Mesh tube = Cylinder(1.0, 3.0, 12, CylinderRings(1.0, 3.0, 12));
  const Topology topo = BuildTopology(tube);
  const double h = MeanEdgeLength(tube, topo);
  LocalFit fit;
  double worst = 0.0;
  int rims = 0;
  for (int32_t v = 0; v < tube.num_vertices(); ++v) {
    if (topo.kind[v] != VertexKind::kBoundary) continue;
    ++rims;
    const Vec3& p = tube.positions[v];
    Vec3 axis;
    const std::optional<double> height = fit.RobustRingHeight(tube.positions.data(), topo, v, h, nullptr, &axis);
    ASSERT_TRUE(height.has_value()) << v;
    worst = std::max(worst, DegreesBetween(axis, Vec3{p.x, p.y, 0.0}));
  }
  EXPECT_EQ(rims, 24);
  EXPECT_LT(worst, 18.0);
}

}  // namespace
}  // namespace meshsmooth
