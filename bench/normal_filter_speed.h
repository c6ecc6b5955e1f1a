// Where the normal-filtering flow's time goes, beside laplacian U0 (docs/normal-filtering.md,
// "Speed", explains the rows).
#pragma once

#include <string>

#include "core/mesh.h"
#include "core/topology.h"

namespace meshsmooth::bench {

// Prints the table of bilateral_normal's parts on `mesh` with its default parameters: one
// filter pass and one vertex pass (differences of runs that do one more per iteration), one
// iteration, and the set-up (face graph and, on a scattered large mesh, the Morton-ordered
// copy), each the median of `runs`, in ms on 1 and on min(2, `hw`) threads and as multiples of
// `u0_ms`, laplacian U0's ms per iteration on those thread counts.
void NormalFilterRows(const Mesh& mesh, const Topology& topo, const double u0_ms[2], int hw, int runs);

// The header of the table NormalFilterIterationRow fills.
void NormalFilterIterationHeader();

// One row: ms per iteration of bilateral_normal (default parameters: 1 filter pass, 5 vertex
// passes) and of laplacian U0 on `mesh`, both in the layout a 20-iteration bilateral_normal job
// runs in, on 1 and on min(2, `hw`) threads; the ratio of the two and bilateral_normal's ns per
// face. Each time is (T(K) - T(1)) / (K - 1), the median of `runs` runs, the flows alternated.
void NormalFilterIterationRow(const std::string& name, const Mesh& mesh, const Topology& topo, int hw, int runs);

}  // namespace meshsmooth::bench
