// SIGINT and SIGTERM taken on a thread of the program's own (sigwait), never in a handler:
// what follows them (shutting a server down, cancelling a call) takes locks, which a signal
// handler must not. Both binaries block the two signals in main() before any thread starts, so
// every thread started later (gRPC's, OpenMP's) inherits the mask and only the waiter sees them.
#pragma once

#include <chrono>

namespace meshsmooth {

// Blocks SIGINT and SIGTERM in the calling thread and, through inheritance, in every thread it
// starts afterwards. Call it before any thread exists.
void BlockShutdownSignals();

// Waits for SIGINT or SIGTERM (blocked with BlockShutdownSignals()) and returns which came.
int WaitForShutdownSignal();

// Same, giving up after `timeout`: 0 when neither came by then.
int WaitForShutdownSignal(std::chrono::milliseconds timeout);

}  // namespace meshsmooth
