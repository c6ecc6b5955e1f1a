// How fast the flows iterate: the variants the speed table times, their time per iteration and
// set-up, and the plain loop that bounds what our layout allows.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/flows/flow.h"
#include "core/mesh.h"
#include "core/topology.h"

namespace meshsmooth::bench {

// A row of the speed table: its label and the flow it times.
struct Variant {
  std::string label;
  FlowParams params;
};

// The rows of the speed table, in order: each flow with its default parameters, plus the
// umbrella flows with inverse-distance weights and median with eq. (14) over two rings.
std::vector<Variant> Variants();

// A flow's time split into its iterations and what a run pays once.
struct OurTiming {
  double per_iteration_ms = -1.0;  // (T(K) - T(1)) / (K - 1): the iterations alone
  double setup_ms = 0.0;           // T(1) - per_iteration: copies, h, reordering, allocation
};

// Medians of `runs` runs of `iterations` and of 1 iteration of `p` on `mesh` on `threads`;
// per_iteration_ms is -1 when a run fails.
OurTiming TimeOurs(const Mesh& mesh, const Topology& topo, FlowParams p, int iterations, int threads, int runs);

// The ceiling of our layout: ms per iteration of a plain CSR U0 loop (no roles, statistics,
// caps or checks) over the Morton-ordered arrays Smooth() runs on; median of `runs`.
double PlainU0Ms(const Mesh& mesh, const Topology& topo, int iterations, int threads, int runs);

// Iterations per timed run on a mesh of `n` vertices: about 40 million vertex-iterations, 3..200.
int IterationsFor(int32_t n);

// The icosphere of `level` with uniform noise of 0.3 h (seed 1), the same on every machine.
Mesh NoisyIcosphere(int level);

}  // namespace meshsmooth::bench
