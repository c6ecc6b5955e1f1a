// WeldPoints: exact-position merging shared by the STL reader and the Draco decoder.
#include "core/weld.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <limits>

namespace meshsmooth {
namespace {

TEST(WeldTest, MergesEqualPositionsInOrderOfFirstAppearance) {
  const std::vector<Vec3> points = {{1, 2, 3}, {0, 0, 0}, {1, 2, 3}, {4, 5, 6}, {0, 0, 0}, {1, 2, 3.0000000001}};
  const Welded w = WeldPoints(points);
  EXPECT_EQ(w.point_to_vertex, (std::vector<int32_t>{0, 1, 0, 2, 1, 3}));
  ASSERT_EQ(w.positions.size(), 4u);
  EXPECT_EQ(w.positions[2], (Vec3{4, 5, 6}));
  EXPECT_EQ(w.positions[3], (Vec3{1, 2, 3.0000000001}));  // one ulp-scale apart is not equal
  EXPECT_EQ(w.merged, 2);
}

TEST(WeldTest, SignedZerosAreOnePointAndNanIsNeverMerged) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Vec3> points = {{0.0, -0.0, 1}, {-0.0, 0.0, 1}, {nan, 0, 0}, {nan, 0, 0}, {0.0, 0.0, 1}};
  const Welded w = WeldPoints(points);
  EXPECT_EQ(w.point_to_vertex, (std::vector<int32_t>{0, 0, 1, 2, 0}));
  EXPECT_EQ(w.merged, 2);
}

// A scan full of coincident points (or of NaN points) must not take quadratic time.
TEST(WeldTest, ManyIdenticalOrNanPointsStayLinear) {
  std::vector<Vec3> points(200000, Vec3{1, 1, 1});
  for (size_t i = 0; i < points.size(); i += 2) points[i] = {std::nan(""), 0, 0};
  const auto t0 = std::chrono::steady_clock::now();
  const Welded w = WeldPoints(points);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_EQ(w.positions.size(), 100001u);  // 100,000 NaN points kept apart, one (1, 1, 1)
  EXPECT_EQ(w.merged, 99999);
  EXPECT_EQ(w.point_to_vertex[1], 1);
  EXPECT_EQ(w.point_to_vertex[3], 1);
  EXPECT_LT(seconds, 5.0);  // quadratic would be ~10^10 comparisons; this is a hang guard, not a timing
}

TEST(WeldTest, EmptyInput) {
  const Welded w = WeldPoints({});
  EXPECT_TRUE(w.positions.empty());
  EXPECT_TRUE(w.point_to_vertex.empty());
  EXPECT_EQ(w.merged, 0);
}

}  // namespace
}  // namespace meshsmooth
