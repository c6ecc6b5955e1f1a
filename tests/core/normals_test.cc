#include "core/normals.h"

#include "core/shapes/parametric.h"
#include "gtest/gtest.h"

namespace meshsmooth {
namespace {

// On a sphere the area-weighted vertex normal is the radial direction, outward.
TEST(NormalsTest, SphereNormalsAreRadial) {
  const Mesh sphere = Icosphere(3);
  const std::vector<Vec3> normals = VertexNormals(sphere);
  ASSERT_EQ(normals.size(), sphere.positions.size());
  for (size_t i = 0; i < normals.size(); ++i) {
    EXPECT_NEAR(Norm(normals[i]), 1.0, 1e-12) << i;
    EXPECT_GT(Dot(normals[i], sphere.positions[i]), 0.999) << i;
  }
}

// Area weighting: a vertex shared by a large face and a small one leans toward the large
// face's normal; unusable faces count for nothing; a vertex without faces gets zero.
TEST(NormalsTest, AreaWeightedAndUnusableFacesIgnored) {
  Mesh m;
  // Vertex 0 at the origin; a big triangle in z = 0 (normal +z), a small one in x = 0
  // (normal +x), an unusable face, and an isolated vertex 5.
  m.positions = {{0, 0, 0}, {10, 0, 0}, {0, 10, 0}, {0, 1, 0}, {0, 0, 1}, {7, 7, 7}};
  m.triangles = {{0, 1, 2}, {0, 3, 4}, {0, 0, 5}, {0, 1, 99}};
  const std::vector<Vec3> n = VertexNormals(m);
  // Twice the areas are 100 and 1: the sum is (1, 0, 100).
  const Vec3 expected = Vec3{1, 0, 100} * (1.0 / std::sqrt(10001.0));
  EXPECT_NEAR(n[0].x, expected.x, 1e-15);
  EXPECT_NEAR(n[0].z, expected.z, 1e-15);
  EXPECT_EQ(n[1], (Vec3{0, 0, 1}));
  EXPECT_EQ(n[3], (Vec3{1, 0, 0}));
  EXPECT_EQ(n[5], Vec3{});
}

}  // namespace
}  // namespace meshsmooth
