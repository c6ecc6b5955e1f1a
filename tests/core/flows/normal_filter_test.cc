// The normal-filtering flows bilateral_normal and guided_normal: creases stay sharp where the
// paper's flows round them, on a noisy cube and on fandisk (a CAD part).
#include <cmath>
#include <map>
#include <random>
#include <utility>

#include "core/flows/flow.h"
#include "core/io/mesh_io.h"
#include "core/normals.h"
#include "gtest/gtest.h"
#include "tests/flow_fixtures.h"
#include "tests/test_data.h"

namespace meshsmooth {
namespace {

using testing::Params;

// A cube [-1, 1]^3 with each side an n x n grid of squares split into two triangles, outward.
Mesh GridCube(int n) {
  Mesh m;
  std::map<std::array<int, 3>, int32_t> index;  // integer grid coordinates -> vertex
  auto vertex = [&](std::array<int, 3> g) {
    auto [it, fresh] = index.emplace(g, m.num_vertices());
    if (fresh) m.positions.push_back(Vec3{double(g[0]), double(g[1]), double(g[2])} * (2.0 / n) - Vec3{1, 1, 1});
    return it->second;
  };
  for (int axis = 0; axis < 3; ++axis) {
    for (int side = 0; side < 2; ++side) {
      const int u = (axis + 1) % 3, w = (axis + 2) % 3;
      for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) {
          auto at = [&](int a, int b) {
            std::array<int, 3> g{};
            g[axis] = side * n, g[u] = a, g[w] = b;
            return vertex(g);
          };
          const int32_t p00 = at(i, j), p10 = at(i + 1, j), p11 = at(i + 1, j + 1), p01 = at(i, j + 1);
          if (side == 1) {
            m.triangles.push_back({p00, p10, p11});
            m.triangles.push_back({p00, p11, p01});
          } else {
            m.triangles.push_back({p00, p11, p10});
            m.triangles.push_back({p00, p01, p11});
          }
        }
      }
    }
  }
  return m;
}

Vec3 FaceNormal(const Mesh& m, const Triangle& t) {
  return Normalized(Cross(m.positions[t[1]] - m.positions[t[0]], m.positions[t[2]] - m.positions[t[0]]));
}

double AngleDeg(const Vec3& a, const Vec3& b) { return std::acos(std::clamp(Dot(a, b), -1.0, 1.0)) * 180.0 / M_PI; }

// Gaussian noise of sigma x h along the area-weighted vertex normals.
Mesh WithNormalNoise(const Mesh& clean, double sigma, uint64_t seed) {
  Mesh m = clean;
  const std::vector<Vec3> n = VertexNormals(clean);
  const double h = MeanEdgeLength(clean, BuildTopology(clean));
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0.0, sigma * h);
  for (size_t v = 0; v < m.positions.size(); ++v) m.positions[v] += n[v] * g(rng);
  return m;
}

// Mean face-normal error against `clean` (degrees), overall and on the faces beside an edge
// whose clean dihedral angle exceeds 30 degrees.
std::pair<double, double> NormalErrors(const Mesh& m, const Mesh& clean) {
  std::map<std::pair<int32_t, int32_t>, std::vector<size_t>> edges;
  for (size_t f = 0; f < clean.triangles.size(); ++f) {
    for (int k = 0; k < 3; ++k) {
      const int32_t a = clean.triangles[f][k], b = clean.triangles[f][(k + 1) % 3];
      edges[{std::min(a, b), std::max(a, b)}].push_back(f);
    }
  }
  std::vector<bool> crease(clean.triangles.size());
  for (const auto& [e, faces] : edges) {
    if (faces.size() == 2 &&
        AngleDeg(FaceNormal(clean, clean.triangles[faces[0]]), FaceNormal(clean, clean.triangles[faces[1]])) > 30.0) {
      crease[faces[0]] = crease[faces[1]] = true;
    }
  }
  double all = 0.0, near = 0.0;
  int count = 0, near_count = 0;
  for (size_t f = 0; f < clean.triangles.size(); ++f) {
    const double d = AngleDeg(FaceNormal(m, m.triangles[f]), FaceNormal(clean, clean.triangles[f]));
    all += d, ++count;
    if (crease[f]) near += d, ++near_count;
  }
  return {all / count, near_count > 0 ? near / near_count : 0.0};
}

int FlippedFaces(const Mesh& m, const Mesh& clean) {
  int flipped = 0;
  for (size_t f = 0; f < clean.triangles.size(); ++f) {
    flipped += Dot(FaceNormal(m, m.triangles[f]), FaceNormal(clean, clean.triangles[f])) < 0.0;
  }
  return flipped;
}

