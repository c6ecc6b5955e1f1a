// Automatic stopping (FlowParams::iterations == kAutoIterations; core/flows/auto_stop.h) and the
// noise estimate it rests on (core/noise.h), measured against the clean surface.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "core/evaluation.h"
#include "core/flows/auto_stop.h"
#include "core/flows/flow.h"
#include "core/flows/flow_kernel.h"
#include "core/io/mesh_io.h"
#include "core/metrics.h"
#include "core/noise.h"
#include "core/shapes.h"
#include "core/topology.h"
#include "gtest/gtest.h"
#include "tests/test_data.h"

namespace meshsmooth {
namespace {

double EstimateOf(const Mesh& clean, const Mesh& noisy, int threads = 0) {
  const Topology topo = BuildTopology(clean);
  return EstimateNoise(noisy, topo, MeanEdgeLength(clean, topo), threads).sigma_h;
}

// Gaussian offsets of sigma h along the normals read back as sigma: the fit's own variance is
// taken out (noise.h), so no calibration constant hides in the estimate.
TEST(NoiseEstimateTest, ReadsGaussianNoiseAlongTheNormals) {
  const Mesh clean = Icosphere(4);
  EXPECT_LT(EstimateOf(clean, clean), 0.005) << "a clean sphere is a quadric to a cubic fit";
  for (double sigma : {0.05, 0.1, 0.2, 0.3}) {
    Mesh noisy = clean;
    AddNormalNoise(noisy, sigma, 7);
    const double e = EstimateOf(clean, noisy);
    std::printf("sigma %.2f h: estimate %.4f h\n", sigma, e);
    EXPECT_NEAR(e, sigma, 0.06 * sigma) << sigma;
  }
  // Random directions: only the normal component, sigma / sqrt(3), is noise to a surface; the
  // tangential part moves the fit's sample points too and reads a little lower (0.82x here).
  Mesh random = clean;
  AddRandomDirectionNoise(random, 0.3, 7);
  const double normal_part = 0.3 / std::sqrt(3.0);
  EXPECT_GT(EstimateOf(clean, random), 0.75 * normal_part);
  EXPECT_LT(EstimateOf(clean, random), 1.05 * normal_part);
}

TEST(NoiseEstimateTest, SameForAnyThreadCount) {
  const Mesh clean = Icosphere(6);  // 40,962 vertices: parallel, and sampled
  Mesh noisy = clean;
  AddNormalNoise(noisy, 0.2, 3);
  EXPECT_EQ(EstimateOf(clean, noisy, 1), EstimateOf(clean, noisy, 2));
  EXPECT_NEAR(EstimateOf(clean, noisy, 2), 0.2, 0.01);
}

TEST(AutoStopTest, CleanMeshComesBackUnchanged) {
  const Mesh clean = TwoRateTorus();
  Mesh m = clean;
  FlowParams p;  // the defaults: the default flow, automatic stopping
  ASSERT_EQ(p.iterations, kAutoIterations);
  absl::StatusOr<FlowResult> r = Smooth(m, p);
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->iterations_run, 0);
  EXPECT_EQ(r->stop_reason, StopReason::kNoNoise);
  ASSERT_TRUE(r->auto_stop.has_value());
  EXPECT_LT(r->auto_stop->noise_sigma_h, 0.02);
  EXPECT_EQ(m.positions, clean.positions);
}

// Automatic stopping on a noisy closed surface: far closer to the clean one, its volume kept,
// no face turned over.
TEST(AutoStopTest, NoisySphereComesBackCloserWithItsVolume) {
  const GroundTruth truth(Icosphere(4));
  for (double sigma : {0.1, 0.2, 0.3}) {
    Mesh m = truth.mesh();
    AddNormalNoise(m, sigma, 11);
    const absl::StatusOr<Quality> before = truth.Evaluate(m);
    const double input_volume = ComputeMetrics(m, BuildTopology(m)).signed_volume;
    absl::StatusOr<FlowResult> r = Smooth(m, FlowParams{});
    ASSERT_TRUE(r.ok()) << r.status();
    const absl::StatusOr<Quality> after = truth.Evaluate(m);
    ASSERT_TRUE(before.ok() && after.ok());
    std::printf("sigma %.1f: %d iterations (%s), estimate %.3f h, moved %.3f h; RMS %.4f -> %.4f h, normal %.2f -> %.2f deg\n",
                sigma, r->iterations_run, std::string(StopReasonName(r->stop_reason)).c_str(),
                r->auto_stop->noise_sigma_h, r->auto_stop->displacement_h, before->rms_distance, after->rms_distance,
                before->normal_error_deg, after->normal_error_deg);
    // A sphere is what the bilaplacian flow with the volume kept converges to: the estimated
    // error keeps falling, and the run goes on to the cap or until it stops improving.
    EXPECT_LE(r->iterations_run, kMaxAutoIterations);
    EXPECT_LT(after->rms_distance, 0.25 * before->rms_distance) << sigma;
    EXPECT_LT(after->normal_error_deg, 0.1 * before->normal_error_deg) << sigma;
    EXPECT_EQ(after->flipped_faces, 0);
    EXPECT_NEAR(ComputeMetrics(m, BuildTopology(m)).signed_volume / input_volume, 1.0, 1e-6) << "volume kept";
  }
}

// No mesh that validates as manifold fails with the default job: needles (a tube of 4 x 0.13
// triangles) with noise; every coordinate stays finite. (Fans of huge valence:
// tests/core/long_work_test.cc.)
TEST(AutoStopTest, DefaultJobNeverFailsOnNeedles) {
  std::vector<std::pair<std::string, Mesh>> meshes;
  meshes.emplace_back("needle tube", Cylinder(1.0, 20.0, 48, 6));
  for (auto& [name, clean] : meshes) {
    for (double sigma : {0.0, 0.1, 0.3}) {
      Mesh m = clean;
      if (sigma > 0.0) AddNormalNoise(m, sigma, 5);
      const Topology topo = BuildTopology(m);
      absl::StatusOr<FlowResult> r = Smooth(m, topo, FlowParams{});
      ASSERT_TRUE(r.ok()) << name << " sigma " << sigma << ": " << r.status();
      for (const Vec3& p : m.positions) ASSERT_TRUE(IsFinite(p)) << name;
      std::printf("%s, sigma %.1f: %d iterations (%s)\n", name.c_str(), sigma, r->iterations_run,
                  std::string(StopReasonName(r->stop_reason)).c_str());
      if (name == "needle tube" && sigma > 0.0) {
        EXPECT_GT(r->iterations_run, 0) << "the tube's middle rings allow an estimate";
      }
    }
  }
}

int FlippedFaces(const std::vector<Vec3>& pos, const Mesh& clean) {
  int flipped = 0;
  for (const Triangle& t : clean.triangles) {
    const Vec3 now = Cross(pos[t[1]] - pos[t[0]], pos[t[2]] - pos[t[0]]);
    const Vec3 was = Cross(clean.positions[t[1]] - clean.positions[t[0]], clean.positions[t[2]] - clean.positions[t[0]]);
    flipped += Dot(now, was) < 0.0;
  }
  return flipped;
}

// The fold repair on needles: an icosphere whose every fifth face is split by a point a
// hundredth of the face's height from one edge, each such point then mirrored across that edge
// (its needle folded over). The repair unfolds every one, and moves no vertex further than
// kFoldRepairReachH h.
TEST(AutoStopTest, FoldRepairUnfoldsNeedlesWithinItsReach) {
  Mesh clean = Icosphere(3);
  struct Needle {
    int32_t apex, a, b;
  };
  std::vector<Needle> needles;
  const size_t faces = clean.triangles.size();
  for (size_t f = 0; f < faces; f += 5) {
    const Triangle t = clean.triangles[f];
    const int32_t p = clean.num_vertices();
    clean.positions.push_back(clean.positions[t[0]] * 0.495 + clean.positions[t[1]] * 0.495 + clean.positions[t[2]] * 0.01);
    clean.triangles[f] = {t[0], t[1], p};
    clean.triangles.push_back({t[1], t[2], p});
    clean.triangles.push_back({t[2], t[0], p});
    needles.push_back({p, t[0], t[1]});
  }
  const Topology topo = BuildTopology(clean);
  const double h = MeanEdgeLength(clean, topo);
  std::vector<uint8_t> role(clean.num_vertices(), flows::kFree);
  Mesh noisy = clean;
  AddNormalNoise(noisy, 0.1, 1);
  const flows::AutoStop stop(noisy, topo, role.data(), h, 1);

  std::vector<Vec3> pos = clean.positions;
  for (const Needle& n : needles) {
    const Vec3 a = clean.positions[n.a], b = clean.positions[n.b], p = clean.positions[n.apex];
    const Vec3 foot = a + (b - a) * (Dot(p - a, b - a) / SquaredNorm(b - a));
    pos[n.apex] = foot * 2.0 - p;  // as far across the edge as it was before it
  }
  const std::vector<Vec3> folded = pos;
  const int before = FlippedFaces(folded, clean);
  const int64_t left = stop.RepairFolds(pos.data());
  double longest = 0.0;
  for (size_t v = 0; v < pos.size(); ++v) longest = std::max(longest, Norm(pos[v] - folded[v]));
  std::printf("%zu needles folded: %d flipped faces, after the repair %d (%lld folded vertices left); longest move "
              "%.3f h\n",
              needles.size(), before, FlippedFaces(pos, clean), static_cast<long long>(left), longest / h);
  EXPECT_GE(before, static_cast<int>(needles.size()));
  EXPECT_EQ(FlippedFaces(pos, clean), 0);
  EXPECT_EQ(left, 0);
  EXPECT_LE(longest, flows::kFoldRepairReachH * h * (1.0 + 1e-12));
}

// A CAD part with features thinner than the noise: the turbine's narrow strips between
// right-angled creases meet at more than kFoldAngleDeg after a run, like folds. Pulling their
// vertices on to their rings' centroids without bound flattened them (RMS 0.061 h, 72 flipped
// faces, against 0.052 h and 41 within kFoldRepairReachH).
TEST(AutoStopTest, FoldRepairLeavesThinFeaturesOfACadPart) {
  MESHSMOOTH_REQUIRE_SHARED("meshes");
  absl::StatusOr<Mesh> clean = ReadMesh(testing::SharedData("meshes").append("turbine.obj").string());
  ASSERT_TRUE(clean.ok()) << clean.status();
  const GroundTruth truth(*clean);
  Mesh m = *clean;
  AddNormalNoise(m, 0.1, 1);
  FlowParams p;
  p.choose_flow = true;  // the default job
  absl::StatusOr<FlowResult> r = Smooth(m, p);
  ASSERT_TRUE(r.ok()) << r.status();
  const absl::StatusOr<Quality> after = truth.Evaluate(m);
  ASSERT_TRUE(after.ok());
  std::printf("turbine sigma 0.1: %s, %d iterations, RMS %.4f h, %lld flipped faces (%lld in fine detail)\n",
              std::string(FlowOf(r->flow).name).c_str(), r->iterations_run, after->rms_distance,
              static_cast<long long>(after->flipped_faces), static_cast<long long>(after->flipped_in_fine_detail));
  EXPECT_LT(after->rms_distance, 0.056);
  EXPECT_LT(after->flipped_faces, 50);
}

TEST(AutoStopTest, ExplicitIterationsRunExactly) {
  Mesh m = Icosphere(3);
  AddNormalNoise(m, 0.2, 1);
  FlowParams p;
  p.iterations = 5;
  absl::StatusOr<FlowResult> r = Smooth(m, p);
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->iterations_run, 5);
  EXPECT_EQ(r->stop_reason, StopReason::kIterations);
  EXPECT_FALSE(r->auto_stop.has_value());
}

