#include "core/measure/evaluation.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/measure/metrics.h"
#include "core/measure/surface_distance.h"
#include "core/shapes/added_noise.h"
#include "core/shapes/parametric.h"
#include "core/topology.h"
#include "gtest/gtest.h"

namespace meshsmooth {
namespace {

constexpr double kPi = std::numbers::pi;

void ExpectVecNear(const Vec3& a, const Vec3& b, double tol) {
  EXPECT_NEAR(a.x, b.x, tol);
  EXPECT_NEAR(a.y, b.y, tol);
  EXPECT_NEAR(a.z, b.z, tol);
}

// The unit cube, faces outward: every face has a cube edge (dihedral 90 degrees).
Mesh Cube() {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  m.triangles = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
                 {3, 7, 6}, {3, 6, 2}, {0, 4, 7}, {0, 7, 3}, {1, 2, 6}, {1, 6, 5}};
  return m;
}

// Rotation of p about the unit axis u by angle t (Rodrigues).
Vec3 Rotate(const Vec3& p, const Vec3& u, double t) {
  return p * std::cos(t) + Cross(u, p) * std::sin(t) + u * (Dot(u, p) * (1.0 - std::cos(t)));
}

// The unit square patch folded along x = 0.5 so that its two halves' normals are `angle_deg`
// apart: a ridge of ny edges, each with one face on either side.
Mesh Fold(int nx, int ny, double angle_deg) {
  Mesh m = TwoRatePlane(nx, ny, 1.0);
  const double slope = std::tan(0.5 * angle_deg * kPi / 180.0);
  for (Vec3& p : m.positions) p.z = -slope * std::abs(p.x - 0.5);
  return m;
}

TEST(ClosestPointTest, AboveTheInterior) {
  const Vec3 a{0, 0, 0}, b{1, 0, 0}, c{0, 1, 0};
  ExpectVecNear(ClosestPointOnTriangle({0.2, 0.3, 0.7}, a, b, c), {0.2, 0.3, 0.0}, 1e-15);
  ExpectVecNear(ClosestPointOnTriangle({0.2, 0.3, -2.0}, a, b, c), {0.2, 0.3, 0.0}, 1e-15);
}

TEST(ClosestPointTest, BeyondEachEdge) {
  const Vec3 a{0, 0, 0}, b{1, 0, 0}, c{0, 1, 0};
  ExpectVecNear(ClosestPointOnTriangle({0.4, -1.0, 1.0}, a, b, c), {0.4, 0.0, 0.0}, 1e-15);  // ab
  ExpectVecNear(ClosestPointOnTriangle({-2.0, 0.7, 0.5}, a, b, c), {0.0, 0.7, 0.0}, 1e-15);  // ca
  ExpectVecNear(ClosestPointOnTriangle({1.0, 1.0, 3.0}, a, b, c), {0.5, 0.5, 0.0}, 1e-15);   // bc
  ExpectVecNear(ClosestPointOnTriangle({0.9, 0.3, -1.0}, a, b, c), {0.8, 0.2, 0.0}, 1e-15);  // bc
}

TEST(ClosestPointTest, BeyondEachCorner) {
  const Vec3 a{0, 0, 0}, b{1, 0, 0}, c{0, 1, 0};
  EXPECT_EQ(ClosestPointOnTriangle({-1.0, -0.5, 0.3}, a, b, c), a);
  EXPECT_EQ(ClosestPointOnTriangle({2.0, -0.1, 0.3}, a, b, c), b);
  EXPECT_EQ(ClosestPointOnTriangle({-0.1, 3.0, -1.0}, a, b, c), c);
  // The distance from beyond a corner is the distance to the corner.
  const Vec3 p{2.0, -1.0, 2.0};
  EXPECT_DOUBLE_EQ(Norm(p - ClosestPointOnTriangle(p, a, b, c)), std::sqrt(1.0 + 1.0 + 4.0));
}

TEST(ClosestPointTest, DegenerateTrianglesActAsSegments) {
  // Collinear corners: the segment from (0,0,0) to (2,0,0).
  ExpectVecNear(ClosestPointOnTriangle({1.5, 1.0, 0.0}, {0, 0, 0}, {2, 0, 0}, {1, 0, 0}), {1.5, 0, 0}, 1e-15);
  ExpectVecNear(ClosestPointOnTriangle({3.0, 1.0, 0.0}, {0, 0, 0}, {1, 0, 0}, {2, 0, 0}), {2, 0, 0}, 1e-15);
  // Two coincident corners, then all three.
  ExpectVecNear(ClosestPointOnTriangle({0.5, 0.0, 1.0}, {0, 0, 0}, {0, 0, 0}, {1, 0, 0}), {0.5, 0, 0}, 1e-15);
  EXPECT_EQ(ClosestPointOnTriangle({1.0, 1.0, 1.0}, {2, 2, 2}, {2, 2, 2}, {2, 2, 2}), (Vec3{2, 2, 2}));
}

TEST(SurfaceDistanceTest, MatchesBruteForceInsideNearAndFar) {
  Mesh m = Icosphere(3);
  AddRandomDirectionNoise(m, 0.3, 7);  // an irregular surface: the tree's boxes overlap
  const SurfaceDistance surface(m);
  EXPECT_EQ(surface.num_triangles(), m.num_triangles());
  int checked = 0;
  for (int32_t v = 0; v < m.num_vertices(); v += 7) {
    for (double scale : {0.2, 0.97, 1.03, 2.5}) {
      const Vec3 p = m.positions[v] * scale + Vec3{0.01, -0.02, 0.015};
      double brute = HUGE_VAL;
      for (const Triangle& t : m.triangles) {
        const Vec3 q = ClosestPointOnTriangle(p, m.positions[t[0]], m.positions[t[1]], m.positions[t[2]]);
        brute = std::min(brute, SquaredNorm(p - q));
      }
      ASSERT_NEAR(surface.SquaredDistance(p), brute, 1e-14 * brute) << v << " " << scale;
      // A bound that is not below the answer does not change it.
      ASSERT_NEAR(surface.SquaredDistance(p, 1.5 * brute), brute, 1e-14 * brute);
      // The nearest triangle is one at that distance (ties share an edge or a corner).
      double d2 = 0.0;
      const int32_t f = surface.NearestTriangle(p, &d2);
      ASSERT_GE(f, 0);
      const Triangle& t = m.triangles[f];
      ASSERT_NEAR(SquaredNorm(p - ClosestPointOnTriangle(p, m.positions[t[0]], m.positions[t[1]], m.positions[t[2]])),
                  brute, 1e-14 * brute);
      ASSERT_NEAR(d2, brute, 1e-14 * brute);
      ++checked;
    }
  }
  EXPECT_EQ(checked, 4 * ((m.num_vertices() + 6) / 7));
  EXPECT_EQ(surface.SquaredDistance(Vec3{0, 0, 0}, 1e-6), 1e-6);  // the bound when nothing is nearer
  EXPECT_TRUE(std::isnan(surface.SquaredDistance(Vec3{std::nan(""), 0, 0})));
  EXPECT_EQ(SurfaceDistance(Mesh{}).SquaredDistance(Vec3{1, 2, 3}), HUGE_VAL);
  EXPECT_EQ(SurfaceDistance(Mesh{}).NearestTriangle(Vec3{1, 2, 3}), -1);
  EXPECT_EQ(surface.NearestTriangle(Vec3{std::nan(""), 0, 0}), -1);
}

TEST(EvaluationTest, CleanMeshAgainstItselfIsZero) {
  const Mesh clean = Icosphere(3);
  const GroundTruth truth(clean);
  absl::StatusOr<Quality> q = truth.Evaluate(clean);
  ASSERT_TRUE(q.ok()) << q.status();
  EXPECT_EQ(q->rms_distance, 0.0);
  EXPECT_EQ(q->max_distance, 0.0);
  EXPECT_EQ(q->normal_error_deg, 0.0);
  EXPECT_TRUE(std::isnan(q->crease_normal_error_deg));  // a sphere has no crease
  EXPECT_EQ(q->volume_change_percent, 0.0);
  EXPECT_EQ(q->flipped_faces, 0);
  const MeshMetrics m = ComputeMetrics(clean, BuildTopology(clean));
  EXPECT_EQ(q->edge_length_cv, m.edge_length_cv);
  EXPECT_EQ(q->min_angle_deg, m.min_angle_deg);
  EXPECT_EQ(truth.measured_faces(), clean.num_triangles());
  EXPECT_EQ(truth.crease_faces(), 0);
  EXPECT_EQ(truth.mean_edge_length(), MeanEdgeLength(clean, BuildTopology(clean)));
}

TEST(EvaluationTest, SphereVerticesPushedOutByDAreAtD) {
  // Every point of the inscribed polyhedron is inside the unit ball, so (1 + d) v is exactly
  // d from the surface, at v.
  const Mesh clean = Icosphere(3);
  const GroundTruth truth(clean);
  const double d = 0.05;
  Mesh pushed = clean;
  for (Vec3& p : pushed.positions) p = p * (1.0 + d);
  absl::StatusOr<Quality> q = truth.Evaluate(pushed);
  ASSERT_TRUE(q.ok()) << q.status();
  const double h = truth.mean_edge_length();
  EXPECT_NEAR(q->rms_distance, d / h, 1e-12);
  EXPECT_NEAR(q->max_distance, d / h, 1e-12);
  EXPECT_NEAR(q->normal_error_deg, 0.0, 1e-6);  // a scaling turns no face
  EXPECT_NEAR(q->volume_change_percent, 100.0 * (std::pow(1.0 + d, 3) - 1.0), 1e-9);
}

TEST(EvaluationTest, SlidingAlongTheSurfaceIsNoDistance) {
  // The plane's inner vertices move within the plane: their own positions changed, the
  // surface did not (the vertex-to-vertex distance would count the move).
  const Mesh clean = TwoRatePlane(12, 10, 1.0);
  const GroundTruth truth(clean);
  const Topology& topo = truth.topology();
  Mesh slid = clean;
  for (int32_t v = 0; v < slid.num_vertices(); ++v) {
    if (topo.kind[v] == VertexKind::kInterior) slid.positions[v] += Vec3{0.02, -0.015, 0.0};
  }
  absl::StatusOr<Quality> q = truth.Evaluate(slid);
  ASSERT_TRUE(q.ok()) << q.status();
  EXPECT_NEAR(q->max_distance, 0.0, 1e-14);
  EXPECT_GT(CompareMeshes(clean, slid)->max, 0.02);
  EXPECT_EQ(q->normal_error_deg, 0.0);                // every face still faces +z
  EXPECT_TRUE(std::isnan(q->volume_change_percent));  // open: no volume
}

TEST(EvaluationTest, RotationTurnsEveryNormalByItsAngle) {
  const Mesh clean = Cube();
  const GroundTruth truth(clean);
  EXPECT_EQ(truth.crease_faces(), 12);
  EXPECT_TRUE(truth.closed());
  Mesh turned = clean;
  const Vec3 axis = Normalized({1.0, 2.0, 3.0}), centre{0.5, 0.5, 0.5};
  const double t = 10.0 * kPi / 180.0;
  for (Vec3& p : turned.positions) p = centre + Rotate(p - centre, axis, t);
  // A rotation by t about u turns a unit normal n by phi, cos phi = cos t + (u.n)^2 (1 - cos t):
  // the cube's normals are +-x, +-y, +-z, two faces each.
  double expected = 0.0;
  for (const Vec3& n : {Vec3{1, 0, 0}, Vec3{0, 1, 0}, Vec3{0, 0, 1}}) {
    const double un = Dot(axis, n);
    expected += std::acos(std::cos(t) + un * un * (1.0 - std::cos(t))) * 180.0 / kPi / 3.0;
  }
  absl::StatusOr<Quality> q = truth.Evaluate(turned);
  ASSERT_TRUE(q.ok()) << q.status();
  EXPECT_NEAR(q->normal_error_deg, expected, 1e-9);
  EXPECT_NEAR(q->crease_normal_error_deg, expected, 1e-9);
  EXPECT_GT(expected, 7.0);  // below t = 10: no normal is perpendicular to the axis
  EXPECT_NEAR(q->volume_change_percent, 0.0, 1e-9);
  EXPECT_EQ(q->flipped_faces, 0);
  EXPECT_GT(q->max_distance, 0.0);
}

TEST(EvaluationTest, CreaseFacesAreThoseOnEdgesSharperThanThirtyDegrees) {
  constexpr int kNx = 8, kNy = 6;
  EXPECT_EQ(GroundTruth(Fold(kNx, kNy, 40.0)).crease_faces(), 2 * kNy);
  EXPECT_EQ(GroundTruth(Fold(kNx, kNy, 20.0)).crease_faces(), 0);
  EXPECT_EQ(GroundTruth(Fold(kNx, kNy, 20.0), 15.0).crease_faces(), 2 * kNy);

  // Lifting one ridge vertex turns crease and plain faces alike; the crease mean is over the
  // 2 ny ridge faces only.
  const Mesh clean = Fold(kNx, kNy, 40.0);
  const GroundTruth truth(clean);
  Mesh lifted = clean;
  lifted.positions[2 * (kNx + 1) + kNx / 2].z += 0.05;  // row 2 of the ridge column
  absl::StatusOr<Quality> q = truth.Evaluate(lifted);
  ASSERT_TRUE(q.ok()) << q.status();
  EXPECT_GT(q->crease_normal_error_deg, q->normal_error_deg);  // 4 of 12 crease faces moved, 6 of 96 faces
  EXPECT_GT(q->normal_error_deg, 0.0);
}

// A clean mesh with a fold: unfolding it is a repair, not a flip; turning a face the fold does
// not touch still counts.
TEST(EvaluationTest, FacesFoldedInTheCleanMeshAreNotCountedAsFlipped) {
  const Mesh sphere = Icosphere(2);
  Mesh folded = sphere;
  folded.positions[0] = sphere.positions[0] * -0.5;  // through the sphere: its 5 faces fold
  const GroundTruth truth(folded);
  // The 5 faces around vertex 0 and the 5 faces across their outer edges.
  EXPECT_EQ(truth.folded_faces(), 10);
  absl::StatusOr<Quality> q = truth.Evaluate(sphere);  // the fold undone
  ASSERT_TRUE(q.ok()) << q.status();
  EXPECT_EQ(q->flipped_faces, 0);
  EXPECT_GT(q->normal_error_deg, 0.0);
  int32_t far = 0;  // the vertex opposite vertex 0, far from the fold
  for (int32_t v = 0; v < sphere.num_vertices(); ++v) {
    if (Dot(sphere.positions[v], sphere.positions[0]) < Dot(sphere.positions[far], sphere.positions[0])) far = v;
  }
  Mesh other = folded;
  other.positions[far] = folded.positions[far] * -0.5;
  q = truth.Evaluate(other);
  ASSERT_TRUE(q.ok()) << q.status();
  EXPECT_EQ(q->flipped_faces, 5);
  EXPECT_EQ(GroundTruth(sphere).folded_faces(), 0);
}

// Fine detail: the clean surface turns by more than 20 degrees within a face. On an icosphere(3)
// neighbouring vertex normals are ~4 degrees apart, on the 12-triangle cube's corners 70.5.
TEST(EvaluationTest, FlipsInFineDetailAreCountedApart) {
  const Mesh sphere = Icosphere(3);
  const GroundTruth smooth(sphere);
  EXPECT_EQ(smooth.fine_detail_faces(), 0);
  Mesh pulled = sphere;
  pulled.positions[0] = sphere.positions[0] * -0.5;
  absl::StatusOr<Quality> q = smooth.Evaluate(pulled);
  ASSERT_TRUE(q.ok()) << q.status();
  EXPECT_EQ(q->flipped_faces, 5);
  EXPECT_EQ(q->flipped_in_fine_detail, 0);

  const Mesh cube = Cube();
  const GroundTruth sharp(cube);
  EXPECT_EQ(sharp.fine_detail_faces(), cube.num_triangles());
  Mesh dented = cube;
  int32_t corner = 0;
  for (int32_t v = 0; v < cube.num_vertices(); ++v) {
    if (SquaredNorm(cube.positions[v]) < SquaredNorm(cube.positions[corner])) corner = v;
  }
  dented.positions[corner] = Vec3{1.5, 1.5, 1.5};  // the corner at the origin pushed through the cube
  q = sharp.Evaluate(dented);
  ASSERT_TRUE(q.ok()) << q.status();
  EXPECT_GT(q->flipped_faces, 0);
  EXPECT_EQ(q->flipped_in_fine_detail, q->flipped_faces);
}

TEST(EvaluationTest, VolumeOfAScaledCube) {
  const Mesh clean = Cube();
  const GroundTruth truth(clean);
  Mesh scaled = clean;
  for (Vec3& p : scaled.positions) p = Vec3{0.5, 0.5, 0.5} + (p - Vec3{0.5, 0.5, 0.5}) * 0.9;
  absl::StatusOr<Quality> q = truth.Evaluate(scaled);
  ASSERT_TRUE(q.ok()) << q.status();
  EXPECT_NEAR(q->volume_change_percent, 100.0 * (0.9 * 0.9 * 0.9 - 1.0), 1e-9);
  // Each corner moved (0.05, 0.05, 0.05) inward: 0.05 from its three faces.
  EXPECT_NEAR(q->max_distance, 0.05 / truth.mean_edge_length(), 1e-12);
}

TEST(EvaluationTest, FlippedFacesAndNonFiniteVertices) {
  const Mesh clean = Icosphere(2);
  const GroundTruth truth(clean);
  Mesh pulled = clean;
  pulled.positions[0] = clean.positions[0] * -0.5;  // through the sphere: its 5 faces flip
  absl::StatusOr<Quality> q = truth.Evaluate(pulled);
  ASSERT_TRUE(q.ok()) << q.status();
  EXPECT_EQ(q->flipped_faces, 5);
  EXPECT_GT(q->normal_error_deg, 0.0);

  Mesh broken = clean;
  broken.positions[3].y = std::nan("");
  q = truth.Evaluate(broken);
  ASSERT_TRUE(q.ok()) << q.status();
  EXPECT_EQ(q->non_finite_vertices, 1);
  EXPECT_TRUE(std::isnan(q->rms_distance));
  EXPECT_TRUE(std::isfinite(q->normal_error_deg));  // the faces without the vertex still count
}

TEST(EvaluationTest, ZeroAreaFacesHaveNoNormalError) {
  Mesh clean;
  clean.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {2, 0, 0}};
  clean.triangles = {{0, 1, 2}, {0, 1, 3}};  // the second is a segment
  const GroundTruth truth(clean);
  EXPECT_EQ(truth.measured_faces(), 1);
  Mesh moved = clean;
  moved.positions[3].z = 0.5;  // the sliver gains an area and a normal; the clean one had none
  absl::StatusOr<Quality> q = truth.Evaluate(moved);
  ASSERT_TRUE(q.ok()) << q.status();
  EXPECT_EQ(q->normal_error_deg, 0.0);
}

