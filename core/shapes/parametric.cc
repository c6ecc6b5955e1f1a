#include "core/shapes/parametric.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <utility>
#include <vector>

#include "core/shapes/random.h"

namespace meshsmooth {
namespace {

using shapes_internal::SplitMix64;

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

// Triangulates `rows` rows of `columns` vertices each (vertex (r, c) = r * columns + c) in
// which odd rows sit half a column step further along than even rows: every cell between two
// rows becomes one triangle with its base on each row, so equal steps give equilateral
// triangles. Counter-clockwise in (column, row) coordinates unless `flip`. With `periodic`
// the last column is joined to the first (a cylinder); otherwise the side edges are jagged.
void AddOffsetRowStrips(Mesh& m, int rows, int columns, bool periodic, bool flip) {
  auto add = [&](int32_t a, int32_t b, int32_t c) {
    if (flip) std::swap(b, c);
    m.triangles.push_back({a, b, c});
  };
  for (int r = 0; r + 1 < rows; ++r) {
    // The vertex of the next row that lies between columns c and c + 1 of this one is c + s.
    const int s = r % 2;
    auto a = [&](int c) { return static_cast<int32_t>(r * columns + (c + columns) % columns); };
    auto b = [&](int c) { return static_cast<int32_t>((r + 1) * columns + (c + columns) % columns); };
    for (int c = 0; c < columns; ++c) {
      if (periodic || (c + 1 < columns && c + s < columns)) add(a(c), a(c + 1), b(c + s));
      if (periodic || (c + s - 1 >= 0 && c + s < columns)) add(a(c), b(c + s), b(c + s - 1));
    }
  }
}

}  // namespace

Mesh Icosphere(int level) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  Mesh m;
  for (const Vec3& v :
       {Vec3{-1, t, 0}, Vec3{1, t, 0}, Vec3{-1, -t, 0}, Vec3{1, -t, 0}, Vec3{0, -1, t}, Vec3{0, 1, t}, Vec3{0, -1, -t},
        Vec3{0, 1, -t}, Vec3{t, 0, -1}, Vec3{t, 0, 1}, Vec3{-t, 0, -1}, Vec3{-t, 0, 1}}) {
    m.positions.push_back(Normalized(v));
  }
  m.triangles = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                 {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                 {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
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

Mesh TwoRateTorus(int tube_segments, double major_radius, double minor_radius, int32_t* dense_vertices) {
  const int dense_count = std::max(8, tube_segments + tube_segments % 2), coarse_count = dense_count / 2;
  // Every other column is shifted by half a step around the tube and columns are sqrt(3)/2
  // steps apart (at the mean radius), so the triangles are close to equilateral.
  const double dv = 2.0 * std::numbers::pi / dense_count;
  const double du = std::sqrt(3.0) / 2.0 * minor_radius / major_radius * dv;
  const int dense_columns = 2 * std::max(1, static_cast<int>(std::lround(std::numbers::pi / du / 2.0)));
  const double split = dense_columns * du;
  const int coarse_columns =
      2 * std::max(1, static_cast<int>(std::lround((2.0 * std::numbers::pi - split) / (4.0 * du))));
  const double coarse_du = (2.0 * std::numbers::pi - split) / coarse_columns;

  struct Column {
    int32_t first, count;
    double v0;  // angle of the column's first vertex around the tube
  };
  std::vector<Column> columns;
  Mesh m;
  auto add_column = [&](double u, int count, bool shifted) {
    const double step = 2.0 * std::numbers::pi / count;
    columns.push_back({m.num_vertices(), count, shifted ? 0.5 * step : 0.0});
    for (int j = 0; j < count; ++j) {
      const double v = columns.back().v0 + step * j;
      const double ring = major_radius + minor_radius * std::cos(v);
      m.positions.push_back({ring * std::cos(u), ring * std::sin(u), minor_radius * std::sin(v)});
    }
  };
  for (int i = 0; i < dense_columns; ++i) add_column(i * du, dense_count, i % 2 == 1);
  if (dense_vertices != nullptr) *dense_vertices = m.num_vertices();
  for (int i = 0; i < coarse_columns; ++i) add_column(split + i * coarse_du, coarse_count, i % 2 == 1);

  // Zip each pair of neighbouring columns into a strip: walk both columns upwards in v and
  // always advance the one whose next vertex comes first. Handles equal counts and the 2:1
  // seams alike; triangles are counter-clockwise in (u, v), so normals point outward.
  for (size_t c = 0; c < columns.size(); ++c) {
    const Column a = columns[c], b = columns[(c + 1) % columns.size()];
    const double sa = 2.0 * std::numbers::pi / a.count, sb = 2.0 * std::numbers::pi / b.count;
    auto va = [&](int i) { return a.v0 + sa * i; };
    // Start B at its last vertex below A's first one.
    int k0 = static_cast<int>(std::floor((a.v0 - b.v0) / sb + 1e-9));
    auto vb = [&](int k) { return b.v0 + sb * k; };
    int i = 0, k = k0;
    auto A = [&a](int j) { return a.first + ((j % a.count) + a.count) % a.count; };
    auto B = [&b](int j) { return b.first + ((j % b.count) + b.count) % b.count; };
    while (i < a.count || k < k0 + b.count) {
      const bool advance_a = k >= k0 + b.count || (i < a.count && va(i + 1) < vb(k + 1) - 1e-12);
      if (advance_a) {
        m.triangles.push_back({A(i), B(k), A(i + 1)});
        ++i;
      } else {
        m.triangles.push_back({A(i), B(k), B(k + 1)});
        ++k;
      }
    }
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

Mesh Cylinder(double radius, double height, int around, int along) {
  around = std::max(3, around);
  along = std::max(2, along);
  Mesh m;
  const double step = 2.0 * std::numbers::pi / around;
  for (int k = 0; k < along; ++k) {
    const double z = height * k / (along - 1);
    for (int j = 0; j < around; ++j) {
      const double a = step * (j + 0.5 * (k % 2));
      m.positions.push_back({radius * std::cos(a), radius * std::sin(a), z});
    }
  }
  AddOffsetRowStrips(m, along, around, /*periodic=*/true, /*flip=*/false);
  return m;
}

Mesh SliverShaft(int around) {
  around = std::max(8, around);
  Mesh m;
  // Rings 0..3: (radius, z) = (0.5, 0), (0.5, 1), (0.3, 1), (0.3, 2); then the caps' centres.
  const double radius[4] = {0.5, 0.5, 0.3, 0.3}, height[4] = {0.0, 1.0, 1.0, 2.0};
  const double step = 2.0 * std::numbers::pi / around;
  for (int k = 0; k < 4; ++k) {
    for (int j = 0; j < around; ++j) {
      m.positions.push_back({radius[k] * std::cos(step * j), radius[k] * std::sin(step * j), height[k]});
    }
  }
  const auto bottom = static_cast<int32_t>(m.positions.size());
  m.positions.push_back({0.0, 0.0, 0.0});
  m.positions.push_back({0.0, 0.0, 2.0});
  auto at = [&](int k, int j) { return static_cast<int32_t>(k * around + (j % around)); };
  for (int j = 0; j < around; ++j) {
    // Outward: the sides face away from the axis, the annulus and the top cap up, the bottom
    // cap down.
    for (int k = 0; k < 3; ++k) AddQuad(m, at(k, j), at(k, j + 1), at(k + 1, j + 1), at(k + 1, j));
    m.triangles.push_back({bottom, at(0, j + 1), at(0, j)});
    m.triangles.push_back({bottom + 1, at(3, j), at(3, j + 1)});
  }
  return m;
}

int CylinderRings(double radius, double height, int around) {
  // Ring spacing sqrt(3)/2 of the chord between neighbours on a ring.
  const double chord = 2.0 * radius * std::sin(std::numbers::pi / std::max(3, around));
  return std::max(2, static_cast<int>(std::lround(height / (std::sqrt(3.0) / 2.0 * chord))) + 1);
}

Mesh CosineHeightField(double amplitude, int periods, int rows_per_period, int columns) {
  periods = std::max(1, periods);
  rows_per_period = std::max(4, rows_per_period);
  columns = std::max(2, columns);
  const int rows = periods * rows_per_period + 1;
  const double dx = 2.0 * std::numbers::pi / rows_per_period, dy = 2.0 / std::sqrt(3.0) * dx;
  Mesh m;
  for (int i = 0; i < rows; ++i) {
    const double x = dx * i;
    for (int j = 0; j < columns; ++j) {
      m.positions.push_back({x, dy * (j + 0.5 * (i % 2)), amplitude * std::cos(x)});
    }
  }
  // Rows run along x, so (column, row) = (y, x) is clockwise seen from +z: flip for +z normals.
  AddOffsetRowStrips(m, rows, columns, /*periodic=*/false, /*flip=*/true);
  return m;
}

Mesh HoleySphere(int level, int holes, double radius, uint64_t seed) {
  const Mesh sphere = Icosphere(level);
  SplitMix64 rng(seed);
  // Distances are chords (no trigonometry: libm's last bit may differ between machines).
  std::vector<Vec3> centre;
  std::vector<double> radius_sq;
  const double apart_sq = (3.0 * 1.5 * radius) * (3.0 * 1.5 * radius);
  for (int tries = 0; static_cast<int>(centre.size()) < holes && tries < 100 * holes; ++tries) {
    const Vec3 c = rng.NextDirection();
    const double r = radius * (1.0 + 0.5 * rng.NextSigned());
    bool free = true;
    for (const Vec3& other : centre) free = free && SquaredNorm(c - other) > apart_sq;
    if (!free) continue;
    centre.push_back(c);
    radius_sq.push_back(r * r);
  }
  std::vector<uint8_t> in_hole(sphere.positions.size(), 0);
  for (size_t v = 0; v < sphere.positions.size(); ++v) {
    for (size_t h = 0; h < centre.size(); ++h)
      in_hole[v] |= SquaredNorm(sphere.positions[v] - centre[h]) < radius_sq[h];
  }
  Mesh m;
  std::vector<int32_t> index(sphere.positions.size(), -1);
  for (const Triangle& t : sphere.triangles) {
    if (in_hole[t[0]] || in_hole[t[1]] || in_hole[t[2]]) continue;
    Triangle kept;
    for (int c = 0; c < 3; ++c) {
      if (index[t[c]] < 0) {
        index[t[c]] = m.num_vertices();
        m.positions.push_back(sphere.positions[t[c]]);
      }
      kept[c] = index[t[c]];
    }
    m.triangles.push_back(kept);
  }
  return m;
}

}  // namespace meshsmooth
