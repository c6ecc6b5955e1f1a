#include "core/features/ridges.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>

#include "core/flows/flow.h"
#include "core/measure/metrics.h"
#include "core/shapes/added_noise.h"
#include "core/shapes/parametric.h"
#include "core/topology.h"
#include "gtest/gtest.h"

namespace meshsmooth {
namespace {

constexpr double kPi = std::numbers::pi;

// The cosine wave of the tests: z = cos x (A = 1, crest curvature 1), three periods, 36 rows of
// constant x per period and 36 vertices per row. Crests x = 2 k pi are the rows k * 36,
// troughs x = (2k + 1) pi the rows k * 36 + 18. With the +z normals the crests bend away from
// the normal (kmax = A > 0 there): ridges; the troughs bend towards it: ravines.
constexpr int kPeriods = 3, kRowsPerPeriod = 36, kColumns = 36;
constexpr int kRows = kPeriods * kRowsPerPeriod + 1;
constexpr double kAmplitude = 1.0;

Mesh Wave() { return CosineHeightField(kAmplitude, kPeriods, kRowsPerPeriod, kColumns); }

struct Score {
  int64_t detected = 0, near_line = 0;  // labelled vertices, and those within h of a true line
  int64_t truth = 0, found = 0;         // vertices of the line rows, and those labelled
  double precision() const { return detected ? static_cast<double>(near_line) / static_cast<double>(detected) : 0.0; }
  double recall() const { return truth ? static_cast<double>(found) / static_cast<double>(truth) : 0.0; }
};

// Scores `labels` against the crest (kRidge) or trough (kRavine) lines of Wave(), by vertex
// identity: x is read from the clean wave. Only vertices at least `margin` rows and columns
// from the grid's sides count, for the detections and for the truth (margin 1 = every vertex
// that can be classified: all but the boundary).
Score ScoreLines(const std::vector<uint8_t>& labels, FeatureLabel label, int margin) {
  const Mesh clean = Wave();
  const double h = MeanEdgeLength(clean, BuildTopology(clean));
  const double offset = label == FeatureLabel::kRidge ? 0.0 : kPi;
  const int line_row = label == FeatureLabel::kRidge ? 0 : kRowsPerPeriod / 2;
  Score s;
  for (int32_t v = 0; v < clean.num_vertices(); ++v) {
    const int row = v / kColumns, column = v % kColumns;
    if (row < margin || row >= kRows - margin || column < margin || column >= kColumns - margin) continue;
    const bool labelled = labels[v] == static_cast<uint8_t>(label);
    if (labelled) {
      const double x = clean.positions[v].x - offset;
      ++s.detected;
      s.near_line += std::abs(x - 2.0 * kPi * std::round(x / (2.0 * kPi))) <= h;
    }
    if (row % kRowsPerPeriod == line_row) {
      ++s.truth;
      s.found += labelled;
    }
  }
  return s;
}

void Print(const char* what, const Score& s) {
  std::printf("%s: %lld detected, precision %.1f%% (%lld within one edge of a line), recall %.1f%% (%lld of %lld)\n",
              what, static_cast<long long>(s.detected), 100.0 * s.precision(), static_cast<long long>(s.near_line),
              100.0 * s.recall(), static_cast<long long>(s.found), static_cast<long long>(s.truth));
}

TEST(RidgesTest, CleanWaveHasRidgesOnTheCrestsAndRavinesInTheTroughs) {
  const Mesh m = Wave();
  Topology topo = BuildTopology(m);
  // Threshold 0.1 A. Where the wave is concave its kmax is 0 along y on the smooth surface; the
  // estimate there is near 0 and exactly constant along y, its own curvature line, so the strict
  // comparison is decided by rounding, and the threshold guards against that (Taubin's closed
  // form reads up to 0.06 A there and, without a threshold, gives hundreds of spurious labels:
  // precision about 25%). Likewise for kmin where the wave is convex.
  FeatureOptions options;
  options.min_abs_curvature = 0.1 * kAmplitude;
  const Features f = DetectFeatures(m, topo, options);
  // Boundary vertices have no estimate and no label; their neighbours are classified like any
  // other vertex (the boundary's curvature is filled in from its interior neighbours).
  for (int32_t v = 0; v < m.num_vertices(); ++v) {
    const int row = v / kColumns, column = v % kColumns;
    if (row < 1 || row >= kRows - 1 || column < 1 || column >= kColumns - 1) {
      EXPECT_EQ(f.labels[v], 0) << v;
      EXPECT_EQ(f.curvature.valid[v], 0) << v;
    }
  }
  const Score crests = ScoreLines(f.labels, FeatureLabel::kRidge, 1);
  const Score troughs = ScoreLines(f.labels, FeatureLabel::kRavine, 1);
  Print("clean wave, crests (ridges)", crests);
  Print("clean wave, troughs (ravines)", troughs);
  EXPECT_EQ(f.ridges, crests.detected);
  EXPECT_EQ(f.ravines, troughs.detected);
  EXPECT_GE(crests.precision(), 0.8);
  EXPECT_GE(crests.recall(), 0.7);
  EXPECT_GE(troughs.precision(), 0.8);
  EXPECT_GE(troughs.recall(), 0.7);
  EXPECT_EQ(crests.truth, 2 * (kColumns - 2));  // two interior crest rows
  EXPECT_EQ(troughs.truth, 3 * (kColumns - 2));
}

// Section 5's recipe: smooth, then detect. Uniform noise of 0.5 h (seed 1) drowns the crest
// curvature (1) in curvature noise of order 0.5 h / h^2: on the raw noisy mesh about 40% of all
// vertices come out as ridges, so its "recall" is chance. After 120 iterations of the median
// flow (default step) the crests are found again. The threshold 0.3 A applies to both meshes:
// the smoothed surface keeps low ripples whose small extrema are not ridges. Vertices within
// 6 rows or columns of the sides are left out of the score: Smooth() keeps the boundary fixed,
// so its noise stays in the nearby rings.
TEST(RidgesTest, MedianSmoothingRecoversTheCrestsOfANoisyWave) {
  const Mesh clean = Wave();
  Topology topo = BuildTopology(clean);
  Mesh noisy = clean;
  AddUniformNoise(noisy, 0.5, 1);
  Mesh smoothed = noisy;
  FlowParams p;
  p.flow = FlowId::kMedian;
  p.iterations = 120;
  ASSERT_TRUE(Smooth(smoothed, topo, p).ok());

  FeatureOptions options;
  options.min_abs_curvature = 0.3 * kAmplitude;
  const Features raw = DetectFeatures(noisy, topo, options);
  const Features after = DetectFeatures(smoothed, topo, options);
  constexpr int kMargin = 6;
  const Score raw_crests = ScoreLines(raw.labels, FeatureLabel::kRidge, kMargin);
  const Score crests = ScoreLines(after.labels, FeatureLabel::kRidge, kMargin);
  const Score raw_troughs = ScoreLines(raw.labels, FeatureLabel::kRavine, kMargin);
  const Score troughs = ScoreLines(after.labels, FeatureLabel::kRavine, kMargin);
  Print("noisy wave, crests, raw", raw_crests);
  Print("noisy wave, crests, after 120 median iterations", crests);
  Print("noisy wave, troughs, raw", raw_troughs);
  Print("noisy wave, troughs, after 120 median iterations", troughs);
  std::printf("true crest vertices found: %lld raw, %lld smoothed (%.2fx)\n", static_cast<long long>(raw_crests.found),
              static_cast<long long>(crests.found),
              static_cast<double>(crests.found) / static_cast<double>(std::max<int64_t>(1, raw_crests.found)));
  EXPECT_GE(crests.found, 2 * raw_crests.found);
  EXPECT_GE(crests.precision(), raw_crests.precision());
  // In absolute terms the smoothed wave is detected about as well as the clean one, troughs
  // included (the raw troughs' chance recall is higher, so no ratio is asserted for them).
  EXPECT_GE(crests.recall(), 0.8);
  EXPECT_GE(crests.precision(), 0.8);
  EXPECT_GE(troughs.recall(), 0.8);
  EXPECT_GE(troughs.precision(), std::max(0.8, raw_troughs.precision()));
}

// Boundary, non-manifold, isolated and degenerate vertices are never labelled, their neighbours
// still are (a poor neighbour does not hide the vertices around it), nothing is NaN,
// and the counts match the labels, on a noisy wave with a bow tie attached, a collapsed
// one-ring, a zero-area sliver and a non-finite coordinate.
TEST(RidgesTest, BrokenVerticesAreNotLabelledAndNothingIsNaN) {
  Mesh m = Wave();
  AddUniformNoise(m, 0.3, 5);
  const Topology clean = BuildTopology(m);
  auto ring = [&clean](int32_t v, int k) { return clean.ring[clean.ring_offsets[v] + k]; };
  const int32_t collapsed = 10 * kColumns + 10, sliver = 30 * kColumns + 20, bad = 50 * kColumns + 15;
  for (int k = 0; k < clean.valence(collapsed); ++k) m.positions[ring(collapsed, k)] = m.positions[collapsed];
  m.positions[sliver] = (m.positions[ring(sliver, 0)] + m.positions[ring(sliver, 1)]) * 0.5;
  m.positions[bad].z = std::numeric_limits<double>::quiet_NaN();
  const int32_t apex = m.num_vertices();
  for (const Vec3& p : {Vec3{0, 0, 5}, Vec3{1, 0, 5}, Vec3{0, 1, 5}, Vec3{-1, 0, 5}, Vec3{0, -1, 5}}) {
    m.positions.push_back(p);
  }
  m.triangles.push_back({apex, apex + 1, apex + 2});  // two triangles sharing only the apex
  m.triangles.push_back({apex, apex + 3, apex + 4});
  m.positions.push_back({9, 9, 9});  // isolated
  Topology topo = BuildTopology(m);
  ASSERT_EQ(topo.kind[apex], VertexKind::kNonManifold);

  const Features f = DetectFeatures(m, topo);
  ASSERT_EQ(f.labels.size(), m.positions.size());
  int64_t ridges = 0, ravines = 0, labelled_next_to_broken = 0;
  for (int32_t v = 0; v < m.num_vertices(); ++v) {
    ASSERT_TRUE(std::isfinite(f.curvature.kmax[v]) && std::isfinite(f.curvature.kmin[v])) << v;
    ASSERT_TRUE(IsFinite(f.curvature.normal[v]) && IsFinite(f.curvature.dir_max[v])) << v;
    ASSERT_LE(f.labels[v], 2) << v;
    ridges += f.labels[v] == static_cast<uint8_t>(FeatureLabel::kRidge);
    ravines += f.labels[v] == static_cast<uint8_t>(FeatureLabel::kRavine);
    if (!f.curvature.valid[v]) {
      EXPECT_EQ(f.labels[v], 0) << v;
      continue;
    }
    bool next_to_broken = false;
    for (int32_t i = topo.ring_offsets[v]; i < topo.ring_offsets[v + 1]; ++i) {
      next_to_broken |= !f.curvature.valid[topo.ring[i]];
    }
    labelled_next_to_broken += next_to_broken && f.labels[v] != 0;
    if (topo.kind[v] != VertexKind::kInterior) {
      EXPECT_EQ(f.curvature.valid[v], 0) << v;
    }
  }
  EXPECT_EQ(f.ridges, ridges);
  EXPECT_EQ(f.ravines, ravines);
  EXPECT_GT(ridges + ravines, 0);  // the noisy wave still has features elsewhere
  std::printf("%lld vertices with an invalid neighbour labelled\n", static_cast<long long>(labelled_next_to_broken));
  EXPECT_GT(labelled_next_to_broken, 0);
  for (int32_t v : {apex, apex + 5, collapsed, bad}) EXPECT_EQ(f.curvature.valid[v], 0) << v;
}

}  // namespace
}  // namespace meshsmooth