TEST(EvaluationTest, RefusesAnotherConnectivity) {
  const Mesh clean = Icosphere(1);
  const GroundTruth truth(clean);
  Mesh other = clean;
  other.triangles.pop_back();
  EXPECT_EQ(truth.Evaluate(other).status().code(), absl::StatusCode::kInvalidArgument);
  other = clean;
  other.positions.push_back({});
  EXPECT_EQ(truth.Evaluate(other).status().code(), absl::StatusCode::kInvalidArgument);
}

// What the noise tests measure: a 100 x 100 plane, its mean edge length h (the unit of the noise's
// sigma), and a copy displaced by `add_noise` with `sigma` and `seed`.
struct NoisyPlane {
  Mesh clean;
  double h;
  Mesh noisy;
};

NoisyPlane MakeNoisyPlane(void (*add_noise)(Mesh&, double, uint64_t), double sigma, uint64_t seed) {
  NoisyPlane p{TwoRatePlane(100, 100, 1.0), 0.0, {}};
  p.h = MeanEdgeLength(p.clean, BuildTopology(p.clean));
  p.noisy = p.clean;
  add_noise(p.noisy, sigma, seed);
  return p;
}

TEST(NoiseTest, NormalNoiseOnAPlaneIsGaussianAlongZ) {
  const double sigma = 0.2;
  const auto [clean, h, noisy] = MakeNoisyPlane(AddNormalNoise, sigma, 11);
  double sum = 0.0, sum2 = 0.0;
  int within_one_sigma = 0;
  for (int32_t v = 0; v < clean.num_vertices(); ++v) {
    ASSERT_EQ(noisy.positions[v].x, clean.positions[v].x);  // along the normal (0, 0, 1) only
    ASSERT_EQ(noisy.positions[v].y, clean.positions[v].y);
    const double z = noisy.positions[v].z / (sigma * h);
    sum += z;
    sum2 += z * z;
    within_one_sigma += std::abs(z) < 1.0;
  }
  const double n = clean.num_vertices();
  EXPECT_NEAR(sum / n, 0.0, 0.04);  // 4 standard errors of the mean
  EXPECT_NEAR(std::sqrt(sum2 / n), 1.0, 0.03);
  EXPECT_NEAR(within_one_sigma / n, 0.6827, 0.02);  // the normal law, not just its variance

  // The distance to the plane is |z|: the RMS distance is sigma, up to the sample.
  absl::StatusOr<Quality> q = GroundTruth(clean).Evaluate(noisy);
  ASSERT_TRUE(q.ok()) << q.status();
  EXPECT_NEAR(q->rms_distance, sigma * std::sqrt(sum2 / n), 1e-12);

  Mesh again = clean;
  AddNormalNoise(again, sigma, 11);
  EXPECT_EQ(again.positions, noisy.positions);
  Mesh other_seed = clean;
  AddNormalNoise(other_seed, sigma, 12);
  EXPECT_NE(other_seed.positions, noisy.positions);
}

