// Invariants every flow keeps on every mesh of a list (synthetic, plus the real meshes of
// ../shared/data/meshes when present): no NaN, boundary and non-manifold vertices fixed by
// default, locked vertices fixed, and the same bytes with 1 and 2 threads.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "core/flows/catalogue.h"
#include "core/flows/driver.h"
#include "core/flows/flow_table.h"
#include "core/flows/lane_batches.h"
#include "core/flows/reorder.h"
#include "core/flows/vector_isa.h"
#include "core/io/mesh_io.h"
#include "core/job/rules.h"
#include "core/measure/metrics.h"
#include "core/measure/noise.h"
#include "gtest/gtest.h"
#include "tests/flow_fixtures.h"
#include "tests/test_data.h"

namespace meshsmooth {
namespace {

using namespace meshsmooth::testing;

struct Case {
  std::string name;
  Mesh mesh;
};

std::vector<Case> Meshes() {
  std::vector<Case> cases;
  cases.push_back({"noisy icosphere(6)", NoisySphere(6)});  // 40962 vertices: runs on 2 threads
  cases.push_back({"noisy two-rate torus", NoisyTorus()});
  Mesh plane = TwoRatePlane(48, 32);
  AddUniformNoise(plane, 0.3, 5);
  cases.push_back({"noisy two-rate plane", plane});
  // The real scans when ../shared/data is there (or CI=true: each must then read).
  if (std::filesystem::is_directory(SharedData("meshes")) || SharedDataRequired()) {
    for (const char* f : {"beetle.obj", "camelhead.obj", "fandisk.obj", "stanford-bunny.ply", "stanford-dragon.ply"}) {
      absl::StatusOr<Mesh> m = ReadMesh((SharedData("meshes") / f).string());
      EXPECT_TRUE(m.ok()) << m.status();
      if (m.ok()) cases.push_back({f, *std::move(m)});
    }
  }
  return cases;
}

bool SameBytes(const Mesh& a, const Mesh& b) {
  return a.positions.size() == b.positions.size() &&
         std::memcmp(a.positions.data(), b.positions.data(), a.positions.size() * sizeof(Vec3)) == 0;
}

// `mesh` smoothed with `p` on `threads` threads, and Smooth()'s result.
std::pair<Mesh, absl::StatusOr<FlowResult>> SmoothedOn(const Mesh& mesh, Topology& topo, FlowParams p, int threads) {
  p.threads = threads;
  Mesh out = mesh;
  absl::StatusOr<FlowResult> r = Smooth(out, topo, p);
  return {std::move(out), std::move(r)};
}

TEST(FlowInvariantsTest, EveryFlowOnEveryMesh) {
  for (const Case& c : Meshes()) {
    Topology topo = BuildTopology(c.mesh);
    const int32_t n = c.mesh.num_vertices();
    std::vector<uint8_t> locked(n, 0);
    for (int32_t v = 0; v < n; v += 17) locked[v] = 1;
    for (const std::string& flow : FlowNames()) {
      SCOPED_TRACE(c.name + " / " + flow);
      FlowParams p = Params(flow, 3);
      const auto [one, r] = SmoothedOn(c.mesh, topo, p, 1);
      ASSERT_TRUE(r.ok()) << r.status();
      const auto [two, r2] = SmoothedOn(c.mesh, topo, p, 2);
      ASSERT_TRUE(r2.ok()) << r2.status();
      EXPECT_TRUE(SameBytes(one, two)) << "1 and 2 threads differ";
      int64_t moved = 0;
      for (int32_t v = 0; v < n; ++v) {
        ASSERT_TRUE(IsFinite(one.positions[v]) || !IsFinite(c.mesh.positions[v])) << "vertex " << v;
        if (topo.kind[v] != VertexKind::kInterior) {
          ASSERT_EQ(one.positions[v], c.mesh.positions[v]) << "non-interior vertex " << v << " moved";
        }
        moved += !(one.positions[v] == c.mesh.positions[v]);
      }
      EXPECT_GT(moved, 0);
      p.locked = locked;
      Mesh lock = c.mesh;
      ASSERT_TRUE(Smooth(lock, topo, p).ok());
      for (int32_t v = 0; v < n; v += 17) ASSERT_EQ(lock.positions[v], c.mesh.positions[v]) << "locked " << v;
    }
  }
}

// Automatic runs of a small mesh iterate beside their probe copy when a second thread is there
// (core/flows/driver.cc): the default job and each candidate flow must then give the bytes and
// counts of the same runs done one after the other on one thread.
TEST(FlowInvariantsTest, ProbeBesideTheRunChangesNoPosition) {
  std::vector<Case> cases;
  cases.push_back({"noisy icosphere(4)", NoisySphere(4)});
  cases.push_back({"noisy two-rate torus", NoisyTorus()});
  Mesh needles = SphereWithNeedles();
  AddNormalNoise(needles, 0.3, 3);
  cases.push_back({"sphere with needles", needles});
  for (const Case& c : cases) {
    Topology topo = BuildTopology(c.mesh);
    for (const std::string& flow : {std::string(), std::string("bilaplacian"), std::string("bilateral_normal")}) {
      SCOPED_TRACE(c.name + " / " + (flow.empty() ? "default job" : flow));
      FlowParams p;
      if (!flow.empty()) p.flow = *ParseFlowName(flow);
      const auto [one, r1] = SmoothedOn(c.mesh, topo, p, 1);
      ASSERT_TRUE(r1.ok()) << r1.status();
      const auto [two, r2] = SmoothedOn(c.mesh, topo, p, 2);
      ASSERT_TRUE(r2.ok()) << r2.status();
      EXPECT_GT(r1->iterations_run, 0);
      EXPECT_EQ(r1->flow, r2->flow);
      EXPECT_EQ(r1->iterations_run, r2->iterations_run);
      EXPECT_TRUE(SameBytes(one, two)) << "the probe beside the run changed the result";
    }
  }
  // Above kParallelThreshold a run with a probe (a default job's sample of 20,000 vertices)
  // goes side by side on exactly two threads, and keeps every thread otherwise.
  const Mesh large = NoisySphere(6);  // 40,962 vertices
  Topology topo = BuildTopology(large);
  const double h = MeanEdgeLength(large, topo);
  std::vector<Mesh> results;
  std::vector<int> counts;
  for (int threads : {1, 2, 3}) {
    SCOPED_TRACE(threads);
    FlowParams p = Params("bilaplacian", kAutoIterations);
    p.threads = threads;
    Mesh m = large;
    const NoiseEstimate noise = EstimateNoise(large, topo, h);
    job::RiskStop rule(h, noise, job::kPolicy);
    absl::StatusOr<FlowResult> r = flows::RunIterations(m, topo, p, {}, h, {0, &rule});
    ASSERT_TRUE(r.ok()) << r.status();
    EXPECT_GT(r->iterations_run, 0);
    results.push_back(std::move(m));
    counts.push_back(r->iterations_run);
  }
  EXPECT_EQ(counts[0], counts[1]);
  EXPECT_EQ(counts[0], counts[2]);
  EXPECT_TRUE(SameBytes(results[0], results[1])) << "1 and 2 threads differ";
  EXPECT_TRUE(SameBytes(results[0], results[2])) << "1 and 3 threads differ";
}

// Large meshes run renumbered into Morton order: the positions must be exactly those of the
// caller's order, for every flow and eq. (14).
TEST(FlowInvariantsTest, InternalReorderingChangesNoPosition) {
  const Mesh noisy = NoisySphere(7);  // 163,842 vertices: above the reordering threshold
  Topology topo = BuildTopology(noisy);
  std::vector<FlowParams> list;
  for (const std::string& flow : FlowNames()) list.push_back(Params(flow, 3));
  FlowParams ring2 = Params("median", 12);
  ring2.adaptive = AdaptiveMode::kRing2;
  ring2.adaptive_recompute_every = 5;
  list.push_back(ring2);
  for (FlowParams p : list) {
    Mesh a = noisy, b = noisy;
    p.reorder = ReorderMode::kAlways;
    ASSERT_TRUE(Smooth(a, topo, p).ok());
    p.reorder = ReorderMode::kNever;
    ASSERT_TRUE(Smooth(b, topo, p).ok());
    EXPECT_TRUE(SameBytes(a, b)) << FlowName(*p.flow);
  }
}

// A reordered run renumbers the caller's faces and topology in place (no copy beside them) and
// gives them back exactly as it was lent them, whether the run ends or is cancelled midway; a
// face with a corner out of range (not in the topology) comes back as it was.
TEST(FlowInvariantsTest, ReorderingGivesTheTopologyAndFacesBack) {
  Mesh noisy = NoisySphere(7);
  const auto n = static_cast<int32_t>(noisy.positions.size());
  noisy.triangles.push_back({0, 1, n + 5});
  const Topology built = BuildTopology(noisy);
  ASSERT_EQ(built.faces.size() + 1, noisy.triangles.size());
  for (const bool cancelled : {false, true}) {
    Topology topo = built;
    Mesh a = noisy, b = noisy;
    FlowParams p = Params("laplacian", 6);
    std::atomic<bool> cancel{false};
    RunControl control;
    control.stop = StopToken(&cancel, StopToken::Clock::time_point::max());
    control.on_progress = [&](const Progress& pr) {
      if (cancelled && pr.iteration == 3) cancel = true;
    };
    p.reorder = ReorderMode::kAlways;
    const absl::StatusOr<FlowResult> r = Smooth(a, topo, p, control);
    EXPECT_EQ(r.ok(), !cancelled) << r.status();
    EXPECT_EQ(a.triangles, noisy.triangles) << cancelled;
    EXPECT_EQ(topo.ring_offsets, built.ring_offsets) << cancelled;
    EXPECT_EQ(topo.ring, built.ring) << cancelled;
    EXPECT_EQ(topo.kind, built.kind) << cancelled;
    EXPECT_EQ(topo.faces, built.faces) << cancelled;
    if (cancelled) {
      // The last completed iteration (the third), as the caller's order has it.
      cancel = false;
      control.on_progress = nullptr;
      p.iterations = 3;
      p.reorder = ReorderMode::kNever;
      ASSERT_TRUE(Smooth(b, topo, p, control).ok());
      EXPECT_TRUE(SameBytes(a, b));
    } else {
      EXPECT_FALSE(SameBytes(a, noisy));
    }
  }
}

// Reordering is chosen for scattered orders and runs long enough to repay it: the icosphere's
// generation order leaves about half the neighbours far apart in memory, its Morton order about
// 2%; small meshes stay in their order.
TEST(FlowInvariantsTest, MortonOrderPaysOffForScatteredOrdersOnLongRuns) {
  const Mesh noisy = NoisySphere(7);
  Topology topo = BuildTopology(noisy);
  EXPECT_TRUE(MortonOrderPaysOff(topo, 20));
  EXPECT_TRUE(MortonOrderPaysOff(topo, 5));
  EXPECT_FALSE(MortonOrderPaysOff(topo, 4));
  EXPECT_FALSE(MortonOrderPaysOff(topo, 1));

  const std::vector<int32_t> order = MortonOrder(noisy.positions);
  std::vector<int32_t> rank(order.size());
  for (size_t i = 0; i < order.size(); ++i) rank[order[i]] = static_cast<int32_t>(i);
  Mesh sorted = noisy;
  for (size_t i = 0; i < order.size(); ++i) sorted.positions[i] = noisy.positions[order[i]];
  for (Triangle& t : sorted.triangles) {
    for (int32_t& v : t) v = rank[v];
  }
  EXPECT_FALSE(MortonOrderPaysOff(BuildTopology(sorted), kMaxIterations));

  const Mesh small = NoisySphere(5);  // 10k vertices: fits the caches in any order
  EXPECT_FALSE(MortonOrderPaysOff(BuildTopology(small), kMaxIterations));
}

// The Morton order is a radix sort in one chunk per thread: the same permutation for any
// number of threads, with every vertex once and nearby vertices close in the order.
TEST(FlowInvariantsTest, MortonOrderIsOnePermutationForAnyThreads) {
  const Mesh noisy = NoisySphere(7);
  const std::vector<int32_t> one = MortonOrder(noisy.positions, 1);
  EXPECT_EQ(MortonOrder(noisy.positions, 2), one);
  EXPECT_EQ(MortonOrder(noisy.positions, 3), one);
  std::vector<int32_t> sorted = one;
  std::sort(sorted.begin(), sorted.end());
  for (int32_t i = 0; i < noisy.num_vertices(); ++i) ASSERT_EQ(sorted[i], i);
  // Consecutive vertices in Morton order are near each other: 1.57 mean edge lengths apart on
  // average here, against 3.15 in the icosphere's own order.
  double sum = 0.0;
  for (size_t i = 1; i < one.size(); ++i) sum += Norm(noisy.positions[one[i]] - noisy.positions[one[i - 1]]);
  const double mean_step = sum / static_cast<double>(one.size() - 1);
  Topology topo = BuildTopology(noisy);
  EXPECT_LT(mean_step, 2.0 * MeanEdgeLength(noisy, topo));
}

// Every 7th face split at its centroid: valences from 3 to 9 side by side, so the vertices
// computed together in one batch of lanes have rings of different lengths.
Mesh SplitEverySeventhFace(Mesh m) {
  const int32_t faces = m.num_triangles();
  for (int32_t f = 0; f < faces; f += 7) {
    const Triangle t = m.triangles[f];
    const int32_t c = m.num_vertices();
    m.positions.push_back((m.positions[t[0]] + m.positions[t[1]] + m.positions[t[2]]) * (1.0 / 3.0));
    m.triangles[f] = {t[0], t[1], c};
    m.triangles.push_back({t[1], t[2], c});
    m.triangles.push_back({t[2], t[0], c});
  }
  return m;
}

// The cotangent flows and the normal filters run compiled for AVX2 or AVX-512 where the CPU
// has them (flows::RunWithIsa), 4 or 8 vertices (faces) per register instead of 2: the
// positions must be the bytes of the x86-64 baseline build. (On a CPU without AVX2 every run
// below is the baseline and the test cannot tell them apart.)
TEST(FlowInvariantsTest, InstructionSetChangesNoPosition) {
  // The builds of the cotangent kernel this CPU can run, by KernelOptions::isa (none = the
  // widest): SSE2 always, AVX2 and AVX-512 when the CPU has them.
  flows::SetKernelOptions({});
  const flows::VectorIsa widest = flows::BestVectorIsa();
  using flows::VectorIsa;
  std::vector<std::pair<std::string, VectorIsa>> isas = {{"sse2", VectorIsa::kSse2}};
  if (widest != VectorIsa::kSse2) isas.push_back({"avx2", VectorIsa::kAvx2});
  if (widest == VectorIsa::kAvx512) isas.push_back({"avx512", VectorIsa::kAvx512});
  if (isas.size() == 1) GTEST_SKIP() << "this CPU has neither AVX2 nor AVX-512: nothing to compare SSE2 with";
  std::string compared = "sse2";
  for (size_t i = 1; i < isas.size(); ++i) compared += " = " + isas[i].first;
  std::printf("comparing the positions of %s\n", compared.c_str());
  RecordProperty("instruction_sets", compared);
  std::vector<Case> cases = Meshes();  // with boundaries (fixed vertices beside free ones) and the real scans
  Mesh split = SplitEverySeventhFace(Icosphere(5));
  AddUniformNoise(split, 0.3, 3);
  cases.push_back({"noisy icosphere(5), every 7th face split", split});
  for (const Case& c : cases) {
    Topology topo = BuildTopology(c.mesh);
    for (const char* flow : {"mcf", "mcf_tangential", "median", "bilateral_normal", "guided_normal"}) {
      SCOPED_TRACE(c.name + " / " + flow);
      FlowParams p = Params(flow, FlowOf(*ParseFlowName(flow)).kind == FlowKind::kNormalFilter ? 2 : 5);
      std::vector<Mesh> runs;
      for (const auto& [name, isa] : isas) {
        flows::KernelOptions options;
        options.isa = isa;
        flows::SetKernelOptions(options);
        Mesh m = c.mesh;
        ASSERT_TRUE(Smooth(m, topo, p).ok());
        runs.push_back(std::move(m));
      }
      flows::SetKernelOptions({});
      EXPECT_FALSE(SameBytes(runs[0], c.mesh));
      for (size_t i = 1; i < isas.size(); ++i)
        EXPECT_TRUE(SameBytes(runs[0], runs[i])) << "sse2 and " << isas[i].first << " differ";
    }
  }
}

// Blocks of free vertices without eq. (14) step W vertices at a time (CurvatureStepLanes);
// eq. (14) with T = 0, which leaves every speed as it is (F (|F| - 0) / |F| = F), takes the
// per-vertex step. Positions and statistics must be the same bits.
// Smooths `mesh` in lane batches and vertex by vertex (KernelOptions::lane_batches off): the same
// bytes and statistics. Returns the batched run's result.
FlowResult ExpectLanesMatchVertices(const Mesh& mesh, Topology& topo, const FlowParams& p) {
  Mesh lanes = mesh, vertex = mesh;
  const absl::StatusOr<FlowResult> a = Smooth(lanes, topo, p);
  flows::KernelOptions vertex_by_vertex;
  vertex_by_vertex.lane_batches = false;
  flows::SetKernelOptions(vertex_by_vertex);
  const absl::StatusOr<FlowResult> b = Smooth(vertex, topo, p);
  flows::SetKernelOptions({});
  EXPECT_TRUE(a.ok() && b.ok()) << a.status() << b.status();
  if (!a.ok() || !b.ok()) return {};
  EXPECT_FALSE(SameBytes(lanes, mesh));
  EXPECT_TRUE(SameBytes(lanes, vertex));
  EXPECT_EQ(a->last.mean_displacement, b->last.mean_displacement);
  EXPECT_EQ(a->last.max_displacement, b->last.max_displacement);
  EXPECT_EQ(a->last.moved_share, b->last.moved_share);
  return *a;
}

TEST(FlowInvariantsTest, LaneStepMatchesVertexStep) {
  Mesh split = SplitEverySeventhFace(Icosphere(5));
  AddUniformNoise(split, 0.3, 3);
  // Blocks that are not all free: boundary vertices moving as curves, locked vertices, batches
  // with no free vertex (the plane's first rows are all locked).
  Mesh plane = TwoRatePlane(96, 64);
  AddUniformNoise(plane, 0.3, 7);
  std::vector<uint8_t> locked(plane.num_vertices(), 0);
  for (int32_t v = 0; v < plane.num_vertices(); ++v) locked[v] = v % 13 == 0 || v < 200;
  for (const Mesh* mesh : {&split, &plane}) {
    Topology topo = BuildTopology(*mesh);
    for (const char* flow : {"mcf", "mcf_tangential", "median"}) {
      for (const AdaptiveMode adaptive : {AdaptiveMode::kNone, AdaptiveMode::kConstant, AdaptiveMode::kRing1}) {
        SCOPED_TRACE(::testing::Message() << (mesh == &plane ? "plane / " : "split sphere / ") << flow << " / adaptive "
                                          << static_cast<int>(adaptive));
        FlowParams p = Params(flow, 5);
        p.adaptive = adaptive;
        p.adaptive_threshold = 0.5;  // kConstant: eq. (14) with T = 0.5 (1 / length)
        if (mesh == &plane) p.boundary = BoundaryMode::kCurve, p.locked = locked;
        ExpectLanesMatchVertices(*mesh, topo, p);
      }
    }
  }
  // Spikes of 4 h on every 97th vertex: a step of 2.5 h^2 moves them by more than h, so they are
  // capped (the lane step computes the cap only for batches that have a capped vertex).
  Mesh spiky = NoisySphere(5, 0.05);
  const double h = MeanEdgeLength(spiky, BuildTopology(spiky));
  for (int32_t v = 0; v < spiky.num_vertices(); v += 97) spiky.positions[v] *= 1.0 + 4.0 * h;
  Topology topo = BuildTopology(spiky);
  for (const char* flow : {"mcf", "median"}) {
    SCOPED_TRACE(flow);
    FlowParams p = Params(flow, 1);
    p.step = 2.5;
    const FlowResult r = ExpectLanesMatchVertices(spiky, topo, p);
    EXPECT_DOUBLE_EQ(r.last.max_displacement, r.mean_edge_length);  // capped
  }
}

TEST(FlowInvariantsTest, LaneBatchesHoldEachBlocksFreeVerticesByValence) {
  const Mesh mesh = SplitEverySeventhFace(Icosphere(5));  // valences 3 .. 9, three blocks
  Topology topo = BuildTopology(mesh);
  const int32_t n = mesh.num_vertices();
  const std::vector<int32_t>& offsets = topo.ring_offsets;
  auto valence = [&](int32_t v) { return offsets[v + 1] - offsets[v]; };
  std::vector<uint8_t> role(n, 1);                  // flows::kFree
  for (int32_t v = 0; v < n; v += 11) role[v] = 0;  // flows::kFixed
  constexpr int32_t kBlock = 4096;                  // flows::kBlock
  for (const int width : {2, 4, 8}) {
    SCOPED_TRACE(width);
    const flows::LaneBatches lanes = flows::BuildLaneBatches(topo, role.data(), width, 2);
    const int32_t blocks = (n + kBlock - 1) / kBlock;
    ASSERT_EQ(lanes.width, width);
    ASSERT_EQ(lanes.block_first.size(), static_cast<size_t>(blocks) + 1);
    ASSERT_EQ(lanes.offsets.size(), lanes.lanes.size() + 1);
    ASSERT_EQ(lanes.data.size(), static_cast<size_t>(lanes.offsets.back()));
    for (int32_t b = 0; b < blocks; ++b) {
      std::vector<int32_t> seen;
      for (int32_t j = lanes.block_first[b]; j < lanes.block_first[b + 1]; ++j) {
        const int32_t* rows = &lanes.data[static_cast<size_t>(lanes.offsets[j])];
        const int32_t count = lanes.lanes[j];
        ASSERT_TRUE(count >= 1 && count <= width);
        int32_t most = 0;
        for (int32_t l = 0; l < width; ++l) {
          const int32_t v = rows[l];
          ASSERT_EQ(v, rows[l < count ? l : 0]);  // a short batch repeats its first vertex
          most = std::max(most, valence(v));
          if (l < count) seen.push_back(v);
        }
        ASSERT_EQ(lanes.offsets[j + 1] - lanes.offsets[j], int64_t{most + 3} * width);
        for (int32_t l = 0; l < width; ++l) {
          const int32_t v = rows[l], begin = offsets[v], nv = valence(v);
          ASSERT_EQ(rows[width + l], nv);
          ASSERT_EQ(rows[2 * width + l], 3 * topo.ring[begin + nv - 1]);  // Q_{n-1}
          for (int32_t k = 0; k < most; ++k) {                            // Q_k, or P past the ring
            ASSERT_EQ(rows[(k + 3) * width + l], 3 * (k < nv ? topo.ring[begin + k] : v));
          }
        }
      }
      std::vector<int32_t> expected;  // the block's free vertices, stably by valence
      for (int32_t v = b * kBlock; v < std::min(n, (b + 1) * kBlock); ++v) {
        if (role[v] == 1) expected.push_back(v);
      }
      std::stable_sort(expected.begin(), expected.end(), [&](int32_t x, int32_t y) { return valence(x) < valence(y); });
      ASSERT_EQ(seen, expected);
    }
  }
}

TEST(FlowInvariantsTest, BoundaryCurveModeSmoothsTheLoopInItsPlane) {
  const Mesh plane = TwoRatePlane(24, 16);
  Mesh m = plane;
  // Wiggle the boundary inside the plane.
  Topology topo = BuildTopology(m);
  for (int32_t v = 0; v < m.num_vertices(); ++v) {
    if (topo.kind[v] == VertexKind::kBoundary)
      m.positions[v] += Vec3{0.01 * ((v * 7) % 3 - 1), 0.01 * ((v * 5) % 3 - 1), 0.0};
  }
  for (const char* flow : {"laplacian", "median"}) {
    FlowParams p = Params(flow, 5);
    p.boundary = BoundaryMode::kCurve;
    Mesh s = m;
    ASSERT_TRUE(Smooth(s, topo, p).ok());
    int moved = 0;
    for (int32_t v = 0; v < m.num_vertices(); ++v) {
      ASSERT_EQ(s.positions[v].z, 0.0);
      if (topo.kind[v] == VertexKind::kBoundary && !(s.positions[v] == m.positions[v])) ++moved;
    }
    EXPECT_GT(moved, 40) << flow;
  }
}

TEST(FlowInvariantsTest, ProgressCancelToleranceAndTimeBudget) {
  const Mesh noisy = NoisySphere(4);
  {
    std::vector<int> seen;
    RunControl control;
    control.on_progress = [&](const Progress& pr) {
      seen.push_back(pr.iteration);
      EXPECT_EQ(pr.total, 7);
      EXPECT_GT(pr.max_displacement, 0.0);
      EXPECT_LE(pr.mean_displacement, pr.max_displacement);
      EXPECT_GT(pr.moved_share, 0.9);
    };
    Mesh m = noisy;
    ASSERT_TRUE(Smooth(m, Params("median", 7), control).ok());
    EXPECT_EQ(seen, (std::vector<int>{1, 2, 3, 4, 5, 6, 7}));
  }
  {
    std::atomic<bool> cancel{false};
    RunControl control;
    control.stop = StopToken(&cancel, StopToken::Clock::time_point::max());
    control.on_progress = [&](const Progress& pr) {
      if (pr.iteration == 3) cancel = true;
    };
    Mesh m = noisy;
    const absl::Status s = Smooth(m, Params("laplacian", 100), control).status();
    EXPECT_EQ(s.code(), absl::StatusCode::kCancelled);
    EXPECT_EQ(m.positions, Smoothed(noisy, Params("laplacian", 3)).positions);  // 3 iterations kept
  }
  {
    FlowParams p = Params("laplacian", 5000);
    p.tolerance = 1e-3;
    Mesh m = noisy;
    absl::StatusOr<FlowResult> r = Smooth(m, p);
    ASSERT_TRUE(r.ok());
    EXPECT_EQ(r->stop_reason, StopReason::kTolerance);
    EXPECT_LT(r->iterations_run, 5000);
    EXPECT_LT(r->last.max_displacement, 1e-3 * r->mean_edge_length);
  }
  {
    RunControl control;
    control.stop = StopToken(nullptr, StopToken::Clock::now() + std::chrono::microseconds(1));
    Mesh m = noisy;
    absl::StatusOr<FlowResult> r = Smooth(m, Params("median", 1000), control);
    ASSERT_TRUE(r.ok());
    EXPECT_EQ(r->stop_reason, StopReason::kTimeBudget);
    EXPECT_LT(r->iterations_run, 1000);
  }
}

// The flow table resolves each name to its own row, and what it lists for ListFlows holds:
// every flow's default step is inside its listed range, and parameters inside the ranges are
// refused only for a constraint that ListFlows states.
TEST(FlowInvariantsTest, FlowTableRowsResolveAndTheirLimitsHold) {
  ASSERT_EQ(FlowNames().size(), FlowTable().size());
  const std::vector<FlowInfo> described = DescribeFlows();
  ASSERT_EQ(described.size(), FlowTable().size());
  for (size_t i = 0; i < FlowTable().size(); ++i) {
    const FlowRow& row = FlowTable()[i];
    SCOPED_TRACE(std::string(row.name));
    EXPECT_EQ(static_cast<size_t>(row.id), i);
    EXPECT_EQ(ParseFlowName(row.name).value(), row.id);
    EXPECT_EQ(FlowNames()[i], row.name);
    EXPECT_EQ(described[i].name, row.name);
    EXPECT_EQ(described[i].parameters.front().name, "step");
    EXPECT_EQ(described[i].parameters.front().max_value, row.max_step);
    // The flows with an implicit form add the implicit step's range (catalogue.cc).
    std::vector<std::string> constraints = row.constraints;
    if (HasImplicitForm(row.id)) constraints.emplace_back("with integration IMPLICIT: step in (0, 1e6]");
    EXPECT_EQ(described[i].constraints, constraints);
    EXPECT_GT(row.default_step, 0.0);
    EXPECT_LE(row.default_step, row.max_step);
    EXPECT_NE(row.make_kernel, nullptr);
    if (!row.constraints.empty()) {
      EXPECT_NE(row.validate, nullptr);
    }
  }
  // taubin at step 1.0 is inside the step range but not its pass-band constraint, which
  // ListFlows states; mcf_tangential at step 10 needs C <= 0.1.
  FlowParams taubin = Params("taubin", 1, 1.0);
  const absl::Status band = ValidateFlowParams(taubin, 100);
  EXPECT_EQ(band.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(band.message().find("pass band"), std::string::npos) << band;
  taubin.taubin_mu = 1.0;
  taubin.step = 0.99;
  EXPECT_TRUE(ValidateFlowParams(taubin, 100).ok());
  FlowParams tangential = Params("mcf_tangential", 1, 10.0);
  const absl::Status weight = ValidateFlowParams(tangential, 100);
  EXPECT_EQ(weight.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(weight.message().find("step * C <= 1"), std::string::npos) << weight;
  tangential.tangential_weight = 0.1;
  EXPECT_TRUE(ValidateFlowParams(tangential, 100).ok());
}

TEST(FlowInvariantsTest, BadParametersAndInputsAreRefusedClearly) {
  const Mesh m0 = Icosphere(2);
  struct Bad {
    FlowParams p;
    std::string expect;
  };
  std::vector<Bad> bad;
  // A name is resolved where a request enters (ParseFlowName); an id outside the table is
  // refused by Smooth() itself.
  const absl::Status unknown = ParseFlowName("laplacien").status();
  EXPECT_EQ(unknown.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(unknown.message().find("unknown flow 'laplacien' (laplacian, taubin,"), std::string::npos) << unknown;
  FlowParams stray = Params("median", 1);
  stray.flow = static_cast<FlowId>(99);
  bad.push_back({stray, "unknown flow id 99"});
  bad.push_back({Params("median", -1), "iterations"});
  FlowParams no_cap = Params("median", kAutoIterations);
  no_cap.max_auto_iterations = 0;
  bad.push_back({no_cap, "automatic iteration limit"});
  bad.push_back({Params("median", kMaxIterations + 1), "iterations"});
  bad.push_back({Params("mcf", 1, -1.0), "step"});
  bad.push_back({Params("mcf", 1, std::numeric_limits<double>::quiet_NaN()), "step"});
  FlowParams lock = Params("median", 1);
  lock.locked = {1, 0};
  bad.push_back({lock, "lock mask"});
  FlowParams tol = Params("median", 1);
  tol.tolerance = -1;
  bad.push_back({tol, "tolerance"});
  for (const Bad& b : bad) {
    Mesh m = m0;
    const absl::Status s = Smooth(m, b.p).status();
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << b.expect;
    EXPECT_NE(s.message().find(b.expect), std::string::npos) << s;
    EXPECT_EQ(m.positions, m0.positions);
  }
  Mesh nan = m0;
  nan.positions[3].y = std::numeric_limits<double>::quiet_NaN();
  const absl::Status s = Smooth(nan, Params("median", 1)).status();
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("NaN"), std::string::npos) << s;
  Mesh empty;
  EXPECT_EQ(Smooth(empty, Params("median", 1)).status().code(), absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace meshsmooth
