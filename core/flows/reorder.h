// Running a large mesh in an order that keeps each vertex's neighbours near it in memory:
// Smooth() renumbers the mesh and its topology into Morton order in place when that pays off
// (FlowParams::reorder), runs there and renumbers them back, so indices stay stable.
// Each ring keeps its order and the faces keep theirs, so every vertex sums the same terms in
// the same order: reordering changes no position.
#pragma once

#include <cstdint>
#include <vector>

#include "core/mesh.h"
#include "core/topology.h"

namespace meshsmooth {

// The order Smooth() runs meshes of 100k vertices or more in (FlowParams::reorder): vertices
// in Morton (Z-)order of their positions, so that a vertex's neighbours sit close to it in
// memory. new -> old; the identity above 2^25 vertices. The keys are computed on `threads`.
std::vector<int32_t> MortonOrder(const std::vector<Vec3>& positions, int threads = 1);

// ReorderMode::kAuto's choice: a mesh of 100k .. 2^25 vertices whose order leaves more than 3%
// of its neighbours over 4096 indices away from their vertex (a Morton order leaves about 2%),
// for a run of at least 2.5 / (that share) iterations: reordering costs about as much as a few
// iterations in a scattered order lose (docs/decisions.md, "Speed"). The share is counted on the
// rings of one vertex in 32 (runs of 64 in every 2048).
bool MortonOrderPaysOff(const Topology& topo, int iterations);

// Sizes Smooth() may reorder (FlowParams::reorder = kAlways): 100k .. 2^25 vertices.
bool ReorderableSize(int32_t n);

// Renumbers `mesh` (its positions, and its faces' corners: the faces keep their order) and `topo`
// (kinds and rings; its list of usable faces names faces, so it stays as it is) in place into
// `order` (new -> old), on `threads`. Each array is made anew and the old one freed before the
// next, so nothing is held twice but one array at a time (at most the rings, 24 bytes a vertex):
// a run in that order needs no copy of the mesh or topology beside the caller's. A corner out of
// range stays as it was (such a face is not in topo.faces).
void Renumber(const std::vector<int32_t>& order, Mesh& mesh, Topology& topo, int threads);

// Undoes Renumber(order, mesh, topo, ...): the positions back in the caller's order and the
// faces and topology exactly as they were.
void RenumberBack(const std::vector<int32_t>& order, Mesh& mesh, Topology& topo, int threads);

// values[order[i]] at i: a per-vertex array (lock mask, strengths, centres) in `order`.
template <typename T>
std::vector<T> InOrder(const std::vector<int32_t>& order, const std::vector<T>& values) {
  if (values.empty()) return {};
  std::vector<T> out(order.size());
  for (size_t i = 0; i < order.size(); ++i) out[i] = values[order[i]];
  return out;
}

}  // namespace meshsmooth
