// Per-vertex normal, principal curvatures and principal directions by Taubin's method
// ("Estimating the tensor of curvature of a surface from a polyhedral approximation", ICCV
// 1995), the estimator the paper uses before ridge and ravine detection (Section 5 of
// ../shared/paper/polyhedral-surface-smoothing.md).
//
// Sign convention: a curvature is positive where the surface bends away from its normal, so a
// sphere with outward normals has kmax = kmin = +1/r (Taubin's own kappa_ij has the opposite
// sign). Units are 1/mesh units.
#pragma once

#include <cstdint>
#include <vector>

#include "core/mesh.h"
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
  // off the normal line. 0 for boundary, non-manifold, isolated and degenerate vertices.
  std::vector<uint8_t> valid;
};

// Taubin's estimate at every vertex of `mesh` (`topology` = BuildTopology(mesh)). For an
// interior vertex P with ring Q_j and unit normal N: kappa_j = -2 N.(Q_j - P) / |Q_j - P|^2,
// T_j = the unit projection of Q_j - P on the tangent plane, M = sum_j w_j kappa_j T_j T_j^T
// with w_j proportional to the area of the two faces at edge P Q_j (sum 1); a Householder
// reflection maps N to the first axis, leaving the 2x2 tangent block (m11 m12; m12 m22), whose
// eigenvalues a >= b give kmax = 3a - b, kmin = 3b - a. Neighbours coincident with P or on its
// normal line are skipped. Deterministic, whatever the number of OpenMP threads.
CurvatureField EstimateCurvature(const Mesh& mesh, const Topology& topology);

}  // namespace meshsmooth
