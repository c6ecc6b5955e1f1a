#include "bench/decimate.h"

#include <OpenMesh/Tools/Decimater/DecimaterT.hh>
#include <OpenMesh/Tools/Decimater/ModNormalFlippingT.hh>
#include <OpenMesh/Tools/Decimater/ModQuadricT.hh>

#include "bench/openmesh_mesh.h"

namespace meshsmooth::bench {

Mesh Decimate(const Mesh& mesh, int32_t vertices) {
  OMesh om = ToOpenMesh(mesh);
  // The normal-flipping module reads face normals.
  om.request_face_normals();
  om.update_face_normals();
  OpenMesh::Decimater::DecimaterT<OMesh> decimater(om);
  OpenMesh::Decimater::ModQuadricT<OMesh>::Handle quadric;
  OpenMesh::Decimater::ModNormalFlippingT<OMesh>::Handle flipping;
  decimater.add(quadric);
  decimater.add(flipping);
  decimater.initialize();
  decimater.decimate_to(static_cast<size_t>(vertices));
  om.garbage_collection();
  Mesh out;
  out.positions.reserve(om.n_vertices());
  for (const OMesh::VertexHandle v : om.vertices()) {
    const OMesh::Point& p = om.point(v);
    out.positions.push_back({p[0], p[1], p[2]});
  }
  out.triangles.reserve(om.n_faces());
  for (const OMesh::FaceHandle f : om.faces()) {
    Triangle t{};
    int k = 0;
    for (const OMesh::VertexHandle v : om.fv_range(f)) t[k++] = v.idx();
    out.triangles.push_back(t);
  }
  return out;
}

}  // namespace meshsmooth::bench
