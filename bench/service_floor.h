// The least any service adds to Draco's own decode and encode: moving the bytes both ways and
// building neighbours to smooth on, measured beside the service table.
#pragma once

#include "bench/bench_common.h"

namespace meshsmooth::bench {

// Prints the floor's table for `nm` (medians of `runs`) against `bare_ms`, Draco's bare decode
// + encode of its upload: an overhead of 1.5x the bare codec leaves 0.5x for everything besides
// the codec itself (validation, metrics, welding seams, gRPC and protobuf framing, copies).
void ServiceFloor(const NamedMesh& nm, int runs, double bare_ms);

}  // namespace meshsmooth::bench
