// A quick subset of the quality benchmark (bench/quality.cc, docs/quality.md) on a real mesh:
// the measures and the noise model give the figures their closed forms predict.
#include <cmath>

#include "core/flows/flow.h"
#include "core/io/mesh_io.h"
#include "core/measure/evaluation.h"
#include "core/shapes/added_noise.h"
#include "gtest/gtest.h"
#include "tests/test_data.h"

namespace meshsmooth {
namespace {

Mesh ReadFandisk() {
  absl::StatusOr<Mesh> m = ReadMesh(testing::SharedData("meshes").append("fandisk.obj").string());
  EXPECT_TRUE(m.ok()) << m.status();
  return m.ok() ? *std::move(m) : Mesh{};
}

TEST(QualityTest, FandiskAgainstItselfIsZero) {
  MESHSMOOTH_REQUIRE_SHARED("meshes");
  const Mesh clean = ReadFandisk();
  const GroundTruth truth(clean);
  EXPECT_TRUE(truth.closed());
  EXPECT_EQ(truth.measured_faces(), 12946);
  // The CAD part's feature lines: a few hundred faces of its 12,946 sit on a sharp edge.
  EXPECT_GT(truth.crease_faces(), 300);
  EXPECT_LT(truth.crease_faces(), 2000);
  absl::StatusOr<Quality> q = truth.Evaluate(clean);
  ASSERT_TRUE(q.ok()) << q.status();
  EXPECT_EQ(q->rms_distance, 0.0);
  EXPECT_EQ(q->max_distance, 0.0);
  EXPECT_EQ(q->normal_error_deg, 0.0);
  EXPECT_EQ(q->crease_normal_error_deg, 0.0);
  EXPECT_EQ(q->volume_change_percent, 0.0);
  EXPECT_EQ(q->flipped_faces, 0);
}

// Gaussian noise of sigma h along the normals: a vertex's distance to the surface is at most
// its offset (less where the nearest point is on another face, as across a crease), so the RMS
// distance is at most sigma and close to it. On a flat region of near-equilateral triangles the
// face normal tilts by atan |g|, the gradient g of the heights having two independent components
// of standard deviation sqrt(2) sigma each: |g| is Rayleigh with mean sigma sqrt(pi), 0.354 at
// sigma = 0.2, about 19 degrees after the arctangent.
TEST(QualityTest, FandiskNormalNoiseMatchesTheNoiseModel) {
  MESHSMOOTH_REQUIRE_SHARED("meshes");
  const GroundTruth truth(ReadFandisk());
  Mesh noisy = truth.mesh();
  AddNormalNoise(noisy, 0.2, 1);
  absl::StatusOr<Quality> q = truth.Evaluate(noisy);
  ASSERT_TRUE(q.ok()) << q.status();
  EXPECT_GT(q->rms_distance, 0.18);
  EXPECT_LT(q->rms_distance, 0.205);
  EXPECT_GT(q->max_distance, 3.0 * 0.2);  // 6,475 Gaussian samples reach past 3 sigma
  EXPECT_LT(q->max_distance, 5.0 * 0.2);
  EXPECT_GT(q->normal_error_deg, 16.0);
  EXPECT_LT(q->normal_error_deg, 22.0);
  EXPECT_NEAR(q->volume_change_percent, 0.0, 0.5);  // zero-mean offsets keep the volume
  EXPECT_EQ(q->non_finite_vertices, 0);

  // Random directions: a third of the variance is normal to the surface.
  Mesh random = truth.mesh();
  AddRandomDirectionNoise(random, 0.2, 1);
  absl::StatusOr<Quality> r = truth.Evaluate(random);
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_NEAR(r->rms_distance, 0.2 / std::sqrt(3.0), 0.01);
  EXPECT_LT(r->normal_error_deg, q->normal_error_deg);
}

// What the benchmark's oracle rows rest on: a flow at a good iteration count takes the noisy
// mesh closer to the clean one, in distance and in normals.
TEST(QualityTest, FandiskBilaplacianAtItsBestCountBeatsTheNoise) {
  MESHSMOOTH_REQUIRE_SHARED("meshes");
  const GroundTruth truth(ReadFandisk());
  Mesh noisy = truth.mesh();
  AddNormalNoise(noisy, 0.2, 1);
  const Quality before = *truth.Evaluate(noisy);
  double best_rms = HUGE_VAL, best_normal = HUGE_VAL;
  Topology topo = truth.topology();  // lent to each run
  for (int iterations : {1, 2, 3, 5, 8}) {
    Mesh m = noisy;
    FlowParams p;
    p.flow = FlowId::kBilaplacian;
    p.iterations = iterations;
    ASSERT_TRUE(Smooth(m, topo, p).ok());
    const Quality q = *truth.Evaluate(m);
    if (q.rms_distance < best_rms) {
      best_rms = q.rms_distance;
      best_normal = q.normal_error_deg;
    }
  }
  EXPECT_LT(best_rms, 0.7 * before.rms_distance);
  EXPECT_LT(best_normal, 0.7 * before.normal_error_deg);
}

}  // namespace
}  // namespace meshsmooth