// A real CAD part with noise: the default job at least halves nothing it should not, keeps the
// volume within 1% of the clean part's, and turns no face over.
TEST(AutoStopTest, NoisyFandiskComesBackCloser) {
  MESHSMOOTH_REQUIRE_SHARED("meshes");
  absl::StatusOr<Mesh> clean = ReadMesh(testing::SharedData("meshes").append("fandisk.obj").string());
  ASSERT_TRUE(clean.ok()) << clean.status();
  const GroundTruth truth(*clean);
  {
    Mesh m = *clean;
    absl::StatusOr<FlowResult> r = Smooth(m, FlowParams{});
    ASSERT_TRUE(r.ok()) << r.status();
    EXPECT_EQ(r->iterations_run, 0) << "the clean part has no noise to remove";
    EXPECT_EQ(m.positions, clean->positions);
  }
  Mesh m = *clean;
  AddNormalNoise(m, 0.2, 1);
  const absl::StatusOr<Quality> before = truth.Evaluate(m);
  absl::StatusOr<FlowResult> r = Smooth(m, FlowParams{});
  ASSERT_TRUE(r.ok()) << r.status();
  const absl::StatusOr<Quality> after = truth.Evaluate(m);
  ASSERT_TRUE(before.ok() && after.ok());
  std::printf("fandisk sigma 0.2: %d iterations, RMS %.4f -> %.4f h, normal %.2f -> %.2f deg, volume %.2f%%\n",
              r->iterations_run, before->rms_distance, after->rms_distance, before->normal_error_deg,
              after->normal_error_deg, after->volume_change_percent);
  EXPECT_LT(after->rms_distance, 0.6 * before->rms_distance);
  EXPECT_LT(after->normal_error_deg, 0.6 * before->normal_error_deg);
  EXPECT_NEAR(after->volume_change_percent, 0.0, 1.0);
  EXPECT_EQ(after->flipped_faces, 0);
}