TEST(NormalFilterTest, NoisyCubeComesBackWithSharpEdgesAndCorners) {
  const Mesh clean = GridCube(12);
  const Mesh noisy = WithNormalNoise(clean, 0.1, 7);
  for (const char* flow : {"bilateral_normal", "guided_normal"}) {
    SCOPED_TRACE(flow);
    const Mesh out = testing::Smoothed(noisy, Params(flow, 20));
    // Every edge of the clean cube's 12 edges (corners included): the dihedral angle between
    // its two faces is back within 3 degrees of 90.
    std::map<std::pair<int32_t, int32_t>, std::vector<size_t>> edges;
    for (size_t f = 0; f < clean.triangles.size(); ++f) {
      for (int k = 0; k < 3; ++k) {
        const int32_t a = clean.triangles[f][k], b = clean.triangles[f][(k + 1) % 3];
        edges[{std::min(a, b), std::max(a, b)}].push_back(f);
      }
    }
    int cube_edges = 0;
    double worst = 0.0, noisy_worst = 0.0;
    for (const auto& [e, faces] : edges) {
      ASSERT_EQ(faces.size(), 2u);
      if (AngleDeg(FaceNormal(clean, clean.triangles[faces[0]]), FaceNormal(clean, clean.triangles[faces[1]])) < 45) {
        continue;
      }
      ++cube_edges;
      const double err =
          std::abs(90.0 - AngleDeg(FaceNormal(out, out.triangles[faces[0]]), FaceNormal(out, out.triangles[faces[1]])));
      worst = std::max(worst, err);
      noisy_worst = std::max(noisy_worst, std::abs(90.0 - AngleDeg(FaceNormal(noisy, noisy.triangles[faces[0]]),
                                                                   FaceNormal(noisy, noisy.triangles[faces[1]]))));
    }
    std::printf("%s: %d cube-edge mesh edges, worst dihedral error %.2f deg (noisy %.2f)\n", flow, cube_edges, worst,
                noisy_worst);
    EXPECT_EQ(cube_edges, 12 * 12);
    EXPECT_LE(worst, 3.0);
    EXPECT_GT(noisy_worst, 10.0);  // the noise did bend them
    EXPECT_EQ(FlippedFaces(out, clean), 0);
  }
}

// Fandisk at sigma = 0.2 h, one seed, against the targets of docs/normal-filtering.md ("On
// fandisk"; the quality benchmark gives the means over seeds and the other noise levels).
// guided_normal's overall bound is above its target of 1.9 degrees, which it does not reach.
TEST(NormalFilterTest, FandiskKeepsItsCreases) {
  const std::filesystem::path path = testing::SharedData("meshes") / "fandisk.obj";
  MESHSMOOTH_REQUIRE_SHARED_PATH(path);
  const Mesh clean = *ReadMesh(path.string());
  const Mesh noisy = WithNormalNoise(clean, 0.2, 1);
  const auto [noisy_all, noisy_crease] = NormalErrors(noisy, clean);
  const double volume = testing::Volume(clean);
  struct Bound {
    const char* flow;
    double all, crease;
  };
  for (const Bound& b : {Bound{"bilateral_normal", 2.2, 3.6}, Bound{"guided_normal", 2.2, 3.0}}) {
    SCOPED_TRACE(b.flow);
    const Mesh out = testing::Smoothed(noisy, Params(b.flow, 20));
    const auto [all, crease] = NormalErrors(out, clean);
    const double dv = std::abs(testing::Volume(out) - volume) / volume;
    std::printf("%s: normal error %.2f deg (noisy %.2f), crease faces %.2f (noisy %.2f), volume %.3f%%\n", b.flow, all,
                noisy_all, crease, noisy_crease, 100 * dv);
    EXPECT_LE(all, b.all);
    EXPECT_LE(crease, b.crease);
    EXPECT_LE(dv, 0.005);
    EXPECT_EQ(FlippedFaces(out, clean), 0);
  }
}

// The vertex update never folds a face over, and it unfolds the needles that the noise folded:
// no face of the result points against the clean mesh's.
TEST(NormalFilterTest, NeedlesComeBackUnfolded) {
  const Mesh clean = testing::SphereWithNeedles();
  for (uint64_t seed : {1, 2, 3}) {
    const Mesh noisy = WithNormalNoise(clean, 0.2, seed);
    const int noisy_flips = FlippedFaces(noisy, clean);
    for (const char* flow : {"bilateral_normal", "guided_normal"}) {
      SCOPED_TRACE(flow);
      const Mesh out = testing::Smoothed(noisy, Params(flow, 20));
      std::printf("%s, seed %d: %d flipped faces (noisy %d)\n", flow, static_cast<int>(seed), FlippedFaces(out, clean),
                  noisy_flips);
      EXPECT_GT(noisy_flips, 10);  // the noise did fold needles
      EXPECT_EQ(FlippedFaces(out, clean), 0);
      EXPECT_LT(NormalErrors(out, clean).first, NormalErrors(noisy, clean).first / 2);
    }
  }
}

// A face without area has no normal: it weighs nothing and moves nothing into NaN; locked
// vertices stay where they are.
TEST(NormalFilterTest, DegenerateFacesAndLockedVerticesAreSafe) {
  Mesh m = WithNormalNoise(Icosphere(3), 0.3, 5);
  const int32_t a = m.triangles[0][0], b = m.triangles[0][1];
  m.positions[b] = m.positions[a];  // two faces collapse to zero area
  for (const char* flow : {"bilateral_normal", "guided_normal"}) {
    FlowParams p = Params(flow, 5);
    p.locked.assign(m.positions.size(), 0);
    p.locked[7] = 1;
    Mesh out = m;
    ASSERT_TRUE(Smooth(out, p).ok()) << flow;
    for (const Vec3& q : out.positions) ASSERT_TRUE(IsFinite(q)) << flow;
    EXPECT_EQ(out.positions[7], m.positions[7]) << flow;
    EXPECT_LT(testing::RadiusError(out), testing::RadiusError(m)) << flow;
  }
}

TEST(NormalFilterTest, ParametersOutOfRangeAreRefused) {
  FlowParams p = Params("bilateral_normal", 1);
  p.normal_filter.sigma_range = 0.0;
  const absl::Status s = ValidateFlowParams(p, 10);
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("normal_filter.sigma_range"), std::string::npos) << s;
  p = Params("bilateral_normal", 1);
  p.normal_filter.vertex_iterations = 101;
  EXPECT_NE(ValidateFlowParams(p, 10).message().find("normal_filter.vertex_iterations"), std::string::npos);
}

}  // namespace
}  // namespace meshsmooth
