#include "core/shapes/marching_tetrahedra.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>
#include <utility>
#include <vector>

namespace meshsmooth {

Mesh MarchingTetrahedra(const std::function<double(const Vec3&)>& f, const Vec3& lo, const Vec3& hi, double step) {
  const int nx = static_cast<int>(std::ceil((hi.x - lo.x) / step)) + 1;
  const int ny = static_cast<int>(std::ceil((hi.y - lo.y) / step)) + 1;
  const int nz = static_cast<int>(std::ceil((hi.z - lo.z) / step)) + 1;
  auto id = [&](int i, int j, int k) { return (static_cast<int64_t>(i) * ny + j) * nz + k; };
  const int64_t nodes = static_cast<int64_t>(nx) * ny * nz;
  Mesh m;
  std::unordered_map<int64_t, int32_t> edge_vertex;  // key: smaller node * nodes + larger node
  // The six tetrahedra of a cube with corners c = bits (x, y, z), all around the diagonal 0-7.
  static constexpr int kTets[6][4] = {{0, 1, 3, 7}, {0, 3, 2, 7}, {0, 2, 6, 7},
                                      {0, 6, 4, 7}, {0, 4, 5, 7}, {0, 5, 1, 7}};
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
            const int32_t a = cut(in[0], out[0]), b = cut(in[0], out[1]), c = cut(in[1], out[1]),
                          d = cut(in[1], out[0]);
            m.triangles.push_back({a, b, c});
            m.triangles.push_back({a, c, d});
          }
        }
      }
    }
  }
  return m;
}

}  // namespace meshsmooth
