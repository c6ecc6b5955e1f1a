// Flat topology for the hot loops, and the validation report of any input.
//
// BuildTopology() turns vertex/face arrays into a CSR one-ring: for vertex v its neighbours are
// ring[ring_offsets[v] .. ring_offsets[v+1]). The ring of an interior vertex is in cyclic order
// (v, ring[k], ring[k+1 mod n]) is a face for every k); the ring of a boundary vertex is the
// open fan from one boundary neighbour to the other ((v, ring[k], ring[k+1]) is a face for
// k < n-1, and ring.front(), ring.back() are its neighbours along the boundary loop). Vertices
// that are not manifold (several fans, or an edge with more than two faces) keep their unique
// neighbours in increasing order and are flagged: the flows keep them fixed.
//
// Faces with an out-of-range or repeated index are left out of the topology and counted; the
// input is never changed and nothing here asserts or crashes, whatever the arrays hold.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/mesh.h"
#include "core/util/stop_token.h"

namespace meshsmooth {

enum class VertexKind : uint8_t {
  kIsolated = 0,     // no usable face references it
  kInterior = 1,     // one closed fan, every edge has two faces
  kBoundary = 2,     // one open fan, two boundary edges
  kNonManifold = 3,  // several fans, or an edge with more than two faces
};

struct Topology {
  std::vector<int32_t> ring_offsets;  // num_vertices + 1 entries
  std::vector<int32_t> ring;          // neighbours, see the header comment for the order
  std::vector<VertexKind> kind;       // one per vertex
  std::vector<int32_t> faces;         // indices into Mesh::triangles of the usable faces

  int32_t num_vertices() const { return static_cast<int32_t>(kind.size()); }
  int32_t valence(int32_t v) const { return ring_offsets[v + 1] - ring_offsets[v]; }
};

// What a mesh holds, counted with the definitions the real test meshes' reference figures use:
// edges are undirected vertex pairs of usable faces; a boundary edge has one face, a
// non-manifold edge more than two; a non-manifold vertex has incident faces forming more than
// one fan across manifold edges; components are vertex-connected groups of faces; boundary
// loops are the components of the boundary-edge graph.
struct ValidationReport {
  int64_t vertices = 0;
  int64_t faces = 0;
  int64_t faces_out_of_range = 0;     // dropped from the topology
  int64_t faces_repeated_index = 0;   // dropped from the topology
  int64_t zero_area_faces = 0;        // area < 1e-12 * (bbox diagonal)^2; kept
  int64_t duplicate_faces = 0;        // same vertex set as an earlier face; kept
  int64_t unreferenced_vertices = 0;  // no usable face uses them
  int64_t non_finite_vertices = 0;    // NaN or Inf in a coordinate
  int64_t edges = 0;
  int64_t boundary_edges = 0;
  int64_t boundary_loops = 0;
  int64_t nonmanifold_edges = 0;
  int64_t nonmanifold_vertices = 0;
  int64_t inconsistently_oriented_edges = 0;
  int64_t connected_components = 0;

  int64_t dropped_faces() const { return faces_out_of_range + faces_repeated_index; }
  bool closed() const { return boundary_edges == 0; }
  bool manifold() const { return nonmanifold_edges == 0 && nonmanifold_vertices == 0; }
  int64_t euler_characteristic() const {
    return (vertices - unreferenced_vertices) - edges + (faces - dropped_faces());
  }
};

// Builds the topology of `mesh`; fills `report` when it is not null. Linear in the mesh's size
// up to a log factor of the largest valence. Once `stop` fires it returns early with an
// unfinished topology and report: a caller that passes a token checks it after the call.
Topology BuildTopology(const Mesh& mesh, ValidationReport* report = nullptr, const StopToken& stop = {});

// The sum over the vertices of their valence squared: the work of a pass that visits the ring
// of every neighbour of every vertex (e.g. eq. (14)'s second rings), which a single vertex of
// valence k makes k^2.
int64_t SquaredValenceSum(const Topology& topo);

// One byte per vertex, 1 for the vertices of boundary loops of at most `max_edges` edges
// whose every vertex is a (manifold) boundary vertex: holes in the sampling a few edges around
// rather than rims of the shape. Linear in the number of boundary vertices times `max_edges`.
std::vector<uint8_t> SmallHoleVertices(const Topology& topo, int32_t max_edges);

// Convenience: the report alone.
ValidationReport Validate(const Mesh& mesh);

// A human-readable multi-line report (one "name: value" per line).
std::string FormatReport(const ValidationReport& report);

}  // namespace meshsmooth
