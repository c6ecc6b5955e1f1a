// A coarse copy of a mesh, for the quality benchmark's detailed clean scans: a dense scan
// decimated to a few thousand vertices keeps its fine detail (a dragon's scales, a statue's
// curls) at the scale of one or two edges, where a noise estimate can read it as noise.
#pragma once

#include <cstdint>

#include "core/mesh.h"

namespace meshsmooth::bench {

// `mesh` decimated to about `vertices` vertices by OpenMesh's quadric decimater (Garland and
// Heckbert's error quadrics, with OpenMesh's guard against collapses that flip a face):
// halfedge collapses, so every vertex left keeps its input position. Faces OpenMesh cannot
// take (non-manifold ones) are left out. Deterministic: the same mesh and count give the same
// bytes.
Mesh Decimate(const Mesh& mesh, int32_t vertices);

}  // namespace meshsmooth::bench
