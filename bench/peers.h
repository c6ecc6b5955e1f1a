// Other libraries' smoothers, run on our meshes: timed beside our flows per iteration
// (meshsmooth_bench), and run to their best iteration count for the time-to-quality table
// (meshsmooth_time_to_quality, through meshsmooth_peer). Each peer lives in its own file,
// compiled only when CMake finds the library (OpenMesh always: it is a dependency).
#pragma once

#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "core/mesh.h"
#include "core/vec3.h"

namespace meshsmooth::bench {

// What one run of a peer gives back.
struct PeerRun {
  double ms = 0.0;              // the smoothing call alone (conversions and set-up outside it excluded)
  std::vector<Vec3> positions;  // the result: vertex i of the input at index i
};

struct Peer {
  std::string id;       // the name meshsmooth_peer takes, e.g. "openmesh_c0"
  std::string library;  // "openmesh", "open3d" or "cgal": meshsmooth_peer_LIBRARY links it alone
  std::string name;     // e.g. "OpenMesh JacobiLaplace uniform C0"
  // The flow meshsmooth_bench's per-iteration table compares it with, e.g. "laplacian U0";
  // empty for a peer that table leaves out.
  std::string ours;
  // Runs `iterations` iterations on a copy of `mesh`; faces that are not usable
  // (IsUsableTriangle) or that the library refuses are left out, their vertices kept.
  std::function<PeerRun(const Mesh& mesh, int iterations)> run;
};

// The time step of CGAL's smooth_shape, in units of the squared mean edge length h^2 of the
// input (the mass matrix holds areas, the cotangent stiffness matrix is free of units). At
// 0.03 h^2 its least RMS distance on fandisk, the Stanford bunny and nefertiti with noise of
// 0.2 h came after 2-3 iterations; 0.01 h^2 reached the same within 3% after 5-8 (about three
// times the time), 0.1 h^2 overshot after one.
inline constexpr double kSmoothShapeTime = 0.03;

// Each list is empty in a program built without that library (peer_*_absent.cc).
std::vector<Peer> OpenMeshPeers();
std::vector<Peer> Open3dPeers();
// tangential_relaxation and smooth_shape at `smooth_shape_time` h^2.
std::vector<Peer> CgalPeers(double smooth_shape_time = kSmoothShapeTime);

// Every peer the program has, OpenMesh's first.
std::vector<Peer> AllPeers(double smooth_shape_time = kSmoothShapeTime);

// The peer called `id` in `peers`; nullptr when there is none.
const Peer* FindPeer(const std::vector<Peer>& peers, std::string_view id);

}  // namespace meshsmooth::bench
