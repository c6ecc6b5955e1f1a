// CGAL 5.5's Polygon_mesh_processing on a Surface_mesh (double): tangential_relaxation, and
// smooth_shape, the implicit mean-curvature flow ((M - t L) x' = M x per iteration: L the
// cotangent stiffness matrix, computed once per call, M the lumped mass matrix, updated every
// iteration; then the volume scaled back about the centroid), solved by Eigen's BiCGSTAB with
// an incomplete LU preconditioner, CGAL's default.
#include <CGAL/Polygon_mesh_processing/smooth_shape.h>
#include <CGAL/Polygon_mesh_processing/tangential_relaxation.h>
#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>

#include <chrono>
#include <cmath>

#include "absl/strings/str_format.h"
#include "bench/peers.h"

namespace meshsmooth::bench {
namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using SurfaceMesh = CGAL::Surface_mesh<Kernel::Point_3>;
namespace PMP = CGAL::Polygon_mesh_processing;

// `mesh` as a Surface_mesh of the vertices its usable faces use: smooth_shape's linear system
// is singular with a vertex no face holds (its row stays empty and the solve fails, leaving the
// mesh as it was), so those vertices stay out, as CGAL's remove_isolated_vertices would leave
// them. Faces CGAL refuses (non-manifold) are left out as well.
struct Converted {
  SurfaceMesh sm;
  std::vector<int32_t> source;  // per Surface_mesh vertex, its index in `mesh`
};

Converted ToSurfaceMesh(const Mesh& mesh) {
  Converted c;
  const int32_t n = mesh.num_vertices();
  std::vector<SurfaceMesh::Vertex_index> vi(static_cast<size_t>(n), SurfaceMesh::null_vertex());
  auto vertex = [&](int32_t v) {
    if (vi[v] == SurfaceMesh::null_vertex()) {
      const Vec3& p = mesh.positions[v];
      vi[v] = c.sm.add_vertex(Kernel::Point_3(p.x, p.y, p.z));
      c.source.push_back(v);
    }
    return vi[v];
  };
  for (const Triangle& t : mesh.triangles) {
    if (IsUsableTriangle(t, n)) c.sm.add_face(vertex(t[0]), vertex(t[1]), vertex(t[2]));
  }
  return c;
}

// Times `smooth` on `c.sm` and takes its points, the vertices it left out as they were.
template <typename Smooth>
PeerRun Run(const Mesh& mesh, Converted& c, Smooth&& smooth) {
  PeerRun run;
  const auto t0 = std::chrono::steady_clock::now();
  smooth();
  run.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  run.positions = mesh.positions;
  for (const SurfaceMesh::Vertex_index v : c.sm.vertices()) {
    const Kernel::Point_3& p = c.sm.point(v);
    run.positions[c.source[static_cast<size_t>(v)]] = {p.x(), p.y(), p.z()};
  }
  return run;
}

// The mean length of the Surface_mesh's edges.
double MeanEdgeLength(const SurfaceMesh& sm) {
  double sum = 0.0;
  for (const SurfaceMesh::Edge_index e : sm.edges()) {
    sum += std::sqrt(CGAL::squared_distance(sm.point(sm.vertex(e, 0)), sm.point(sm.vertex(e, 1))));
  }
  return sm.number_of_edges() > 0 ? sum / static_cast<double>(sm.number_of_edges()) : 0.0;
}

}  // namespace

std::vector<Peer> CgalPeers(double smooth_shape_time) {
  return {
      {"cgal_tangential_relaxation", "cgal", "CGAL tangential_relaxation (5.5)", "mcf_tangential",
       [](const Mesh& mesh, int it) {
         Converted c = ToSurfaceMesh(mesh);
         return Run(mesh, c, [&] {
           PMP::tangential_relaxation(c.sm, CGAL::parameters::number_of_iterations(static_cast<unsigned>(it)));
         });
       }},
      {"cgal_smooth_shape", "cgal", absl::StrFormat("CGAL smooth_shape, time %g h^2 (5.5)", smooth_shape_time), "",
       [smooth_shape_time](const Mesh& mesh, int it) {
         Converted c = ToSurfaceMesh(mesh);
         const double h = MeanEdgeLength(c.sm);
         return Run(mesh, c, [&] {
           PMP::smooth_shape(c.sm, smooth_shape_time * h * h,
                             CGAL::parameters::number_of_iterations(static_cast<unsigned>(it)));
         });
       }},
  };
}

}  // namespace meshsmooth::bench
