// Per-vertex strength (FlowParams::strength): 0 keeps a vertex's bits in every flow and in the
// default job, 1 everywhere is the run without strengths bit for bit, a value between scales
// the vertex's move (closed form for the umbrella flow), and bad values are refused.
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "core/flows/catalogue.h"
#include "core/flows/flow.h"
#include "core/job/repair.h"
#include "core/measure/folded_faces.h"
#include "core/shapes/added_noise.h"
#include "core/shapes/parametric.h"
#include "gtest/gtest.h"
#include "tests/flow_fixtures.h"

namespace meshsmooth {
namespace {

using namespace meshsmooth::testing;

bool SameBytes(const Mesh& a, const Mesh& b) {
  return a.positions.size() == b.positions.size() &&
         std::memcmp(a.positions.data(), b.positions.data(), a.positions.size() * sizeof(Vec3)) == 0;
}

// Strength 0 above the plane z = 0.3 (a cap of the unit sphere), 1 below.
std::vector<float> CapHeld(const Mesh& m) {
  std::vector<float> s(m.positions.size(), 1.0f);
  for (size_t v = 0; v < s.size(); ++v) s[v] = m.positions[v].z > 0.3 ? 0.0f : 1.0f;
  return s;
}

// The jobs the tests run: every flow for three iterations, and the default job.
std::vector<std::pair<std::string, FlowParams>> Jobs() {
  std::vector<std::pair<std::string, FlowParams>> jobs;
  for (const std::string& flow : FlowNames()) jobs.emplace_back(flow, Params(flow, 3));
  jobs.emplace_back("the default job", FlowParams{});
  return jobs;
}

TEST(StrengthTest, ZeroKeepsEveryBitInEveryFlowAndTheDefaultJob) {
  const Mesh noisy = NoisySphere(4);
  Topology topo = BuildTopology(noisy);
  const std::vector<float> strength = CapHeld(noisy);
  for (auto [name, p] : Jobs()) {
    SCOPED_TRACE(name);
    p.strength = strength;
    Mesh out = noisy;
    ASSERT_TRUE(Smooth(out, topo, p).ok());
    int64_t moved = 0;
    for (int32_t v = 0; v < noisy.num_vertices(); ++v) {
      if (strength[v] == 0.0f) {
        ASSERT_EQ(std::memcmp(&out.positions[v], &noisy.positions[v], sizeof(Vec3)), 0) << "vertex " << v;
      } else {
        moved += !(out.positions[v] == noisy.positions[v]);
      }
    }
    EXPECT_GT(moved, noisy.num_vertices() / 2) << "the vertices of strength 1 hardly moved";
  }
}

TEST(StrengthTest, AllOnesGiveTheBitsOfNoStrength) {
  const Mesh noisy = NoisySphere(4);
  Topology topo = BuildTopology(noisy);
  for (auto [name, p] : Jobs()) {
    SCOPED_TRACE(name);
    Mesh plain = noisy, ones = noisy;
    ASSERT_TRUE(Smooth(plain, topo, p).ok());
    p.strength.assign(noisy.positions.size(), 1.0f);
    ASSERT_TRUE(Smooth(ones, topo, p).ok());
    EXPECT_TRUE(SameBytes(plain, ones));
  }
}

// One umbrella step moves v by lambda s U0(v) (eq. 2 and 3): a vertex of strength 1/2 moves
// half as far as with strength 1, in the same direction.
TEST(StrengthTest, HalfStrengthMovesHalfAsFarInOneUmbrellaStep) {
  const Mesh noisy = NoisySphere(4);
  Topology topo = BuildTopology(noisy);
  const double lambda = 0.5;
  FlowParams p = Params("laplacian", 1, lambda);
  Mesh full = noisy, half = noisy;
  ASSERT_TRUE(Smooth(full, topo, p).ok());
  p.strength.assign(noisy.positions.size(), 1.0f);
  for (size_t v = 0; v < p.strength.size(); v += 2) p.strength[v] = 0.5f;
  ASSERT_TRUE(Smooth(half, topo, p).ok());
  for (int32_t v = 0; v < noisy.num_vertices(); ++v) {
    Vec3 centroid;
    for (int32_t k = topo.ring_offsets[v]; k < topo.ring_offsets[v + 1]; ++k) centroid += noisy.positions[topo.ring[k]];
    centroid *= 1.0 / topo.valence(v);
    const Vec3 u0 = centroid - noisy.positions[v];
    const Vec3 want_full = noisy.positions[v] + u0 * lambda;
    EXPECT_LT(Norm(full.positions[v] - want_full), 1e-12) << v;
    if (v % 2 != 0) {
      EXPECT_EQ(half.positions[v], full.positions[v]) << v;
      continue;
    }
    const Vec3 moved = half.positions[v] - noisy.positions[v];
    EXPECT_LT(Norm(moved - u0 * (0.5 * lambda)), 1e-12) << v;
    EXPECT_NEAR(Norm(moved), 0.5 * Norm(full.positions[v] - noisy.positions[v]), 1e-12) << v;
  }
}

// The Morton order a large mesh runs in (core/flows/reorder.h) carries the strengths along.
TEST(StrengthTest, ReorderedRunKeepsTheStrengths) {
  Mesh noisy = Icosphere(7);  // 163,842 vertices: reorderable
  AddUniformNoise(noisy, 0.3, 2);
  Topology topo = BuildTopology(noisy);
  FlowParams p = Params("laplacian", 2);
  p.strength = CapHeld(noisy);
  for (size_t v = 1; v < p.strength.size(); v += 3) p.strength[v] *= 0.25f;
  p.reorder = ReorderMode::kNever;
  Mesh never = noisy, always = noisy;
  ASSERT_TRUE(Smooth(never, topo, p).ok());
  p.reorder = ReorderMode::kAlways;
  ASSERT_TRUE(Smooth(always, topo, p).ok());
  EXPECT_TRUE(SameBytes(never, always));
}

// Scaled moves are made block by block, beside the kernel's: the same bytes on 1 and 2 threads
// (a mesh above the parallel threshold), in every flow; held vertices keep their bits there too,
// the default job's included, which chooses on patches of a mesh this large.
TEST(StrengthTest, ScaledMovesAreTheSameOnAnyThreadCount) {
  const Mesh noisy = NoisySphere(6);  // 40,962 vertices: two threads
  Topology topo = BuildTopology(noisy);
  std::vector<float> strength = CapHeld(noisy);
  for (size_t v = 0; v < strength.size(); v += 3) strength[v] *= 0.4f;
  for (auto [name, p] : Jobs()) {
    SCOPED_TRACE(name);
    p.strength = strength;
    Mesh one = noisy, two = noisy;
    p.threads = 1;
    ASSERT_TRUE(Smooth(one, topo, p).ok());
    p.threads = 2;
    ASSERT_TRUE(Smooth(two, topo, p).ok());
    EXPECT_TRUE(SameBytes(one, two));
    int64_t moved = 0;
    for (int32_t v = 0; v < noisy.num_vertices(); ++v) {
      if (strength[v] == 0.0f) {
        ASSERT_EQ(std::memcmp(&two.positions[v], &noisy.positions[v], sizeof(Vec3)), 0) << "vertex " << v;
      } else {
        moved += !(two.positions[v] == noisy.positions[v]);
      }
    }
    EXPECT_GT(moved, noisy.num_vertices() / 2);
  }
}

TEST(StrengthTest, BadStrengthsAreRefusedNamingThem) {
  const Mesh noisy = NoisySphere(2);
  const auto n = noisy.positions.size();
  for (const auto& [what, strength] :
       std::vector<std::pair<std::string, std::vector<float>>>{{"too short", std::vector<float>(n - 1, 1.0f)},
                                                               {"NaN", std::vector<float>(n, std::nanf(""))},
                                                               {"above 1", std::vector<float>(n, 1.5f)},
                                                               {"below 0", std::vector<float>(n, -0.25f)}}) {
    SCOPED_TRACE(what);
    for (FlowParams p : {FlowParams{}, Params("taubin", 2)}) {
      p.strength = strength;
      Mesh out = noisy;
      const absl::StatusOr<FlowResult> r = Smooth(out, p);
      ASSERT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
      EXPECT_NE(r.status().message().find("strength"), std::string::npos) << r.status();
      EXPECT_TRUE(SameBytes(out, noisy));
    }
  }
}

// A region held at strength 0 in the default job, on a mesh whose noise folds faces: the result
// keeps no more folded faces than the input had.
TEST(StrengthTest, DefaultJobReturnsNoMoreFoldedFaces) {
  for (uint64_t seed : {1, 2, 3}) {
    Mesh needles = SphereWithNeedles();
    AddNormalNoise(needles, 0.3, seed);
    Topology topo = BuildTopology(needles);
    FlowParams p;
    p.strength = CapHeld(needles);
    for (size_t v = 0; v < p.strength.size(); v += 5) p.strength[v] = std::min(p.strength[v], 0.5f);
    Mesh out = needles;
    ASSERT_TRUE(Smooth(out, topo, p).ok());
    const FaceFolds folds(needles, topo);
    EXPECT_LE(folds.Count(out.positions.data()), folds.Count(needles.positions.data())) << "seed " << seed;
  }
}

// The default job reads the noise on the vertices it may move: a clean cap held at strength 0 on
// a noisy sphere leaves the estimate and the count of the whole noisy sphere's, where the cap's
// clean fits would pull the median down by about the cap's share.
TEST(StrengthTest, DefaultJobReadsTheNoiseWhereVerticesMove) {
  const Mesh clean = Icosphere(4);
  const Mesh noisy = NoisySphere(4);
  Mesh half = noisy;
  const std::vector<float> strength = CapHeld(noisy);
  for (size_t v = 0; v < strength.size(); ++v) {
    if (strength[v] == 0.0f) half.positions[v] = clean.positions[v];
  }
  Mesh all = noisy;
  const absl::StatusOr<FlowResult> whole = Smooth(all, FlowParams{});
  FlowParams p;
  p.strength = strength;
  const absl::StatusOr<FlowResult> held = Smooth(half, p);
  ASSERT_TRUE(whole.ok() && held.ok());
  ASSERT_TRUE(whole->auto_stop && held->auto_stop);
  EXPECT_NEAR(held->auto_stop->noise_sigma_h, whole->auto_stop->noise_sigma_h, 0.1 * whole->auto_stop->noise_sigma_h);
  EXPECT_NEAR(held->iterations_run, whole->iterations_run, 0.3 * whole->iterations_run);
}

// The last edit of the default job with strengths: vertices pushed through a clean sphere fold
// their faces; KeepNoMoreFolds puts back those vertices (and their neighbours where needed) and
// leaves the moves far from any fold.
TEST(StrengthTest, KeepNoMoreFoldsPutsBackOnlyAroundTheFolds) {
  const Mesh sphere = Icosphere(3);
  Topology topo = BuildTopology(sphere);
  const FaceFolds folds(sphere, topo);
  ASSERT_EQ(folds.Count(sphere.positions.data()), 0);
  std::vector<Vec3> result = sphere.positions;
  for (Vec3& p : result) p *= 0.99;  // a harmless move everywhere
  const std::vector<int32_t> pushed = {0, 100, 200, 300};
  for (int32_t v : pushed) result[v] *= -0.2;  // through the centre: its fan turns over
  ASSERT_GT(folds.Count(result.data()), 0);
  const std::vector<Vec3> before = result;
  const int64_t back = job::KeepNoMoreFolds(result.data(), sphere.positions.data(), sphere, topo);
  EXPECT_EQ(folds.Count(result.data()), 0);
  for (int32_t v : pushed) EXPECT_EQ(result[v], sphere.positions[v]) << v;
  EXPECT_GE(back, static_cast<int64_t>(pushed.size()));
  EXPECT_LT(back, sphere.num_vertices() / 4) << "more than the folds' surroundings went back";
  int64_t kept = 0;
  for (int32_t v = 0; v < sphere.num_vertices(); ++v) kept += result[v] == before[v];
  EXPECT_EQ(kept + back, sphere.num_vertices());
}

}  // namespace
}  // namespace meshsmooth
