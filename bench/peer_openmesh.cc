// OpenMesh 9's JacobiLaplaceSmootherT on a double-precision mesh: uniform weights with
// Tangential_and_Normal, C0 (one umbrella step of 0.5) and C1 (a step along the umbrella of
// the umbrellas, OpenMesh's bi-Laplacian); cotangent weights (computed once, in initialize)
// with Normal, C0. Boundary vertices stay fixed (OpenMesh's active set).
#include <OpenMesh/Tools/Smoother/JacobiLaplaceSmootherT.hh>
#include <chrono>

#include "bench/openmesh_mesh.h"
#include "bench/peers.h"

namespace meshsmooth::bench {
namespace {

using Smoother = OpenMesh::Smoother::JacobiLaplaceSmootherT<OMesh>;

PeerRun Run(const Mesh& mesh, int iterations, Smoother::Component component, Smoother::Continuity continuity) {
  std::vector<OMesh::VertexHandle> vh;
  OMesh om = ToOpenMesh(mesh, &vh);
  om.request_vertex_normals();
  om.request_face_normals();
  om.update_normals();
  Smoother smoother(om);
  smoother.initialize(component, continuity);
  PeerRun run;
  const auto t0 = std::chrono::steady_clock::now();
  smoother.smooth(static_cast<unsigned>(iterations));
  run.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  run.positions.reserve(vh.size());
  for (const OMesh::VertexHandle v : vh) {
    const OMesh::Point& p = om.point(v);
    run.positions.push_back({p[0], p[1], p[2]});
  }
  return run;
}

}  // namespace

std::vector<Peer> OpenMeshPeers() {
  return {
      {"openmesh_c0", "openmesh", "OpenMesh JacobiLaplace uniform C0", "laplacian U0",
       [](const Mesh& m, int it) { return Run(m, it, Smoother::Tangential_and_Normal, Smoother::C0); }},
      {"openmesh_c1", "openmesh", "OpenMesh JacobiLaplace uniform C1", "",
       [](const Mesh& m, int it) { return Run(m, it, Smoother::Tangential_and_Normal, Smoother::C1); }},
      {"openmesh_cotangent", "openmesh", "OpenMesh JacobiLaplace cotangent Normal C0", "mcf",
       [](const Mesh& m, int it) { return Run(m, it, Smoother::Normal, Smoother::C0); }},
  };
}

}  // namespace meshsmooth::bench
