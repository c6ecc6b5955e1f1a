#include "core/shapes.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <unordered_map>
#include <utility>
#include <vector>

#include "core/metrics.h"
#include "core/normals.h"
#include "core/topology.h"

namespace meshsmooth {
namespace {

// ln(x) for finite x > 0 from +, -, *, / and frexp alone (core is built without FMA
// contraction, and sqrt is correctly rounded), so noise is the same bytes on every CPU:
// glibc picks among log implementations by CPU features. x = m 2^e with m in
// [sqrt(1/2), sqrt(2)), ln m = 2 atanh(t), t = (m - 1) / (m + 1), |t| < 0.172; the series
// to t^25 is exact to double precision.
double PortableLog(double x) {
  int e = 0;
  double m = std::frexp(x, &e);  // m in [0.5, 1)
  if (m < std::numbers::sqrt2 / 2.0) {
    m *= 2.0;
    --e;
  }
  const double t = (m - 1.0) / (m + 1.0), t2 = t * t;
  double sum = 0.0;
  for (int k = 25; k >= 1; k -= 2) sum = sum * t2 + 1.0 / k;
  return 2.0 * t * sum + e * std::numbers::ln2;
}

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
  // Standard normal: Marsaglia's polar method, with PortableLog for the logarithm.
  double NextGaussian() {
    for (;;) {
      const double u = NextSigned(), v = NextSigned(), s = u * u + v * v;
      if (s > 0.0 && s < 1.0) return u * std::sqrt(-2.0 * PortableLog(s) / s);
    }
  }
  // Uniform on the unit sphere: a point of the unit ball by rejection, normalised.
  Vec3 NextDirection() {
    for (;;) {
      const Vec3 p{NextSigned(), NextSigned(), NextSigned()};
      const double s = SquaredNorm(p);
      if (s > 1e-6 && s <= 1.0) return p * (1.0 / std::sqrt(s));
    }
  }

