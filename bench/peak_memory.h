// Peak resident memory of one job (upload bytes, decode, topology, smoothing, encoded result),
// measured in a fresh process: the benchmark re-runs itself with --peak-child, so that no
// thread pool or allocator state is inherited across fork.
#pragma once

#include <string>

#include "core/mesh.h"

namespace meshsmooth::bench {

// The child's side (`--peak-child DRACO_PATH`): runs a job's steps on the Draco file (median,
// 5 iterations), prints the growth of VmHWM over the resident set it started from in bytes per
// vertex, and returns the process's exit status.
int PeakChild(const std::string& draco_path);

// Bytes per vertex at the peak of a job on `mesh`, from a child run of the program `self`; -1
// when the child fails.
double PeakBytesPerVertex(const Mesh& mesh, const std::string& self);

}  // namespace meshsmooth::bench
