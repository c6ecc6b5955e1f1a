// OpenMesh 9's JacobiLaplaceSmootherT: uniform weights with Tangential_and_Normal, cotangent
// weights (computed once, in initialize) with Normal; both C0, on a double-precision mesh.
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Tools/Smoother/JacobiLaplaceSmootherT.hh>
#include <chrono>

#include "bench/peers.h"

namespace meshsmooth::bench {
namespace {

struct DoubleTraits : OpenMesh::DefaultTraits {
  typedef OpenMesh::Vec3d Point;
  typedef OpenMesh::Vec3d Normal;
};
using OMesh = OpenMesh::TriMesh_ArrayKernelT<DoubleTraits>;
using Smoother = OpenMesh::Smoother::JacobiLaplaceSmootherT<OMesh>;

double Run(const Mesh& mesh, int iterations, Smoother::Component component) {
  OMesh om;
  std::vector<OMesh::VertexHandle> vh;
  vh.reserve(mesh.positions.size());
  for (const Vec3& p : mesh.positions) vh.push_back(om.add_vertex({p.x, p.y, p.z}));
  for (const Triangle& t : mesh.triangles) {
    if (IsUsableTriangle(t, mesh.num_vertices())) om.add_face(vh[t[0]], vh[t[1]], vh[t[2]]);
  }
  om.request_vertex_normals();
  om.request_face_normals();
  om.update_normals();
  Smoother smoother(om);
  smoother.initialize(component, Smoother::C0);
  const auto t0 = std::chrono::steady_clock::now();
  smoother.smooth(static_cast<unsigned>(iterations));
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

std::vector<Peer> OpenMeshPeers() {
  return {
      {"OpenMesh JacobiLaplace uniform C0", "laplacian U0",
       [](const Mesh& m, int it) { return Run(m, it, Smoother::Tangential_and_Normal); }},
      {"OpenMesh JacobiLaplace cotangent Normal C0", "mcf",
       [](const Mesh& m, int it) { return Run(m, it, Smoother::Normal); }},
  };
}

}  // namespace meshsmooth::bench
