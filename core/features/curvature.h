// Per-vertex normal, principal curvatures and principal directions, the input of ridge and
// ravine detection (the paper's Section 5; docs/paper.md, "Ridges and ravines", says why this
// estimator and not Taubin's 1995 one the paper names).
//
// The tensor follows Rusinkiewicz ("Estimating curvatures and their derivatives on triangle
// meshes", 3DPVT 2004): per face, the second fundamental form II that best maps each edge e_i
// to the change of the vertex normals along it, II e_i ~ (n_j - n_k) (his eq. (8): three edges,
// six equations, three unknowns, least squares); per vertex, the faces' II carried into the
// vertex's tangent plane by the minimal rotation (his Section 3.2) and averaged with each
// corner's mixed Voronoi area as weight (Section 3.3; Meyer et al. 2002). It needs no spread of
// edge directions, so every interior vertex with one usable face gets a tensor whatever its
// valence (valence 4 of criss-cross grids and 3-4 of marching cubes included), where a fit of the
// tensor to Taubin's directional curvatures needs three ring directions modulo pi. The vertex
// normals use Max's weights ("Weights for computing vertex normals from facet normals", 1999:
// the face cross products over |e1|^2 |e2|^2), exact for any triangulation of points on a sphere,
// which makes the whole estimate exact there (icosphere(5): 0.0000%, a random triangulation of
// the sphere too).
//
// Sign convention: a curvature is positive where the surface bends away from its normal, so a
// sphere with outward normals has kmax = kmin = +1/r. Units are 1/mesh units.
#pragma once

#include <cstdint>
#include <vector>

#include "core/mesh.h"
#include "core/topology.h"
#include "core/util/stop_token.h"

namespace meshsmooth {

// One entry per vertex. Where valid[v] is 0 every field of v is zero except possibly the
// normal; nothing is ever NaN or Inf.
struct CurvatureField {
  std::vector<Vec3> normal;        // unit, Max-weighted mean of the incident face normals (faces with
                                   // a coincident or non-finite corner left out); zero where
                                   // undefined (isolated, non-manifold, every face degenerate)
  std::vector<Vec3> dir_max;       // unit tangent direction of kmax (sign arbitrary)
  std::vector<Vec3> dir_min;       // unit tangent direction of kmin, = normal x dir_max
  std::vector<double> kmax, kmin;  // kmax >= kmin
  // 1 where the estimate exists: an interior vertex (closed one-ring) with a normal and at
  // least one incident face of non-zero area whose corners all have normals and whose edges
  // span a plane. 0 for boundary, non-manifold, isolated and degenerate vertices.
  std::vector<uint8_t> valid;
};

// The estimate at every vertex of `mesh` (`topology` = BuildTopology(mesh)). Two passes over the
// vertices (normals; then, at each interior vertex P with unit normal N and tangent basis (t1, t2)
// of the Householder reflection that maps N to the first axis, Rusinkiewicz's eq. (8) solved per
// incident face in (t1, t2) rotated into the face's plane, the results averaged with the mixed
// area of P's corner). Faces with a boundary corner count only when P has no other (a boundary
// vertex's normal comes from a one-sided fan). kmax >= kmin are the eigenvalues of the average
// and dir_max, dir_min its eigenvectors. O(n); deterministic, whatever the number of OpenMP
// threads. Once `stop` fires the vertices left stay invalid: a caller that passes a token checks
// it.
CurvatureField EstimateCurvature(const Mesh& mesh, const Topology& topology, const StopToken& stop = {});

}  // namespace meshsmooth
