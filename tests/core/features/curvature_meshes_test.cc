// Curvature and ridges on the triangulations scanners and meshers
// produce, not only on regular meshes. The meshes are built here:
// - the cosine sheet z = cos x on a 241 x 49 grid, each square split by one diagonal
//   (consistent), by alternating diagonals (criss-cross: half the vertices have valence 4), and
//   the Delaunay triangulation of stratified random points (one uniform point per grid cell,
//   boundary points on the boundary), made Delaunay by Lawson's edge flips;
// - a sphere and a torus (R = 3, r = 1) through about 10k stratified random points (an
//   icosphere's vertices, or a (u, v) grid's, each moved by a uniform random offset of up to 0.45
//   edge, then put back on the surface), triangulated by the same flips (opposite angles summing
//   to at most pi: on a sphere that is its convex hull);
// - a sphere extracted from a signed-distance grid by marching tetrahedra (see its test for
//   what is asserted there and what is not).
// Every test prints its numbers.
#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>
#include <random>
#include <utility>
#include <vector>

#include "core/features/curvature.h"
#include "core/features/ridges.h"
#include "core/measure/metrics.h"
#include "core/shapes/marching_tetrahedra.h"
#include "core/shapes/parametric.h"
#include "core/topology.h"
#include "gtest/gtest.h"

