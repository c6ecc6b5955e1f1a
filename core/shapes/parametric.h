// Synthetic test shapes (the paper's Figs. 1, 4 and 7, a cosine sheet, a sphere with holes).
// Every generator is deterministic: same arguments, same bytes, on every machine.
#pragma once

#include <cstdint>

#include "core/mesh.h"

namespace meshsmooth {

// Unit icosphere: the icosahedron subdivided `level` times, vertices on the unit sphere,
// faces outward. 10*4^level + 2 vertices. Vertex order: the 12 icosahedron vertices, then each
// level's edge midpoints in order of first use (faces in order, edges ab, bc, ca of each), so
// another implementation built the same way numbers the vertices alike.
Mesh Icosphere(int level);

// Torus with two sampling rates (the paper's Fig. 4): half of it (the u in [0, pi) half
// around the major circle) is sampled twice as densely as the other half, in both directions,
// with near-equilateral triangles in each half and a strip of transition triangles at the two seams
// (no T-junction). `tube_segments` (even, >= 8) vertices go around the tube in the dense half,
// half as many in the coarse half. The dense half's vertices come first: their count is
// written to `*dense_vertices` when it is not null. Closed, genus 1, faces outward.
Mesh TwoRateTorus(int tube_segments = 32, double major_radius = 1.0, double minor_radius = 0.25,
                  int32_t* dense_vertices = nullptr);

// Unit square patch in the z = 0 plane on an nx x ny grid; the left half of the columns is
// sampled `ratio` times more densely than the right half (the paper's Fig. 7). Open: one
// boundary loop. Normals point to +z.
Mesh TwoRatePlane(int nx, int ny, double ratio = 3.0);

// Open cylinder around the z axis: `along` (>= 2) rings of `around` (>= 3) vertices at
// z = 0 .. height, every other ring turned by half a step, so the triangles are near
// equilateral when height / (along - 1) is about sqrt(3)/2 * 2 pi radius / around (use
// CylinderRings() for that count). Two boundary loops (the end rings); faces outward.
Mesh Cylinder(double radius, double height, int around, int along);

// The number of rings that makes Cylinder(radius, height, around, rings) near equilateral.
int CylinderRings(double radius, double height, int around);

// The cosine wave z = amplitude * cos(x) over x in [0, 2 pi periods]: rows of constant x,
// `rows_per_period` (>= 4) of them per period (so the crests x = 2 k pi and, for an even
// count, the troughs x = (2k+1) pi fall on rows), each with `columns` (>= 2) vertices along
// y, every other row shifted by half a step in y, the y step 2/sqrt(3) times the x step: near
// equilateral triangles in the xy plane. Vertex (row i, column j) has index i * columns + j.
// Open: one boundary loop. Normals point to +z.
Mesh CosineHeightField(double amplitude, int periods, int rows_per_period, int columns);

// A stepped shaft as a CAD exporter tessellates it: a cylinder of radius 0.5 (z in [0, 1])
// under one of radius 0.3 (z in [1, 2]), joined by a flat annulus at z = 1 and closed by flat
// caps; each ring carries `around` (>= 8) vertices. Each side and the annulus are one strip of
// quads cut into two triangles, each cap a fan from its centre: every face is a sliver or a
// needle that touches a crease (at around = 128, the sides' smallest angles are 0.8-1.4 degrees,
// the fans' 2.8). 4 * around + 2 vertices, 8 * around faces; closed, faces outward.
Mesh SliverShaft(int around);

// Icosphere(level) with `holes` round holes cut out, as a scan with many gaps: hole centres
// drawn uniformly on the sphere (seeded), apart by more than three times the largest radius,
// radii between 0.5 and 1.5 times `radius`, each hole the faces with a corner closer than its
// radius to its centre (distances are chords of the unit sphere); vertices no face uses are
// dropped. Manifold, each hole one boundary loop.
Mesh HoleySphere(int level, int holes, double radius, uint64_t seed);

}  // namespace meshsmooth
