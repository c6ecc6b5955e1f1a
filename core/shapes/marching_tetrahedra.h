// An iso-surface extractor, for inputs shaped as scanners' and simulations' extraction leaves
// them. Deterministic: same arguments, same bytes, on every machine.
#pragma once

#include <functional>

#include "core/mesh.h"

namespace meshsmooth {

// Marching tetrahedra, as iso-surface extraction leaves a mesh (valence 3 to 12+, slivers,
// needles, vertices a linear interpolation off the surface): the zero set of `f` (negative
// inside) on the grid lo + step (i, j, k) that covers the box [lo, hi], each cube cut into the
// six tetrahedra around its main diagonal, one vertex per crossed grid edge (shared between
// tetrahedra; a node where f is 0 counts as outside), one or two triangles per crossed
// tetrahedron, faces outward. Closed where the surface stays inside the box.
Mesh MarchingTetrahedra(const std::function<double(const Vec3&)>& f, const Vec3& lo, const Vec3& hi, double step);

}  // namespace meshsmooth
