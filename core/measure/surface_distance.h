// Exact distances from points to a triangle mesh's surface (the union of its triangles, not its
// vertices), for measuring a smoothed mesh against the clean one (core/measure/evaluation.h): a vertex
// that slid along the surface is at distance 0, however far it is from its old position.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "core/mesh.h"
#include "core/vec3.h"

namespace meshsmooth {

// The point of triangle abc nearest to p, by the Voronoi regions of its corners, edges and
// interior (Ericson, "Real-Time Collision Detection", 5.1.5). A degenerate triangle (corners
// collinear or coincident) gives the nearest point of its three edges.
Vec3 ClosestPointOnTriangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c);

// The usable triangles of a mesh (IsUsableTriangle, finite corners) in a bounding-volume
// hierarchy: axis-aligned boxes split at the median centroid of their longest axis, at most
// four triangles a leaf. The mesh need not outlive it. A query visits the nearer child first
// and skips every box farther than the best distance so far.
class SurfaceDistance {
 public:
  explicit SurfaceDistance(const Mesh& mesh);

  // The squared distance from p to the nearest triangle, or `bound2` when no triangle is
  // nearer: pass the squared distance to a point known to be on the surface (a vertex of the
  // mesh, say) and the search only opens boxes nearer than it. +inf (the default bound) when
  // the mesh has no triangles; NaN for a point that is not finite.
  double SquaredDistance(const Vec3& p, double bound2 = HUGE_VAL) const;

  // The nearest triangle to p: its index in the mesh's `triangles` (-1 when the mesh has none or
  // p is not finite) and, in `squared_distance` when given, the squared distance to it. For a
  // mesh measured against a surface with other connectivity: the surface's normal at the point
  // nearest to a vertex is its nearest triangle's.
  int32_t NearestTriangle(const Vec3& p, double* squared_distance = nullptr) const;

  int64_t num_triangles() const { return static_cast<int64_t>(corners_.size()); }

 private:
  struct Node {
    BoundingBox box;
    int32_t first = 0;  // leaf: first triangle in corners_; inner node: index of the left child
    int32_t count = 0;  // leaf: its triangles (> 0); inner node: 0, the right child is first + 1
  };

  std::vector<Node> nodes_;  // nodes_[0] is the root
  // Visits the leaves that may hold a triangle nearer than `best`, nearer boxes first;
  // visit(i) tests corners_[i] and lowers `best`.
  template <typename Visit>
  void Search(const Vec3& p, double& best, Visit&& visit) const;

  std::vector<std::array<Vec3, 3>> corners_;  // the triangles in leaf order
  std::vector<int32_t> ids_;                  // per corners_ entry: its index in the mesh's triangles
};

}  // namespace meshsmooth
