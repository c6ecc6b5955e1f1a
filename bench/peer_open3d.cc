// Open3D 0.16's TriangleMesh::FilterSmoothLaplacian (inverse-distance weights, as our U1) and
// FilterSmoothTaubin (the same weights, lambda 0.5, mu -0.53). Both build their adjacency list
// inside the call, as a user of that API pays it; both are single-threaded.
#include <open3d/geometry/TriangleMesh.h>

#include <chrono>

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

template <typename Fn>
double Time(Fn&& fn) {
  const auto t0 = std::chrono::steady_clock::now();
  fn();
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

std::vector<Peer> Open3dPeers() {
  return {
      {"Open3D FilterSmoothLaplacian (0.16)", "laplacian U1",
       [](const Mesh& mesh, int it) {
         const auto m = ToOpen3d(mesh);
         return Time([&] { m.FilterSmoothLaplacian(it, 0.5); });
       }},
      {"Open3D FilterSmoothTaubin (0.16)", "taubin U1",
       [](const Mesh& mesh, int it) {
         const auto m = ToOpen3d(mesh);
         return Time([&] { m.FilterSmoothTaubin(it, 0.5, -0.53); });
       }},
  };
}

}  // namespace meshsmooth::bench
