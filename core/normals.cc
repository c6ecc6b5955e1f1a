#include "core/normals.h"

namespace meshsmooth {

std::vector<Vec3> VertexNormals(const Mesh& mesh) { return VertexNormals(mesh.positions, mesh.triangles); }

std::vector<Vec3> VertexNormals(std::span<const Vec3> positions, std::span<const Triangle> triangles) {
  const auto n = static_cast<int32_t>(positions.size());
  std::vector<Vec3> normals(n);
  for (const Triangle& t : triangles) {
    if (!IsUsableTriangle(t, n)) continue;
    const Vec3& a = positions[t[0]];
    // The unnormalised cross product weights each face by its area.
    const Vec3 fn = Cross(positions[t[1]] - a, positions[t[2]] - a);
    for (int32_t v : t) normals[v] += fn;
  }
  for (Vec3& v : normals) {
    const double len = Norm(v);
    v = len > 0.0 && std::isfinite(len) ? v * (1.0 / len) : Vec3{};
  }
  return normals;
}

}  // namespace meshsmooth