// A job that names no flow (choose_flow) on the CAD part: the estimated error picks
// bilateral_normal, which keeps the creases: within 1.25 times the best fixed count's distance
// (0.0523 h at 16 rounds, bench/quality.cc) and a few degrees of normal error next to creases,
// where the bilaplacian flow at its own best count leaves 22 degrees.
TEST(AutoStopTest, ChosenFlowKeepsTheCreasesOfANoisyCadPart) {
  MESHSMOOTH_REQUIRE_SHARED("meshes");
  absl::StatusOr<Mesh> clean = ReadMesh(testing::SharedData("meshes").append("fandisk.obj").string());
  ASSERT_TRUE(clean.ok()) << clean.status();
  const GroundTruth truth(*clean);
  Mesh m = *clean;
  AddNormalNoise(m, 0.2, 1);
  FlowParams p;
  p.choose_flow = true;
  absl::StatusOr<FlowResult> r = Smooth(m, p);
  ASSERT_TRUE(r.ok()) << r.status();
  const absl::StatusOr<Quality> after = truth.Evaluate(m);
  ASSERT_TRUE(after.ok());
  std::printf("fandisk sigma 0.2, flow chosen: %s, %d iterations (%s), RMS %.4f h, crease normal %.2f deg\n",
              std::string(FlowOf(r->flow).name).c_str(), r->iterations_run,
              std::string(StopReasonName(r->stop_reason)).c_str(), after->rms_distance, after->crease_normal_error_deg);
  EXPECT_EQ(r->flow, FlowId::kBilateralNormal);
  EXPECT_LT(after->rms_distance, 1.25 * 0.0523);
  EXPECT_LT(after->crease_normal_error_deg, 5.0);
  EXPECT_EQ(after->flipped_faces, 0);
}

