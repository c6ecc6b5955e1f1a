// How far noise turns a mesh's faces, and how far a run turned them: the face-normal measures the
// default job's discrepancy rule reads (core/job/rules.h). A face's normal turns under
// offsets of its vertices along the surface normal by about the offsets over its heights: the
// same offsets turn a sliver far more than a well-shaped face.
#pragma once

#include <cstdint>
#include <vector>

#include "core/mesh.h"
#include "core/topology.h"

namespace meshsmooth {

// The mean angle (radians) by which offsets of deviation `sigma` along the vertices' normals,
// independent from vertex to vertex, turn the usable faces of `mesh` (every k-th face of a mesh
// of more than 20,000): measured on `draws` draws of such offsets (a fixed pseudo-random
// sequence: the same on every machine and thread count).
double PredictedNormalNoise(const Mesh& mesh, const Topology& topo, double sigma, int draws = 2);

// How far a run has turned the faces of its input: the mean angle (radians) between each usable
// face's normal in the input and in `pos` (every k-th face of a mesh of more than 20,000).
class NormalTurn {
 public:
  NormalTurn(const Mesh& input, const Topology& topo) : NormalTurn(input.positions.data(), input.triangles, topo) {}
  // The same for the input positions `input` of `triangles`' vertices.
  NormalTurn(const Vec3* input, const std::vector<Triangle>& triangles, const Topology& topo);
  double Of(const Vec3* pos) const;

 private:
  const std::vector<Triangle>& triangles_;
  std::vector<int32_t> faces_;  // the measured faces
  std::vector<Vec3> normal_;    // their unit normals in the input
};

// The total variation of the face normals: the sum over the interior edges of the edge's length
// times the difference of its two faces' unit normals. Noise raises it; a crease costs its length
// times its angle's gap, whether sharp or rounded.
double NormalVariation(const Vec3* pos, const Topology& topo);

}  // namespace meshsmooth
