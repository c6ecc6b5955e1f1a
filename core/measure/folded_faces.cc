#include "core/measure/folded_faces.h"

namespace meshsmooth {

FaceFolds::FaceFolds(const Mesh& mesh, const Topology& topo) : mesh_(mesh), topo_(topo) {
  const auto faces = static_cast<int32_t>(topo.faces.size());
  const int32_t n = topo.num_vertices();
  // The usable faces around each vertex (CSR), to find the other face of each edge.
  std::vector<int32_t> offsets(n + 1, 0), around(3 * static_cast<size_t>(faces));
  for (int32_t f = 0; f < faces; ++f) {
    for (int32_t v : face(f)) ++offsets[v + 1];
  }
  for (int32_t v = 0; v < n; ++v) offsets[v + 1] += offsets[v];
  std::vector<int32_t> fill(offsets.begin(), offsets.end() - 1);
  for (int32_t f = 0; f < faces; ++f) {
    for (int32_t v : face(f)) around[fill[v]++] = f;
  }
  across_.assign(faces, {-1, -1, -1});
  for (int32_t f = 0; f < faces; ++f) {
    const Triangle& t = face(f);
    for (int k = 0; k < 3; ++k) {
      const int32_t a = t[k], b = t[(k + 1) % 3];
      int32_t other = -1, count = 0;
      for (int32_t i = offsets[a]; i < offsets[a + 1]; ++i) {
        const int32_t g = around[i];
        const Triangle& u = face(g);
        if (g != f && (u[0] == b || u[1] == b || u[2] == b)) {
          other = g;
          ++count;
        }
      }
      if (count == 1) across_[f][k] = other;
    }
  }
}

std::vector<uint8_t> FaceFolds::Folded(const Vec3* pos) const {
  const auto faces = static_cast<int32_t>(across_.size());
  std::vector<Vec3> normal(faces);
  for (int32_t f = 0; f < faces; ++f) {
    const Triangle& t = face(f);
    normal[f] = Cross(pos[t[1]] - pos[t[0]], pos[t[2]] - pos[t[0]]);
  }
  std::vector<uint8_t> folded(faces, 0);
  for (int32_t f = 0; f < faces; ++f) {
    for (int32_t g : across_[f]) folded[f] |= g >= 0 && Dot(normal[f], normal[g]) < 0.0;
  }
  return folded;
}

int64_t FaceFolds::Count(const Vec3* pos) const {
  int64_t count = 0;
  for (uint8_t f : Folded(pos)) count += f;
  return count;
}

}  // namespace meshsmooth
