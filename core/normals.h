// Per-vertex normals of a Mesh.
#pragma once

#include <span>
#include <vector>

#include "core/mesh.h"
#include "core/topology.h"
#include "core/vec3.h"

namespace meshsmooth {

// Area-weighted vertex normals: for each vertex, the sum of the cross products (twice the
// area times the unit normal) of the usable faces around it (IsUsableTriangle), normalised.
// Oriented by the faces' winding (counter-clockwise = outward); the zero vector for a vertex
// that no usable face touches or whose faces cancel out.
std::vector<Vec3> VertexNormals(const Mesh& mesh);

// The same over positions other than the mesh's own (e.g. a moved or rescaled copy), one per
// vertex.
std::vector<Vec3> VertexNormals(std::span<const Vec3> positions, std::span<const Triangle> triangles);

// Twice the area-weighted normal of interior vertex `v` from its cyclic ring (the sum of the
// cross products of its faces, not normalised): the same direction VertexNormals() gives it
// when its faces are all usable, computed from the ring alone so that a parallel loop over
// vertices needs no scatter. A boundary vertex's from its open fan; zero for any other.
inline Vec3 RingNormal(const Topology& topo, const Vec3* positions, int32_t v) {
  const bool closed = topo.kind[v] == VertexKind::kInterior;
  if (!closed && topo.kind[v] != VertexKind::kBoundary) return {};
  const int32_t begin = topo.ring_offsets[v], end = topo.ring_offsets[v + 1];
  const Vec3 p = positions[v];
  Vec3 sum;
  // A boundary vertex's fan is open: from its first ring entry to its last, no closing face.
  Vec3 prev = positions[topo.ring[closed ? end - 1 : begin]] - p;
  for (int32_t k = closed ? begin : begin + 1; k < end; ++k) {
    const Vec3 cur = positions[topo.ring[k]] - p;
    sum += Cross(prev, cur);
    prev = cur;
  }
  return sum;
}

}  // namespace meshsmooth
