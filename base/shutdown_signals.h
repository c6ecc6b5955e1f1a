// SIGINT and SIGTERM taken on a thread of the program's own (sigwait), never in a handler:
// what follows them (shutting a server down, cancelling a call) takes locks, which a signal
// handler must not. Both binaries block the two signals in main() before any thread starts, so
// every thread started later (gRPC's, OpenMP's) inherits the mask and only the waiter sees them.
#pragma once

#include <atomic>
#include <chrono>
#include <functional>
#include <thread>

namespace meshsmooth {

// Blocks SIGINT and SIGTERM in the calling thread and, through inheritance, in every thread it
// starts afterwards. Call it before any thread exists.
void BlockShutdownSignals();

// Waits for SIGINT or SIGTERM (blocked with BlockShutdownSignals()) and returns which came.
int WaitForShutdownSignal();

// Same, giving up after `timeout`: 0 when neither came by then.
int WaitForShutdownSignal(std::chrono::milliseconds timeout);

// Waits for SIGINT or SIGTERM on a thread of its own and calls `on_signal` with it, once; its
// destructor ends the wait at once (an eventfd wakes the thread: no polling interval to sit out).
// Build it after BlockShutdownSignals().
class ShutdownSignalWatcher {
 public:
  explicit ShutdownSignalWatcher(std::function<void(int)> on_signal);
  ~ShutdownSignalWatcher();
  ShutdownSignalWatcher(const ShutdownSignalWatcher&) = delete;
  ShutdownSignalWatcher& operator=(const ShutdownSignalWatcher&) = delete;

 private:
  std::function<void(int)> on_signal_;
  int signal_fd_ = -1;
  int wake_fd_ = -1;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace meshsmooth
