#include "core/attributes.h"

#include <algorithm>
#include <cmath>

namespace meshsmooth {

bool AllFloat32(const std::vector<double>& values) {
  return std::all_of(values.begin(), values.end(),
                     [](double v) { return !std::isfinite(v) || static_cast<double>(static_cast<float>(v)) == v; });
}

std::optional<std::vector<double>> PerVertexValues(const Mesh& mesh, const CornerAttribute& a) {
  if (a.empty() || a.corners.size() != 3 * mesh.triangles.size()) return std::nullopt;
  const int c = a.components;
  const int64_t entries = a.entries();
  // The common case (a PLY's per-vertex values, normals from FreshNormals): corner k of
  // triangle t names entry triangles[t][k], and there is one entry per vertex.
  if (entries == mesh.num_vertices()) {
    bool identity = true;
    for (size_t i = 0; i < a.corners.size() && identity; ++i) identity = a.corners[i] == mesh.triangles[i / 3][i % 3];
    if (identity) return a.values;
  }
  std::vector<double> out(static_cast<size_t>(c) * mesh.positions.size(), 0.0);
  std::vector<int32_t> entry_of(mesh.positions.size(), -1);
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const int32_t v = mesh.triangles[t][k];
      const int32_t e = a.corners[3 * t + k];
      // A corner of a vertex that does not exist keeps its value only per corner.
      if (v < 0 || v >= mesh.num_vertices()) {
        if (e >= 0) return std::nullopt;
        continue;
      }
      if (e < 0 || e >= entries) return std::nullopt;  // a corner without a value cannot go per vertex
      int32_t& seen = entry_of[v];
      if (seen == e) continue;
      if (seen >= 0) {
        for (int j = 0; j < c; ++j) {
          if (a.values[static_cast<size_t>(c) * seen + j] != a.values[static_cast<size_t>(c) * e + j]) {
            return std::nullopt;
          }
        }
        continue;
      }
      seen = e;
      for (int j = 0; j < c; ++j) out[static_cast<size_t>(c) * v + j] = a.values[static_cast<size_t>(c) * e + j];
    }
  }
  return out;
}

CornerAttribute FreshNormals(const Mesh& mesh, const CornerAttribute& layout) {
  CornerAttribute n;
  n.components = 3;
  if (layout.components == 3 && layout.corners.size() == 3 * mesh.triangles.size()) {
    n.values = layout.values;
    n.corners = layout.corners;
  } else {
    n.values.assign(3 * mesh.positions.size(), 0.0);
    n.corners.resize(3 * mesh.triangles.size());
    for (size_t t = 0; t < mesh.triangles.size(); ++t) {
      for (int k = 0; k < 3; ++k) {
        const int32_t v = mesh.triangles[t][k];
        n.corners[3 * t + k] = v >= 0 && v < mesh.num_vertices() ? v : -1;
      }
    }
  }
  const int64_t entries = n.entries();
  std::vector<Vec3> sum(entries);
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const Triangle& tri = mesh.triangles[t];
    if (!IsUsableTriangle(tri, mesh.num_vertices())) continue;
    const Vec3& a = mesh.positions[tri[0]];
    const Vec3 fn = Cross(mesh.positions[tri[1]] - a, mesh.positions[tri[2]] - a);  // |fn| = 2 x area
    for (int k = 0; k < 3; ++k) {
      const int32_t e = n.corners[3 * t + k];
      if (e >= 0 && e < entries) sum[e] += fn;
    }
  }
  for (int64_t e = 0; e < entries; ++e) {
    const double len = Norm(sum[e]);
    if (!(len > 0.0) || !std::isfinite(len)) {
      if (layout.empty()) n.values[3 * e + 2] = 1.0;  // no old value: +z
      continue;
    }
    const Vec3 u = sum[e] * (1.0 / len);
    n.values[3 * e] = u.x;
    n.values[3 * e + 1] = u.y;
    n.values[3 * e + 2] = u.z;
  }
  return n;
}

}  // namespace meshsmooth
