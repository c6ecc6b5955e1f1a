// CGAL 5.5's Polygon_mesh_processing::tangential_relaxation on a Surface_mesh (double).
#include <CGAL/Polygon_mesh_processing/tangential_relaxation.h>
#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>

#include <chrono>

#include "bench/peers.h"

namespace meshsmooth::bench {

std::vector<Peer> CgalPeers() {
  return {{"CGAL tangential_relaxation (5.5)", "mcf_tangential", [](const Mesh& mesh, int it) {
             using Kernel = CGAL::Simple_cartesian<double>;
             using SurfaceMesh = CGAL::Surface_mesh<Kernel::Point_3>;
             SurfaceMesh sm;
             std::vector<SurfaceMesh::Vertex_index> vi;
             vi.reserve(mesh.positions.size());
             for (const Vec3& p : mesh.positions) vi.push_back(sm.add_vertex(Kernel::Point_3(p.x, p.y, p.z)));
             for (const Triangle& t : mesh.triangles) {
               if (IsUsableTriangle(t, mesh.num_vertices())) sm.add_face(vi[t[0]], vi[t[1]], vi[t[2]]);
             }
             const auto t0 = std::chrono::steady_clock::now();
             CGAL::Polygon_mesh_processing::tangential_relaxation(
                 sm, CGAL::parameters::number_of_iterations(static_cast<unsigned>(it)));
             return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
           }}};
}

}  // namespace meshsmooth::bench
