// Internal to core/flows: the cotangent kernel's ring indices laid out as it loads them.
#pragma once

#include <cstdint>
#include <vector>

#include "core/topology.h"

namespace meshsmooth::flows {

// The ring indices MeanCurvatureLanes loads (core/flows/kernel.h), laid out as it loads them,
// so that a step of a batch of `width` consecutive vertices reads one row of indices instead of
// gathering them (mcf at 655k vertices, 1 thread: 14.4 -> 12.0 ms per iteration).
//
// Batch b (vertices b * width .. (b + 1) * width - 1; whole batches only) starts at
// lane_ring[lane_offsets[b]] and has 1 + its largest valence rows of `width` entries: row 0
// holds 3 Q_{n-1} of each lane (3 P for an empty ring), row k + 1 holds 3 Q_k, or 3 P for a
// lane whose ring is shorter: 3x an index is where that position's x sits in the array of
// doubles. Both vectors are left empty (the kernel then gathers from the ring) when 3n does
// not fit in int32, or when the rows would hold more than twice the ring's entries plus one
// row per batch (a few huge valences).
void BuildLaneRing(const Topology& topo, int width, int threads, std::vector<int32_t>& lane_ring,
                   std::vector<int64_t>& lane_offsets);

}  // namespace meshsmooth::flows
