// The mesh as the user sent it: positions and triangles, index for index.
//
// Nothing here is cleaned or reordered: faces with repeated or out-of-range indices stay in
// `triangles` (the topology ignores them and the validation report counts them), so what is
// smoothed and written back is the user's own mesh with only positions changed.
//
// Optional per-vertex colours ride along: read from and written to PLY (`red green blue`
// uchar properties), OBJ (`v x y z r g b`) and Draco (COLOR); OFF and STL ignore them.
//
// So do a scan's other attributes (core/io/mesh_io.h says which format reads and writes which):
// texture coordinates and normals per face corner, named per-vertex properties and the OBJ
// material and group lines. Nothing in core changes them; the CLI recomputes the normals from
// the smoothed positions.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/vec3.h"

namespace meshsmooth {

using Triangle = std::array<int32_t, 3>;

// An 8-bit sRGB colour.
struct Rgb {
  uint8_t r = 0, g = 0, b = 0;
  friend constexpr bool operator==(const Rgb&, const Rgb&) = default;
};

// Values given per face corner, as OBJ's `vt` and `vn` with `f v/vt/vn`: a table of values and,
// for each corner of each triangle, the index of its value. Several corners of one vertex may
// name different values (a UV seam, a hard edge).
struct CornerAttribute {
  int components = 0;            // values per entry: 2 (UV), 3 (normal); 0 = the mesh has none
  std::vector<double> values;    // components x entries
  std::vector<int32_t> corners;  // 3 per triangle, in triangle order; -1 = this corner has none
  bool empty() const { return components == 0; }
  int64_t entries() const { return components == 0 ? 0 : static_cast<int64_t>(values.size()) / components; }
};

// A named per-vertex property of a PLY file (`confidence`, `quality`, `intensity`, ...), one
// value per vertex, and the PLY type it was declared with (`float`, `uchar`, ...).
struct VertexProperty {
  std::string name;
  std::string type;
  std::vector<double> values;
};

// An OBJ line that is not geometry but names how the faces after it are shown: `mtllib`,
// `usemtl`, `g`, `o`, `s`; written back before the same triangle.
struct ObjDirective {
  int32_t before_triangle = 0;  // the index of the first triangle after it
  std::string line;             // the whole line, keyword included
};

struct Mesh {
  std::vector<Vec3> positions;
  std::vector<Triangle> triangles;
  // Per-vertex colours: empty when the mesh has none, otherwise one per vertex (colors[i] is
  // the colour of positions[i]). Nothing in core changes them: a flow moves positions only.
  std::vector<Rgb> colors;
  CornerAttribute uvs;      // texture coordinates
  CornerAttribute normals;  // unit normals
  std::vector<VertexProperty> properties;
  std::vector<ObjDirective> obj_directives;

  // True when the mesh carries anything besides positions, triangles and colours.
  bool has_attributes() const {
    return !uvs.empty() || !normals.empty() || !properties.empty() || !obj_directives.empty();
  }

  int32_t num_vertices() const { return static_cast<int32_t>(positions.size()); }
  int32_t num_triangles() const { return static_cast<int32_t>(triangles.size()); }
};

// True when one of the face's indices is outside [0, num_vertices): a face no format can store
// and no step may read.
inline bool IndexOutOfRange(const Triangle& t, int32_t num_vertices) {
  for (int32_t i : t) {
    if (i < 0 || i >= num_vertices) return true;
  }
  return false;
}

// True when the face's indices are in [0, num_vertices) and pairwise distinct: the only faces
// the topology and OpenMesh may see (Debian's OpenMesh asserts on anything else).
inline bool IsUsableTriangle(const Triangle& t, int32_t num_vertices) {
  return !IndexOutOfRange(t, num_vertices) && t[0] != t[1] && t[1] != t[2] && t[0] != t[2];
}

}  // namespace meshsmooth
