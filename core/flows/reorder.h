// Running a large mesh in an order that keeps each vertex's neighbours near it in memory:
// Smooth() copies the mesh and its topology into Morton order when that pays off
// (FlowParams::reorder), runs there and copies the positions back, so indices stay stable.
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

// A mesh, its topology and its lock mask copied into an order (new -> old).
struct ReorderedMesh {
  std::vector<int32_t> order;   // new -> old
  Mesh mesh;                    // positions and triangles, renumbered
  Topology topo;                // kind, rings and usable faces, renumbered
  std::vector<uint8_t> locked;  // empty when the caller's was
};

// The copy of (mesh, topo, locked) in Morton order, made on `threads`.
ReorderedMesh ReorderByMorton(const Mesh& mesh, const Topology& topo, const std::vector<uint8_t>& locked, int threads);

// Writes r's positions back to `mesh` in the caller's order.
void RestoreOrder(const ReorderedMesh& r, Mesh& mesh, int threads);

// Makes `mesh`'s faces anew from r's, in the caller's numbering: the same faces as those r was
// made from (each corner renumbered back; a corner out of range was kept as it was), so a caller
// may free its own while it runs on r.
void RestoreFaces(const ReorderedMesh& r, Mesh& mesh, int threads);

}  // namespace meshsmooth
