// Open3D 0.16's TriangleMesh::FilterSmoothLaplacian (inverse-distance weights, as our U1) and
// FilterSmoothTaubin (the same weights, lambda 0.5, mu -0.53). Both build their adjacency list
// inside the call, as a user of that API pays it; both are single-threaded.
#include <open3d/geometry/TriangleMesh.h>

#include <chrono>
#include <memory>

#include "bench/peers.h"

namespace meshsmooth::bench {
namespace {

open3d::geometry::TriangleMesh ToOpen3d(const Mesh& mesh) {
  open3d::geometry::TriangleMesh m;
  m.vertices_.reserve(mesh.positions.size());
  for (const Vec3& p : mesh.positions) m.vertices_.emplace_back(p.x, p.y, p.z);
  for (const Triangle& t : mesh.triangles) {
    if (IsUsableTriangle(t, mesh.num_vertices())) m.triangles_.emplace_back(t[0], t[1], t[2]);
  }
  return m;
}

// Times `filter` (a call returning the smoothed copy) and takes its vertices.
template <typename Filter>
PeerRun Run(Filter&& filter) {
  PeerRun run;
  const auto t0 = std::chrono::steady_clock::now();
  const std::shared_ptr<open3d::geometry::TriangleMesh> out = filter();
  run.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  run.positions.reserve(out->vertices_.size());
  for (const Eigen::Vector3d& p : out->vertices_) run.positions.push_back({p.x(), p.y(), p.z()});
  return run;
}

}  // namespace

std::vector<Peer> Open3dPeers() {
  return {
      {"open3d_laplacian", "open3d", "Open3D FilterSmoothLaplacian (0.16)", "laplacian U1",
       [](const Mesh& mesh, int it) {
         const auto m = ToOpen3d(mesh);
         return Run([&] { return m.FilterSmoothLaplacian(it, 0.5); });
       }},
      {"open3d_taubin", "open3d", "Open3D FilterSmoothTaubin (0.16)", "taubin U1",
       [](const Mesh& mesh, int it) {
         const auto m = ToOpen3d(mesh);
         return Run([&] { return m.FilterSmoothTaubin(it, 0.5, -0.53); });
       }},
  };
}

}  // namespace meshsmooth::bench
