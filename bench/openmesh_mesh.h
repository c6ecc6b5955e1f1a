// Our mesh in OpenMesh's double-precision triangle mesh, for the bench code that hands meshes to
// OpenMesh (its smoother as a peer, peer_openmesh.cc; its decimater, decimate.cc).
#pragma once

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <utility>
#include <vector>

#include "core/mesh.h"

namespace meshsmooth::bench {

struct OpenMeshDoubleTraits : OpenMesh::DefaultTraits {
  typedef OpenMesh::Vec3d Point;
  typedef OpenMesh::Vec3d Normal;
};
using OMesh = OpenMesh::TriMesh_ArrayKernelT<OpenMeshDoubleTraits>;

// `mesh` as an OpenMesh mesh: every vertex, in order (their handles into `handles` when it is
// not null), and every usable triangle OpenMesh takes (it refuses non-manifold ones).
inline OMesh ToOpenMesh(const Mesh& mesh, std::vector<OMesh::VertexHandle>* handles = nullptr) {
  OMesh om;
  std::vector<OMesh::VertexHandle> vh;
  vh.reserve(mesh.positions.size());
  for (const Vec3& p : mesh.positions) vh.push_back(om.add_vertex({p.x, p.y, p.z}));
  for (const Triangle& t : mesh.triangles) {
    if (IsUsableTriangle(t, mesh.num_vertices())) om.add_face(vh[t[0]], vh[t[1]], vh[t[2]]);
  }
  if (handles != nullptr) *handles = std::move(vh);
  return om;
}

}  // namespace meshsmooth::bench