namespace meshsmooth {
namespace {

constexpr double kPi = std::numbers::pi;

double Angle(const Vec3& a, const Vec3& b) { return std::atan2(Norm(Cross(a, b)), Dot(a, b)); }

// Lawson's flips on a closed-or-bounded manifold mesh: an interior edge whose two opposite
// angles sum to more than pi is replaced by the other diagonal of its quad, until none is left
// (in the plane that is the Delaunay triangulation; on points on a sphere, their convex hull).
void MakeDelaunay(Mesh& m) {
  for (int pass = 0; pass < 100; ++pass) {
    std::map<std::pair<int32_t, int32_t>, std::vector<int32_t>> edge_faces;
    for (int32_t f = 0; f < static_cast<int32_t>(m.triangles.size()); ++f) {
      for (int c = 0; c < 3; ++c) {
        const int32_t a = m.triangles[f][c], b = m.triangles[f][(c + 1) % 3];
        edge_faces[{std::min(a, b), std::max(a, b)}].push_back(f);
      }
    }
    std::vector<uint8_t> touched(m.triangles.size(), 0);
    int flips = 0;
    for (const auto& [edge, faces] : edge_faces) {
      if (faces.size() != 2 || touched[faces[0]] || touched[faces[1]]) continue;
      auto opposite = [&](int32_t f) {
        for (int c = 0; c < 3; ++c) {
          const int32_t v = m.triangles[f][c];
          if (v != edge.first && v != edge.second) return std::make_pair(v, c);
        }
        return std::make_pair(-1, -1);
      };
      const auto [c, ci] = opposite(faces[0]);
      const auto [d, di] = opposite(faces[1]);
      if (edge_faces.count({std::min(c, d), std::max(c, d)})) continue;  // would duplicate an edge
      const Vec3 pa = m.positions[edge.first], pb = m.positions[edge.second];
      const Vec3 pc = m.positions[c], pd = m.positions[d];
      if (Angle(pa - pc, pb - pc) + Angle(pa - pd, pb - pd) <= kPi + 1e-9) continue;
      // Face 0 is (c, x, y) in its order from c: the new faces (c, x, d) and (d, y, c) keep it.
      const int32_t x = m.triangles[faces[0]][(ci + 1) % 3], y = m.triangles[faces[0]][(ci + 2) % 3];
      m.triangles[faces[0]] = {c, x, d};
      m.triangles[faces[1]] = {d, y, c};
      touched[faces[0]] = touched[faces[1]] = 1;
      ++flips;
    }
    if (flips == 0) return;
  }
}

enum class Diagonals { kConsistent, kAlternating, kDelaunay };

// z = cos x over x in [0, 6 pi] (rows i = 0..240, crests at x = 0, 2 pi, ...), y in [0, 48 dx].
constexpr int kSheetRows = 241, kSheetColumns = 49;
constexpr double kSheetStep = 6.0 * kPi / (kSheetRows - 1);

Mesh CosineSheet(Diagonals diagonals) {
  Mesh m;
  std::mt19937_64 rng(20);
  std::uniform_real_distribution<double> jitter(-0.45 * kSheetStep, 0.45 * kSheetStep);
  for (int i = 0; i < kSheetRows; ++i) {
    for (int j = 0; j < kSheetColumns; ++j) {
      double x = i * kSheetStep, y = j * kSheetStep;
      if (diagonals == Diagonals::kDelaunay) {
        if (i > 0 && i < kSheetRows - 1) x += jitter(rng);
        if (j > 0 && j < kSheetColumns - 1) y += jitter(rng);
      }
      m.positions.push_back({x, y, std::cos(x)});
    }
  }
  for (int i = 0; i + 1 < kSheetRows; ++i) {
    for (int j = 0; j + 1 < kSheetColumns; ++j) {
      const int32_t a = i * kSheetColumns + j, b = a + kSheetColumns, c = b + 1, d = a + 1;  // counter-clockwise
      if (diagonals == Diagonals::kAlternating && (i + j) % 2 == 1) {
        m.triangles.push_back({a, b, d});
        m.triangles.push_back({b, c, d});
      } else {
        m.triangles.push_back({a, b, c});
        m.triangles.push_back({a, c, d});
      }
    }
  }
  if (diagonals == Diagonals::kDelaunay) MakeDelaunay(m);
  return m;
}

struct LineScore {
  int64_t detected = 0, near = 0;  // labelled vertices, and those within one edge of a line
  int64_t bins = 0, found = 0;     // stretches of line 2h long, and those with a near label
  double precision() const { return detected ? static_cast<double>(near) / static_cast<double>(detected) : 0.0; }
  double recall() const { return bins ? static_cast<double>(found) / static_cast<double>(bins) : 0.0; }
};

// Scores `label` against the lines x = offset + 2 pi k inside the sheet, counting only what lies
// at least 3 h from the sheet's sides. Recall: the lines cut into stretches 2 h long in y, a
// stretch found when a labelled vertex within h of the line lies in it.
LineScore ScoreSheet(const Mesh& m, const Features& f, FeatureLabel label, double offset) {
  const double h = MeanEdgeLength(m, BuildTopology(m));
  const double x_max = (kSheetRows - 1) * kSheetStep, y_max = (kSheetColumns - 1) * kSheetStep;
  const double margin = 3.0 * h, bin = 2.0 * h;
  const int bins_per_line = static_cast<int>((y_max - 2.0 * margin) / bin);
  std::vector<double> lines;
  for (double x = offset; x <= x_max; x += 2.0 * kPi) {
    if (x > margin && x < x_max - margin) lines.push_back(x);
  }
  std::vector<std::vector<uint8_t>> hit(lines.size(), std::vector<uint8_t>(bins_per_line, 0));
  LineScore s;
  for (int32_t v = 0; v < m.num_vertices(); ++v) {
    const Vec3 p = m.positions[v];
    if (f.labels[v] != static_cast<uint8_t>(label)) continue;
    if (p.x < margin || p.x > x_max - margin || p.y < margin || p.y > y_max - margin) continue;
    ++s.detected;
    for (size_t l = 0; l < lines.size(); ++l) {
      if (std::abs(p.x - lines[l]) > h) continue;
      ++s.near;
      const int b = static_cast<int>((p.y - margin) / bin);
      if (b >= 0 && b < bins_per_line) hit[l][b] = 1;
      break;
    }
  }
  for (const auto& line : hit) {
    s.bins += static_cast<int64_t>(line.size());
    for (uint8_t x : line) s.found += x;
  }
  return s;
}

// Crests (ridges) and troughs (ravines) of the sheet in all three triangulations: precision
// >= 0.9 and recall >= 0.8 each, with the threshold of the other wave tests (0.1: half the
// sheet has a principal curvature that is 0 on the smooth surface, see ridges_test.cc), and
// with the relative threshold `meshsmooth ridges` takes by default, which needs no unit. The
// estimate needs no help from the valence: every interior vertex gets one.
TEST(CurvatureMeshesTest, CosineSheetCrestsAndTroughsInEveryTriangulation) {
  const struct {
    Diagonals diagonals;
    const char* name;
  } cases[] = {{Diagonals::kConsistent, "consistent diagonals"},
               {Diagonals::kAlternating, "alternating diagonals"},
               {Diagonals::kDelaunay, "Delaunay of stratified random points"}};
  for (const auto& c : cases) {
    for (const bool relative : {false, true}) {
      SCOPED_TRACE(relative ? "relative threshold (the default of meshsmooth ridges)" : "threshold 0.1");
      const Mesh m = CosineSheet(c.diagonals);
      const Topology topo = BuildTopology(m);
      FeatureOptions options;
      if (relative) {
        options.relative_threshold = kDefaultRelativeThreshold;
      } else {
        options.min_abs_curvature = 0.1;
      }
      const Features f = DetectFeatures(m, topo, options);
      int64_t interior = 0, valid = 0;
      for (int32_t v = 0; v < m.num_vertices(); ++v) {
        interior += topo.kind[v] == VertexKind::kInterior;
        valid += f.curvature.valid[v] != 0;
      }
      const LineScore crests = ScoreSheet(m, f, FeatureLabel::kRidge, 0.0);
      const LineScore troughs = ScoreSheet(m, f, FeatureLabel::kRavine, kPi);
      std::printf(
          "sheet, %s: %lld of %lld interior vertices valid; crests: %lld labelled, precision %.3f, recall %.3f "
          "(%lld of %lld stretches); troughs: %lld labelled, precision %.3f, recall %.3f (%lld of %lld)\n",
          c.name, static_cast<long long>(valid), static_cast<long long>(interior),
          static_cast<long long>(crests.detected), crests.precision(), crests.recall(),
          static_cast<long long>(crests.found), static_cast<long long>(crests.bins),
          static_cast<long long>(troughs.detected), troughs.precision(), troughs.recall(),
          static_cast<long long>(troughs.found), static_cast<long long>(troughs.bins));
      EXPECT_EQ(valid, interior) << c.name;
      EXPECT_GE(crests.precision(), 0.9) << c.name;
      EXPECT_GE(crests.recall(), 0.8) << c.name;
      EXPECT_GE(troughs.precision(), 0.9) << c.name;
      EXPECT_GE(troughs.recall(), 0.8) << c.name;
      EXPECT_GT(crests.bins, 0) << c.name;
      EXPECT_GT(troughs.bins, 0) << c.name;
      if (relative) std::printf("relative threshold: %.4f\n", f.threshold);
    }
  }
}

// The same bits for 1, 2 and 3 OpenMP threads (the sheet is above the size where the loops go
// parallel).
TEST(CurvatureMeshesTest, SameResultForAnyThreadCount) {
  const Mesh m = CosineSheet(Diagonals::kDelaunay);
  const Topology topo = BuildTopology(m);
  const int saved = omp_get_max_threads();
  std::vector<Features> runs;
  for (int threads : {1, 2, 3}) {
    omp_set_num_threads(threads);
    runs.push_back(DetectFeatures(m, topo));
  }
  omp_set_num_threads(saved);
  for (size_t i = 1; i < runs.size(); ++i) {
    EXPECT_EQ(runs[i].labels, runs[0].labels) << i;
    EXPECT_EQ(runs[i].curvature.kmax, runs[0].curvature.kmax) << i;
    EXPECT_EQ(runs[i].curvature.kmin, runs[0].curvature.kmin) << i;
    EXPECT_EQ(runs[i].curvature.dir_max, runs[0].curvature.dir_max) << i;
  }
  EXPECT_GT(runs[0].ridges, 0);
}

struct ErrorStats {
  double median = 0.0, p95 = 0.0;
  int64_t unclassified = 0;
};

// The median and 95th percentile over the vertices of max(|kmax - k1|, |kmin - k2|) / max(|k1|,
// |k2|), with (k1 >= k2) the true principal curvatures; invalid vertices counted apart.
template <typename Truth>
ErrorStats CurvatureErrors(const Mesh& m, Truth truth) {
  const CurvatureField f = EstimateCurvature(m, BuildTopology(m));
  std::vector<double> errors;
  ErrorStats s;
  for (int32_t v = 0; v < m.num_vertices(); ++v) {
    if (!f.valid[v]) {
      ++s.unclassified;
      continue;
    }
    const auto [k1, k2] = truth(m.positions[v]);
    errors.push_back(std::max(std::abs(f.kmax[v] - k1), std::abs(f.kmin[v] - k2)) /
                     std::max(std::abs(k1), std::abs(k2)));
  }
  std::sort(errors.begin(), errors.end());
  if (errors.empty()) return s;
  s.median = errors[errors.size() / 2];
  s.p95 = errors[std::min(errors.size() - 1, errors.size() * 95 / 100)];
  return s;
}

// Icosphere(5) (10242 vertices), each vertex moved in its tangent plane by up to 0.45 edge and
// put back on the unit sphere, then flipped to the hull.
Mesh RandomSphere() {
  Mesh m = Icosphere(5);
  const double h = MeanEdgeLength(m, BuildTopology(m));
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> jitter(-0.45 * h, 0.45 * h);
  for (Vec3& p : m.positions) p = Normalized(p + Vec3{jitter(rng), jitter(rng), jitter(rng)});
  MakeDelaunay(m);
  return m;
}

// A (u, v) grid of 168 x 56 vertices on the torus (R = 3, r = 1), each moved by up to 0.45 step
// in u and v, faces outward, then flipped.
Mesh RandomTorus() {
  constexpr int kU = 168, kV = 56;
  constexpr double R = 3.0, r = 1.0;
  std::mt19937_64 rng(22);
  std::uniform_real_distribution<double> jitter(-0.45, 0.45);
  Mesh m;
  for (int i = 0; i < kU; ++i) {
    for (int j = 0; j < kV; ++j) {
      const double u = (i + jitter(rng)) * 2.0 * kPi / kU, v = (j + jitter(rng)) * 2.0 * kPi / kV;
      m.positions.push_back(
          {(R + r * std::cos(v)) * std::cos(u), (R + r * std::cos(v)) * std::sin(u), r * std::sin(v)});
    }
  }
  for (int i = 0; i < kU; ++i) {
    for (int j = 0; j < kV; ++j) {
      const int32_t a = i * kV + j, b = ((i + 1) % kU) * kV + j, c = ((i + 1) % kU) * kV + (j + 1) % kV,
                    d = i * kV + (j + 1) % kV;
      m.triangles.push_back({a, b, c});
      m.triangles.push_back({a, c, d});
    }
  }
  MakeDelaunay(m);
  return m;
}

// The torus's principal curvatures at p with outward normals: 1/r around the tube and
// cos v / (R + r cos v) around the axis.
std::pair<double, double> TorusCurvatures(const Vec3& p) {
  const double rho = std::hypot(p.x, p.y), cos_v = (rho - 3.0) / 1.0;
  const double around_axis = cos_v / (3.0 + cos_v);
  return {1.0, around_axis};
}

// Prints the errors of `m` and checks the estimator's bounds: median <= 5%, 95th percentile <= 15%,
// every vertex with an estimate.
template <typename Truth>
void ExpectAccurate(const char* name, const Mesh& m, Truth truth) {
  const ErrorStats s = CurvatureErrors(m, truth);
  std::printf(
      "%s through %d stratified random points: relative error median %.4f%%, 95th percentile %.4f%%, "
      "%lld vertices without an estimate\n",
      name, m.num_vertices(), 100.0 * s.median, 100.0 * s.p95, static_cast<long long>(s.unclassified));
  EXPECT_LE(s.median, 0.05) << name;
  EXPECT_LE(s.p95, 0.15) << name;
  EXPECT_EQ(s.unclassified, 0) << name;
}

TEST(CurvatureMeshesTest, SphereAndTorusThroughRandomPoints) {
  ExpectAccurate("sphere", RandomSphere(), [](const Vec3&) { return std::make_pair(1.0, 1.0); });
  ExpectAccurate("torus (R = 3, r = 1)", RandomTorus(), TorusCurvatures);
}

// Marching tetrahedra (core/shapes/marching_tetrahedra.h) on a grid of the signed distance to a sphere of radius 1,
// its centre off the grid's symmetry so that no grid node lies on the surface.
constexpr Vec3 kCentre{0.0123, 0.0371, 0.0217};

Mesh MarchingTetrahedraSphere(double step) {
  return MarchingTetrahedra([](const Vec3& p) { return Norm(p - kCentre) - 1.0; }, Vec3{-1.3, -1.3, -1.3},
                            Vec3{1.3, 1.3, 1.3}, step);
}

// The marching-tetrahedra sphere: every vertex gets an estimate (1210 of valence 3 or 4, and
// slivers), and with the vertices moved onto the sphere along the radius the estimate is exact
// there (Max's normals and the per-face fit are exact on any inscribed triangulation). The raw
// extraction is printed but not bounded: its vertices sit off the sphere by the linear
// interpolation's error (up to about step^2 / 8 = 3e-4 here), which on edges as short as
// 0.01 puts a 1-ring estimate off by tens of percent (measured: median 32.7%, 95th percentile
// 208%); the bounds of 5% / 15% there need a wider support than the 1-ring (docs/decisions.md).
TEST(CurvatureMeshesTest, MarchingTetrahedraSphere) {
  const Vec3 centre = kCentre;
  const Mesh raw = MarchingTetrahedraSphere(0.05);
  Mesh on_sphere = raw;
  for (Vec3& p : on_sphere.positions) p = centre + Normalized(p - centre);
  ValidationReport report;
  const Topology topo = BuildTopology(raw, &report);
  ASSERT_TRUE(report.closed() && report.manifold()) << FormatReport(report);
  int64_t valence_3_or_4 = 0;
  for (int32_t v = 0; v < raw.num_vertices(); ++v) valence_3_or_4 += topo.valence(v) <= 4;
  const auto unit = [](const Vec3&) { return std::make_pair(1.0, 1.0); };
  const ErrorStats r = CurvatureErrors(raw, unit);
  const ErrorStats s = CurvatureErrors(on_sphere, unit);
  std::printf(
      "marching-tetrahedra sphere: %d vertices (%lld of valence 3 or 4), %lld zero-area faces; relative "
      "error median %.4f%%, 95th percentile %.4f%%, %lld without an estimate; vertices on the sphere: "
      "median %.4f%%, 95th percentile %.4f%%, %lld without an estimate\n",
      raw.num_vertices(), static_cast<long long>(valence_3_or_4), static_cast<long long>(report.zero_area_faces),
      100.0 * r.median, 100.0 * r.p95, static_cast<long long>(r.unclassified), 100.0 * s.median, 100.0 * s.p95,
      static_cast<long long>(s.unclassified));
  EXPECT_GT(valence_3_or_4, 1000);
  EXPECT_EQ(r.unclassified, 0);
  EXPECT_EQ(s.unclassified, 0);
  EXPECT_LE(s.median, 0.05);
  EXPECT_LE(s.p95, 0.15);
  EXPECT_EQ(DetectFeatures(raw, topo).classified, raw.num_vertices());
}

}  // namespace
}  // namespace meshsmooth
