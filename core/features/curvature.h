// Per-vertex normal, principal curvatures and principal directions after Taubin
// ("Estimating the tensor of curvature of a surface from a polyhedral approximation", ICCV
// 1995), the estimator the paper uses before ridge and ravine detection (Section 5; see
// docs/paper.md, "Ridges and ravines").
//
// It uses Taubin's directional curvatures kappa_j and weights w_j, but fits the tangent-plane
// tensor to them by weighted least squares instead of Taubin's trace relation
// (kappa1 = 3 m11 - m22): that relation assumes the edge directions are spread uniformly around
// the vertex and is off by up to 25% on an icosphere (measured: 25.1% on icosphere(5), whose
// hexagon edges sit at 0, +-54, +-126 degrees), while the fit is exact on any sphere (with a
// radial normal every kappa_j is 1/r, and B = I / r fits them with zero residual; what error
// remains comes from the area-weighted normal, measured 2.25% on icosphere(5)).
//
// Sign convention: a curvature is positive where the surface bends away from its normal, so a
// sphere with outward normals has kmax = kmin = +1/r (Taubin's own kappa_ij has the opposite
// sign). Units are 1/mesh units.
#pragma once

#include <cstdint>
#include <vector>

#include "core/mesh.h"
#include "core/stop_token.h"
#include "core/topology.h"

namespace meshsmooth {

// One entry per vertex. Where valid[v] is 0 every field of v is zero except possibly the
// normal; nothing is ever NaN or Inf.
struct CurvatureField {
  std::vector<Vec3> normal;   // unit, area-weighted mean of the incident face normals; zero
                              // where undefined (isolated, non-manifold, all faces degenerate)
  std::vector<Vec3> dir_max;  // unit tangent direction of kmax (sign arbitrary)
  std::vector<Vec3> dir_min;  // unit tangent direction of kmin, = normal x dir_max
  std::vector<double> kmax, kmin;  // kmax >= kmin
  // 1 where the estimate exists: an interior vertex (closed one-ring) with finite
  // coordinates, a non-degenerate normal and at least three neighbours at a non-zero distance
  // off the normal line, in at least three distinct tangent directions (modulo pi, so that the
  // fit below is determined). 0 for boundary, non-manifold, isolated and degenerate vertices.
  std::vector<uint8_t> valid;
};

// The estimate at every vertex of `mesh` (`topology` = BuildTopology(mesh)). For an interior
// vertex P with ring Q_j and unit normal N (area-weighted mean of the face normals):
// kappa_j = -2 N.(Q_j - P) / |Q_j - P|^2, T_j = the unit projection of Q_j - P on the tangent
// plane, w_j proportional to the area of the two faces at edge P Q_j (sum 1), all as in Taubin.
// In the tangent basis (t1, t2) of the Householder reflection that maps N to the first axis,
// the symmetric 2x2 tensor B minimises sum_j w_j (T_j^T B T_j - kappa_j)^2 (3x3 normal
// equations, solved in closed form; a near-singular system leaves the vertex invalid). kmax >=
// kmin are B's eigenvalues and dir_max, dir_min its eigenvectors. Neighbours coincident with P
// or on its normal line are skipped. Deterministic, whatever the number of OpenMP threads.
// Once `stop` fires the vertices left stay invalid: a caller that passes a token checks it.
CurvatureField EstimateCurvature(const Mesh& mesh, const Topology& topology, const StopToken& stop = {});

}  // namespace meshsmooth
