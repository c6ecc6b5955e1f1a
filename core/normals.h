// Per-vertex normals of a Mesh.
#pragma once

#include <span>
#include <vector>

#include "core/mesh.h"
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

}  // namespace meshsmooth
