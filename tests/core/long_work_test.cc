// Long steps of a job: per-vertex work linear in the valence, and every long loop
// stops when its StopToken fires (the work left undone is what the tests see).
#include <atomic>
#include <chrono>

#include "core/features/ridges.h"
#include "core/flows/flow.h"
#include "core/io/draco_codec.h"
#include "core/measure/metrics.h"
#include "core/shapes/added_noise.h"
#include "core/shapes/parametric.h"
#include "core/topology.h"
#include "core/util/stop_token.h"
#include "gtest/gtest.h"
#include "tests/flow_fixtures.h"
#include "tests/hostile_inputs.h"

namespace meshsmooth {
namespace {

double SecondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// A fan whose centre has valence 120,000 validates in milliseconds: the closed-fan check is
// linear in the valence (comparing every pair of the centre's faces would take ~10 s). The
// bound is generous.
TEST(LongWorkTest, HighValenceFanTopologyIsLinearInTheValence) {
  constexpr int32_t kValence = 120000;
  const Mesh fan = testing::Fan(kValence);
  const auto t0 = std::chrono::steady_clock::now();
  ValidationReport r;
  Topology topo = BuildTopology(fan, &r);
  EXPECT_LT(SecondsSince(t0), 2.0);
  ASSERT_EQ(topo.kind[0], VertexKind::kInterior);
  ASSERT_EQ(topo.valence(0), kValence);
  for (int32_t k = 0; k < kValence; ++k) {  // the ring in the faces' cyclic order
    const int32_t a = topo.ring[topo.ring_offsets[0] + k], b = topo.ring[topo.ring_offsets[0] + (k + 1) % kValence];
    ASSERT_EQ(b - 1, a % kValence) << k;
  }
  EXPECT_EQ(r.boundary_edges, kValence);
  EXPECT_EQ(r.boundary_loops, 1);
  EXPECT_EQ(r.nonmanifold_vertices, 0);
  EXPECT_EQ(SquaredValenceSum(topo), int64_t{kValence} * kValence + 9 * int64_t{kValence});
}

// The default job on a closed fan whose two apexes have valence 120,000 and whose rim vertices
// each see that many second-ring neighbours: the noise estimate gives up on such rings in
// bounded time (core/measure/noise.cc, kMaxGather) instead of gathering 120,000 points per vertex, and
// with no estimate the job does nothing. The bound is generous.
TEST(LongWorkTest, DefaultJobOnAHugeClosedFanIsBounded) {
  Mesh fan = testing::ClosedFan(120000);
  AddNormalNoise(fan, 0.1, 3);
  const Mesh input = fan;
  Topology topo = BuildTopology(fan);
  const auto t0 = std::chrono::steady_clock::now();
  absl::StatusOr<FlowResult> r = Smooth(fan, topo, testing::Params("bilaplacian", kAutoIterations));
  EXPECT_LT(SecondsSince(t0), 5.0);
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_EQ(r->stop_reason, StopReason::kNoEstimate);
  EXPECT_EQ(r->iterations_run, 0);
  EXPECT_EQ(fan.positions, input.positions);
}

// The general path (boundary, non-manifold, inconsistently oriented fans) is linear too: the
// fan with every other face turned over.
TEST(LongWorkTest, HighValenceInconsistentFanIsLinear) {
  constexpr int32_t kValence = 120000;
  Mesh fan = testing::Fan(kValence);
  for (size_t f = 0; f < fan.triangles.size(); f += 2) std::swap(fan.triangles[f][1], fan.triangles[f][2]);
  const auto t0 = std::chrono::steady_clock::now();
  ValidationReport r;
  Topology topo = BuildTopology(fan, &r);
  EXPECT_LT(SecondsSince(t0), 2.0);
  EXPECT_EQ(topo.valence(0), kValence);
  EXPECT_EQ(r.inconsistently_oriented_edges, kValence);
}

// A token that has fired stops each long step at its first poll: the work is not done.
TEST(LongWorkTest, FiredTokenStopsEveryLongStep) {
  const Mesh mesh = Icosphere(6);  // 40,962 vertices: several polls in every loop
  const Topology full = BuildTopology(mesh);
  std::atomic<bool> cancel{true};
  const StopToken stop(&cancel, StopToken::Clock::time_point::max());
  EXPECT_EQ(stop.Check().code(), absl::StatusCode::kCancelled);

  ValidationReport r;
  const Topology partial = BuildTopology(mesh, &r, stop);
  EXPECT_LT(partial.ring.size(), full.ring.size() / 2);

  EXPECT_GT(ComputeMetrics(mesh, full).area, 12.0);
  EXPECT_LT(ComputeMetrics(mesh, full, stop).area, 6.0);
  EXPECT_LT(ComputeMetricsBeside(
                mesh, full, [] {}, 2, stop)
                .area,
            6.0);

  EXPECT_EQ(DetectFeatures(mesh, full).classified, mesh.num_vertices());
  EXPECT_LT(DetectFeatures(mesh, full, {}, stop).classified, mesh.num_vertices() / 2);

  const std::string bytes = *EncodeDraco(mesh);
  EXPECT_EQ(DracoMesh::Decode(bytes, stop).status().code(), absl::StatusCode::kCancelled);
  absl::StatusOr<DracoMesh> dm = DracoMesh::Decode(bytes);
  ASSERT_TRUE(dm.ok());
  EXPECT_EQ(dm->Encode(dm->welded(), {}, {}, stop).status().code(), absl::StatusCode::kCancelled);

  const StopToken late(nullptr, StopToken::Clock::now() - std::chrono::seconds(1));
  EXPECT_EQ(late.Check().code(), absl::StatusCode::kDeadlineExceeded);
  EXPECT_EQ(DracoMesh::Decode(bytes, late).status().code(), absl::StatusCode::kDeadlineExceeded);
  EXPECT_TRUE(StopToken().Check().ok());
}

}  // namespace
}  // namespace meshsmooth
