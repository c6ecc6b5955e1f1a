// Jobs through the service: a one-worker server on loopback TCP, timed from the client, beside
// Draco's own decode and encode and the job's steps one by one.
#pragma once

#include <string>

#include "bench/bench_common.h"

namespace meshsmooth::bench {

// Prints two rows: the default job (a JobSpec with no field set but `flow`, empty for the
// default flow) on `nm` as it is and on a copy with Gaussian noise of 0.2 h along the normals
// (seed 1), each the median of `runs` calls.
void DefaultJobRows(const NamedMesh& nm, const std::string& flow, int runs);

// With `on`, the servers these tables start serve Prometheus metrics (--metrics-listen on a free
// loopback port), so that the rows show what counting every job costs. Off by default.
void SetServiceMetrics(bool on);

// Prints the row of the service table for laplacian U0 with `iterations` on `nm` (medians of
// `runs`); returns Draco's bare decode + encode of its upload in ms, or -1 on failure.
double ServiceRow(const NamedMesh& nm, int iterations, int runs);

// Prints where a job's time goes besides smoothing, step by step as the service's job runs
// them (medians of `runs`).
void ServiceBreakdown(const NamedMesh& nm, int runs);

}  // namespace meshsmooth::bench
