#include "core/shapes.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <utility>
#include <vector>

#include "core/metrics.h"
#include "core/topology.h"

namespace meshsmooth {
namespace {

Vec3 Normalized(const Vec3& v) { return v * (1.0 / Norm(v)); }

// splitmix64: a tiny, well-mixed generator whose output is defined by this code alone (the
// standard distributions are not bit-identical across library implementations).
class SplitMix64 {
 public:
  explicit SplitMix64(uint64_t seed) : state_(seed) {}
  uint64_t Next() {
    uint64_t z = (state_ += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  // Uniform in [-1, 1).
  double NextSigned() { return static_cast<double>(Next() >> 11) * 0x1.0p-52 - 1.0; }

 private:
  uint64_t state_;
};

// Cumulative positions of n cells: the first n/2 have width 1, the rest width `ratio`,
// scaled so that the n cells span `total`.
std::vector<double> TwoRateSamples(int n, double ratio, double total) {
  std::vector<double> s(n + 1, 0.0);
  for (int i = 0; i < n; ++i) s[i + 1] = s[i] + (i < n / 2 ? 1.0 : ratio);
  for (double& x : s) x *= total / s[n];
  return s;
}

// Appends two triangles per grid cell, (a, b, c) counter-clockwise seen from the normal side.
void AddQuad(Mesh& m, int32_t a, int32_t b, int32_t c, int32_t d) {
  m.triangles.push_back({a, b, c});
  m.triangles.push_back({a, c, d});
}

}  // namespace

Mesh Icosphere(int level) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  Mesh m;
  for (const Vec3& v : {Vec3{-1, t, 0}, Vec3{1, t, 0}, Vec3{-1, -t, 0}, Vec3{1, -t, 0},
                        Vec3{0, -1, t}, Vec3{0, 1, t}, Vec3{0, -1, -t}, Vec3{0, 1, -t},
                        Vec3{t, 0, -1}, Vec3{t, 0, 1}, Vec3{-t, 0, -1}, Vec3{-t, 0, 1}}) {
    m.positions.push_back(Normalized(v));
  }
  m.triangles = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                 {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                 {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                 {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int l = 0; l < level; ++l) {
    std::map<std::pair<int32_t, int32_t>, int32_t> midpoints;
    auto mid = [&](int32_t a, int32_t b) {
      auto [it, inserted] = midpoints.try_emplace({std::min(a, b), std::max(a, b)}, 0);
      if (inserted) {
        m.positions.push_back(Normalized(m.positions[a] + m.positions[b]));
        it->second = m.num_vertices() - 1;
      }
      return it->second;
    };
    std::vector<Triangle> next;
    next.reserve(m.triangles.size() * 4);
    for (const auto& [a, b, c] : m.triangles) {
      const int32_t ab = mid(a, b), bc = mid(b, c), ca = mid(c, a);
      next.push_back({a, ab, ca});
      next.push_back({b, bc, ab});
      next.push_back({c, ca, bc});
      next.push_back({ab, bc, ca});
    }
    m.triangles = std::move(next);
  }
  return m;
}

Mesh TwoRateTorus(int nu, int nv, double major_radius, double minor_radius, double ratio) {
  const std::vector<double> u = TwoRateSamples(nu, ratio, 2.0 * std::numbers::pi);
  Mesh m;
  m.positions.reserve(static_cast<size_t>(nu) * nv);
  for (int i = 0; i < nu; ++i) {
    for (int j = 0; j < nv; ++j) {
      const double v = 2.0 * std::numbers::pi * j / nv;
      const double ring = major_radius + minor_radius * std::cos(v);
      m.positions.push_back({ring * std::cos(u[i]), ring * std::sin(u[i]), minor_radius * std::sin(v)});
    }
  }
  auto id = [nu, nv](int i, int j) { return static_cast<int32_t>((i % nu) * nv + (j % nv)); };
  for (int i = 0; i < nu; ++i) {
    for (int j = 0; j < nv; ++j) AddQuad(m, id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
  }
  return m;
}

Mesh TwoRatePlane(int nx, int ny, double ratio) {
  const std::vector<double> x = TwoRateSamples(nx, ratio, 1.0);
  Mesh m;
  for (int j = 0; j <= ny; ++j) {
    for (int i = 0; i <= nx; ++i) m.positions.push_back({x[i], static_cast<double>(j) / ny, 0.0});
  }
  auto id = [nx](int i, int j) { return static_cast<int32_t>(j * (nx + 1) + i); };
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) AddQuad(m, id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
  }
  return m;
}

void AddUniformNoise(Mesh& mesh, double fraction_of_mean_edge, uint64_t seed) {
  const double amplitude = fraction_of_mean_edge * MeanEdgeLength(mesh, BuildTopology(mesh));
  SplitMix64 rng(seed);
  for (Vec3& p : mesh.positions) {
    p.x += amplitude * rng.NextSigned();
    p.y += amplitude * rng.NextSigned();
    p.z += amplitude * rng.NextSigned();
  }
}

}  // namespace meshsmooth