TEST(NoiseTest, RandomDirectionNoiseHasAThirdOfItsVarianceAlongEachAxis) {
  const double sigma = 0.2;
  const auto [clean, h, noisy] = MakeNoisyPlane(AddRandomDirectionNoise, sigma, 3);
  double z2 = 0.0, d2 = 0.0;
  for (int32_t v = 0; v < clean.num_vertices(); ++v) {
    const Vec3 d = (noisy.positions[v] - clean.positions[v]) * (1.0 / (sigma * h));
    z2 += d.z * d.z;
    d2 += SquaredNorm(d);
  }
  const double n = clean.num_vertices();
  EXPECT_NEAR(d2 / n, 1.0, 0.05);
  EXPECT_NEAR(z2 / n, 1.0 / 3.0, 0.03);
  Mesh again = clean;
  AddRandomDirectionNoise(again, sigma, 3);
  EXPECT_EQ(again.positions, noisy.positions);
}

TEST(NoiseTest, VerticesWithoutFacesStayPut) {
  Mesh clean = Icosphere(1);
  clean.positions.push_back({5, 5, 5});  // referenced by no face
  Mesh noisy = clean;
  AddNormalNoise(noisy, 0.3, 1);
  EXPECT_EQ(noisy.positions.back(), clean.positions.back());
  AddRandomDirectionNoise(noisy, 0.3, 1);
  EXPECT_EQ(noisy.positions.back(), clean.positions.back());
  EXPECT_NE(noisy.positions.front(), clean.positions.front());
}

}  // namespace
}  // namespace meshsmooth
