// Internal to core/flows: the cotangent kernel's batches of vertices, with their ring indices
// laid out as the kernel loads them.
#pragma once

#include <cstdint>
#include <vector>

#include "core/topology.h"

namespace meshsmooth::flows {

// The free vertices of each block of kBlock vertices (core/flows/flow_kernel.h), in batches of
// `width` for MeanCurvatureLanes: a batch takes as many kernel steps as its largest valence,
// so the free vertices of a block are sorted by valence (stably) before they are cut into
// batches: on scans that saves a quarter of the steps (docs/decisions.md, "Speed"). The rows replace
// the gathers of ring indices.
//
// Batch j (of lanes[j] <= width vertices; a block's last batch may be short) starts at
// data[offsets[j]] and has 3 + its largest valence rows of `width` entries:
//   row 0       the vertices, lane by lane (short batches repeat their first vertex);
//   row 1       their valences;
//   row 2       3 Q_{n-1} of each lane (3 P for an empty ring);
//   row k + 3   3 Q_k, or 3 P for a lane whose ring is shorter.
// 3x an index is where that position's x sits in the array of doubles. The batches of block b
// are [block_first[b], block_first[b + 1]).
struct LaneBatches {
  int width = 0;
  std::vector<int32_t> data;
  std::vector<int64_t> offsets;
  std::vector<int32_t> lanes;
  std::vector<int32_t> block_first;
};

// The batches of the vertices whose role is kFree (3n must fit in int32, as Smooth() ensures).
// Left empty (the kernel then takes the vertex-by-vertex path) when the rows would hold more
// than twice the ring's entries plus three rows per batch (a few huge valences).
LaneBatches BuildLaneBatches(const Topology& topo, const uint8_t* role, int width, int threads);

}  // namespace meshsmooth::flows
