// The mesh as the user sent it: positions and triangles, index for index.
//
// Nothing here is cleaned or reordered: faces with repeated or out-of-range indices stay in
// `triangles` (the topology ignores them and the validation report counts them), so what is
// smoothed and written back is the user's own mesh with only positions changed.
//
// Optional per-vertex colours ride along: read from and written to PLY (`red green blue`
// uchar properties); OBJ, OFF, STL and Draco ignore them on both read and write.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "core/vec3.h"

namespace meshsmooth {

using Triangle = std::array<int32_t, 3>;

// An 8-bit sRGB colour.
struct Rgb {
  uint8_t r = 0, g = 0, b = 0;
  friend constexpr bool operator==(const Rgb&, const Rgb&) = default;
};

struct Mesh {
  std::vector<Vec3> positions;
  std::vector<Triangle> triangles;
  // Per-vertex colours: empty when the mesh has none, otherwise one per vertex (colors[i] is
  // the colour of positions[i]). Nothing in core changes them: a flow moves positions only.
  std::vector<Rgb> colors;

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
