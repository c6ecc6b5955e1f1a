// Folded faces: a usable face is folded when, across one of its edges, the edge's other face
// (an edge with exactly two usable faces) has a normal more than 90 degrees from its own: the
// two faces lie back to back, as noise or a run that pulls vertices against fixed ones folds
// thin triangles over. The default job with per-vertex strengths returns no more of them than
// its input had (core/job/repair.h, KeepNoMoreFolds).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "core/mesh.h"
#include "core/topology.h"

namespace meshsmooth {

// Each usable face's neighbours across its edges, found once for a mesh; then its folded faces
// at any positions of its vertices.
class FaceFolds {
 public:
  FaceFolds(const Mesh& mesh, const Topology& topo);
  // Per entry of topo.faces: 1 where the face is folded at positions `pos`.
  std::vector<uint8_t> Folded(const Vec3* pos) const;
  // The count of Folded(pos)'s ones.
  int64_t Count(const Vec3* pos) const;
  // The usable faces across face i's edges (topo.faces indices; -1 where an edge has not
  // exactly two usable faces).
  const std::array<int32_t, 3>& across(int32_t i) const { return across_[i]; }
  // The vertices of usable face i (topo.faces[i]).
  const Triangle& face(int32_t i) const { return mesh_.triangles[topo_.faces[i]]; }

 private:
  const Mesh& mesh_;
  const Topology& topo_;
  std::vector<std::array<int32_t, 3>> across_;
};

}  // namespace meshsmooth
