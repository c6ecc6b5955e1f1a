// Other libraries' smoothers, timed on our meshes for the side-by-side table. Each peer lives in
// its own file, compiled only when CMake finds the library (OpenMesh always: it is a dependency).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "core/mesh.h"

namespace meshsmooth::bench {

struct Peer {
  std::string name;  // e.g. "OpenMesh JacobiLaplace uniform C0"
  std::string ours;  // the flow it is compared with, e.g. "laplacian U0"
  // Runs `iterations` iterations on a copy of `mesh` (set-up excluded when the library allows)
  // and returns the milliseconds spent smoothing.
  std::function<double(const Mesh& mesh, int iterations)> run;
};

std::vector<Peer> OpenMeshPeers();
std::vector<Peer> Open3dPeers();  // empty when Open3D was not found
std::vector<Peer> CgalPeers();    // empty when CGAL was not found

}  // namespace meshsmooth::bench