// Above kMaxChoiceVertices the flow and the count are chosen on patches of the mesh and the
// whole mesh runs once at that count: a 131k-vertex noisy torus still comes back far closer
// (the 1,456-vertex one: 0.30 times the noisy distance), its volume kept; the clean torus
// comes back unchanged.
TEST(AutoStopTest, LargeMeshChoosesOnItsPatches) {
  const GroundTruth truth(TwoRateTorus(256));
  ASSERT_GT(truth.mesh().num_vertices(), kMaxChoiceVertices);
  {
    Mesh m = truth.mesh();
    FlowParams p;
    p.choose_flow = true;
    absl::StatusOr<FlowResult> r = Smooth(m, p);
    ASSERT_TRUE(r.ok()) << r.status();
    EXPECT_EQ(r->iterations_run, 0);
    EXPECT_EQ(m.positions, truth.mesh().positions);
  }
  Mesh m = truth.mesh();
  AddNormalNoise(m, 0.2, 3);
  const absl::StatusOr<Quality> before = truth.Evaluate(m);
  const double input_volume = ComputeMetrics(m, BuildTopology(m)).signed_volume;
  FlowParams p;
  p.choose_flow = true;
  absl::StatusOr<FlowResult> r = Smooth(m, p);
  ASSERT_TRUE(r.ok()) << r.status();
  const absl::StatusOr<Quality> after = truth.Evaluate(m);
  ASSERT_TRUE(before.ok() && after.ok());
  std::printf("torus of %d vertices, sigma 0.2: %s, %d iterations (%s), RMS %.4f -> %.4f h\n",
              m.num_vertices(), std::string(FlowOf(r->flow).name).c_str(), r->iterations_run,
              std::string(StopReasonName(r->stop_reason)).c_str(), before->rms_distance, after->rms_distance);
  EXPECT_GT(r->iterations_run, 0);
  EXPECT_LT(after->rms_distance, 0.4 * before->rms_distance);
  EXPECT_EQ(after->flipped_faces, 0);
  EXPECT_NEAR(ComputeMetrics(m, BuildTopology(m)).signed_volume / input_volume, 1.0, 1e-6);
}

}  // namespace
}  // namespace meshsmooth
