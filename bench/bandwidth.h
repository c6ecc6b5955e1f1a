// The memory bandwidth the flows are held against: a STREAM-like triad, and the bytes one
// iteration of a flow must move per vertex in our layout.
#pragma once

#include <cstddef>

#include "core/flows/flow.h"

namespace meshsmooth::bench {

// GB/s of the triad a = b + s c on three arrays of `bytes` each on `threads` threads, counting
// 24 bytes per element (two reads, one write); the best of 5, as STREAM reports.
double Triad(size_t bytes, int threads);

// Bytes one iteration of `flow` must move per vertex of mean valence `mean_valence` (no
// write-allocate, as the triad counts).
double BytesPerVertex(FlowId flow, double mean_valence);

}  // namespace meshsmooth::bench