 private:
  uint64_t state_;
};

// Moves each vertex a usable face touches by sigma h N(0, 1) along direction(v), in vertex
// order (one Gaussian, then whatever `direction` draws, per vertex).
template <typename Direction>
void AddGaussianNoise(Mesh& mesh, double sigma_fraction_of_mean_edge, uint64_t seed, Direction&& direction) {
  const Topology topo = BuildTopology(mesh);
  const double sigma = sigma_fraction_of_mean_edge * MeanEdgeLength(mesh, topo);
  SplitMix64 rng(seed);
  for (int32_t v = 0; v < topo.num_vertices(); ++v) {
    if (topo.kind[v] == VertexKind::kIsolated) continue;
    const double distance = sigma * rng.NextGaussian();
    mesh.positions[v] += distance * direction(v, rng);
  }
}

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

Mesh MarchingTetrahedra(const std::function<double(const Vec3&)>& f, const Vec3& lo, const Vec3& hi, double step) {
  const int nx = static_cast<int>(std::ceil((hi.x - lo.x) / step)) + 1;
  const int ny = static_cast<int>(std::ceil((hi.y - lo.y) / step)) + 1;
  const int nz = static_cast<int>(std::ceil((hi.z - lo.z) / step)) + 1;
  auto id = [&](int i, int j, int k) { return (static_cast<int64_t>(i) * ny + j) * nz + k; };
  const int64_t nodes = static_cast<int64_t>(nx) * ny * nz;
  Mesh m;
  std::unordered_map<int64_t, int32_t> edge_vertex;  // key: smaller node * nodes + larger node
  // The six tetrahedra of a cube with corners c = bits (x, y, z), all around the diagonal 0-7.
  static constexpr int kTets[6][4] = {{0, 1, 3, 7}, {0, 3, 2, 7}, {0, 2, 6, 7}, {0, 6, 4, 7}, {0, 4, 5, 7}, {0, 5, 1, 7}};
  // f on the grid, one x-slab pair at a time.
  std::vector<double> value(static_cast<size_t>(2) * ny * nz);
  auto fill = [&](int i, double* slab) {
    for (int j = 0; j < ny; ++j) {
      for (int k = 0; k < nz; ++k) slab[j * nz + k] = f(Vec3{lo.x + i * step, lo.y + j * step, lo.z + k * step});
    }
  };
  fill(0, value.data());
  for (int i = 0; i + 1 < nx; ++i) {
    double* const slab[2] = {value.data() + static_cast<size_t>(i % 2) * ny * nz,
                             value.data() + static_cast<size_t>((i + 1) % 2) * ny * nz};
    fill(i + 1, slab[1]);
    for (int j = 0; j + 1 < ny; ++j) {
      for (int k = 0; k + 1 < nz; ++k) {
        int64_t ids[8];
        Vec3 ps[8];
        double ds[8];
        for (int c = 0; c < 8; ++c) {
          const int di = c & 1, dj = (c >> 1) & 1, dk = (c >> 2) & 1;
          ids[c] = id(i + di, j + dj, k + dk);
          ps[c] = Vec3{lo.x + (i + di) * step, lo.y + (j + dj) * step, lo.z + (k + dk) * step};
          ds[c] = slab[di][(j + dj) * nz + k + dk];
        }
        for (const auto& tet : kTets) {
          int in[4], out[4], n_in = 0, n_out = 0;
          for (int c : tet) (ds[c] < 0.0 ? in[n_in++] : out[n_out++]) = c;
          if (n_in == 0 || n_out == 0) continue;
          auto cut = [&](int a, int b) {
            const int64_t key = std::min(ids[a], ids[b]) * nodes + std::max(ids[a], ids[b]);
            const auto [it, added] = edge_vertex.try_emplace(key, m.num_vertices());
            if (added) m.positions.push_back(ps[a] + (ps[b] - ps[a]) * (ds[a] / (ds[a] - ds[b])));
            return it->second;
          };
          // Faces outward, decided on the tetrahedron's corners (a triangle cut close to a
          // corner can be too thin for its own normal to say). Lone corner L: the cut triangle
          // (L + t_i (R_i - L)) turns like (R_0 - L, R_1 - L, R_2 - L) around L, t_i > 0. Two
          // and two: the quad through the four crossed edges turns like the one through their
          // midpoints.
          if (n_in == 1 || n_out == 1) {
            const int lone = n_in == 1 ? in[0] : out[0];
            int* rest = n_in == 1 ? out : in;
            const Vec3 l = ps[lone];
            const double turn = Dot(ps[rest[0]] - l, Cross(ps[rest[1]] - l, ps[rest[2]] - l));
            if ((turn > 0.0) != (n_in == 1)) std::swap(rest[1], rest[2]);  // away from an inside L
            m.triangles.push_back({cut(lone, rest[0]), cut(lone, rest[1]), cut(lone, rest[2])});
          } else {
            auto mid = [&](int a, int b) { return (ps[a] + ps[b]) * 0.5; };
            const Vec3 ma = mid(in[0], out[0]), mb = mid(in[0], out[1]), mc = mid(in[1], out[1]);
            const Vec3 outward = ps[out[0]] + ps[out[1]] - ps[in[0]] - ps[in[1]];
            if (Dot(Cross(mb - ma, mc - ma), outward) < 0.0) std::swap(out[0], out[1]);
            const int32_t a = cut(in[0], out[0]), b = cut(in[0], out[1]), c = cut(in[1], out[1]), d = cut(in[1], out[0]);
            m.triangles.push_back({a, b, c});
            m.triangles.push_back({a, c, d});
          }
        }
      }
    }
  }
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
    for (size_t h = 0; h < centre.size(); ++h) in_hole[v] |= SquaredNorm(sphere.positions[v] - centre[h]) < radius_sq[h];
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

void AddUniformNoise(Mesh& mesh, double fraction_of_mean_edge, uint64_t seed) {
  const double amplitude = fraction_of_mean_edge * MeanEdgeLength(mesh, BuildTopology(mesh));
  SplitMix64 rng(seed);
  for (Vec3& p : mesh.positions) {
    p.x += amplitude * rng.NextSigned();
    p.y += amplitude * rng.NextSigned();
    p.z += amplitude * rng.NextSigned();
  }
}

void AddNormalNoise(Mesh& mesh, double sigma_fraction_of_mean_edge, uint64_t seed) {
  const std::vector<Vec3> normals = VertexNormals(mesh);
  AddGaussianNoise(mesh, sigma_fraction_of_mean_edge, seed, [&](int32_t v, SplitMix64&) { return normals[v]; });
}

void AddRandomDirectionNoise(Mesh& mesh, double sigma_fraction_of_mean_edge, uint64_t seed) {
  AddGaussianNoise(mesh, sigma_fraction_of_mean_edge, seed,
                   [](int32_t, SplitMix64& rng) { return rng.NextDirection(); });
}

}  // namespace meshsmooth
