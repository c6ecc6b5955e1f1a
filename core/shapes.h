// Synthetic test shapes (the paper's Figs. 1, 4 and 7) and seeded noise.
// Every generator is deterministic: same arguments, same bytes, on every machine.
#pragma once

#include <cstdint>

#include "core/mesh.h"

namespace meshsmooth {

// Unit icosphere: the icosahedron subdivided `level` times, vertices on the unit sphere,
// faces outward. 10*4^level + 2 vertices. Same vertex order as ../shared/reference/paper_flows.py.
Mesh Icosphere(int level);

// Torus with major radius R and tube radius r on a regular nu x nv grid (nu around the major
// circle, nv around the tube; both even, >= 4). Half of the nu columns cover an arc `ratio`
// times shorter than the other half, so the mesh has two sampling rates (the paper's Fig. 4).
// ratio = 1 gives a uniform torus. Closed, genus 1, faces outward.
Mesh TwoRateTorus(int nu, int nv, double major_radius = 1.0, double minor_radius = 0.4,
                  double ratio = 3.0);

// Unit square patch in the z = 0 plane on an nx x ny grid; the left half of the columns is
// sampled `ratio` times more densely than the right half (the paper's Fig. 7). Open: one
// boundary loop. Normals point to +z.
Mesh TwoRatePlane(int nx, int ny, double ratio = 3.0);

// Adds to every coordinate of every vertex an independent uniform value in
// [-fraction * h, fraction * h], with h the mesh's mean edge length (the paper's "uniform
// noise"). Seeded: the same seed gives the same noise.
void AddUniformNoise(Mesh& mesh, double fraction_of_mean_edge, uint64_t seed);

}  // namespace meshsmooth
