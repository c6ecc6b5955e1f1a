// The mesh as the user sent it: positions and triangles, index for index.
//
// Nothing here is cleaned or reordered: faces with repeated or out-of-range indices stay in
// `triangles` (the topology ignores them and the validation report counts them), so what is
// smoothed and written back is the user's own mesh with only positions changed.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "core/vec3.h"

namespace meshsmooth {

using Triangle = std::array<int32_t, 3>;

struct Mesh {
  std::vector<Vec3> positions;
  std::vector<Triangle> triangles;

  int32_t num_vertices() const { return static_cast<int32_t>(positions.size()); }
  int32_t num_triangles() const { return static_cast<int32_t>(triangles.size()); }
};

// True when the face's indices are in [0, num_vertices) and pairwise distinct: the only faces
// the topology and OpenMesh may see (Debian's OpenMesh asserts on anything else).
inline bool IsUsableTriangle(const Triangle& t, int32_t num_vertices) {
  for (int32_t i : t) {
    if (i < 0 || i >= num_vertices) return false;
  }
  return t[0] != t[1] && t[1] != t[2] && t[0] != t[2];
}

}  // namespace meshsmooth
