// How the CLI reaches the service: one or more meshsmoothd replicas through any gRPC target
// (round-robin over its addresses, keepalive, TLS and a bearer token when asked), or the same
// service started in-process; each call's deadline and credentials; and Ctrl-C during a call.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <thread>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "base/shutdown_signals.h"
#include "grpcpp/grpcpp.h"
#include "server/server.h"

namespace meshsmooth::client {

struct ConnectionOptions {
  // A gRPC target (ChannelTarget); empty = an in-process server.
  std::string server;
  std::string token_file;  // bearer token (ReadTokenFile)
  std::string tls_ca;      // PEM roots; enables TLS
  double timeout_seconds = 3600.0;
  int retries = 4;  // attempts after the first on UNAVAILABLE / RESOURCE_EXHAUSTED; 0 = none
  // Without `server`: the most memory a job may need by its estimate (server/job_memory.h);
  // 0 = what the machine has available (LocalMemoryBound, client/local_run.h).
  int64_t max_memory_bytes = 0;
};

// The gRPC target for --server: a target with a scheme (dns:///name:port, unix:path, ...) or a
// single host:port goes as it is; a comma-separated list of IP:PORT (IPv4 literals or
// `localhost`, or [IPv6]:PORT, one family) becomes an ipv4: or ipv6: target. With `shuffle`,
// the addresses of an ipv4:/ipv6: list come in a random order: round_robin sends a channel's
// first call to the first address that connects, which would otherwise be the first listed
// for every one-job CLI process. InvalidArgument for a list naming a host (use dns:/// and a
// name with several addresses) or mixing families.
absl::StatusOr<std::string> ChannelTarget(const std::string& server, bool shuffle = false);

// The channel's service config (JSON): round_robin over the target's addresses, and gRPC's
// retryPolicy for ListFlows (UNAVAILABLE and RESOURCE_EXHAUSTED, `retries` + 1 attempts, at
// most 5). Smooth is retried by RetryingSmooth instead (client/retry.h says why).
std::string ServiceConfigJson(int retries);

// The channel to `options.server`, or to an in-process server started here and kept alive in
// `embedded`. InvalidArgument when the target is malformed or the CA file cannot be read; the
// in-process server's own errors when it cannot start.
absl::StatusOr<std::shared_ptr<grpc::Channel>> Connect(const ConnectionOptions& options,
                                                       std::unique_ptr<server::Server>& embedded);

// The deadline of a call made now: `options.timeout_seconds` ahead. Retries share it.
std::chrono::system_clock::time_point CallDeadline(const ConnectionOptions& options);

// `status` of a failed call to `options.server`, with a hint when it looks like one side speaks
// TLS and the other does not: a server that closes the connection at once ("Socket closed")
// when no --tls-ca was given, a failed TLS handshake when one was; or that the server's
// certificate does not verify against --tls-ca. Anything else unchanged.
absl::Status WithConnectionHint(const absl::Status& status, const ConnectionOptions& options);

// Sets the call's deadline and, with a token file, its "authorization: Bearer" metadata.
// InvalidArgument when the token file cannot be read or is blank.
absl::Status PrepareContext(const ConnectionOptions& options, grpc::ClientContext& context,
                            std::chrono::system_clock::time_point deadline);

// Ctrl-C while a call runs: SIGINT/SIGTERM (blocked in every thread by main()) are waited for
// on a thread of their own, and the first one calls `on_interrupt` (which cancels the call on
// the server). Ends at once when the call is over.
class InterruptWatcher {
 public:
  explicit InterruptWatcher(std::function<void()> on_interrupt)
      : on_interrupt_(std::move(on_interrupt)), watcher_([this](int) {
          interrupted_.store(true);
          on_interrupt_();
        }) {}

  bool interrupted() const { return interrupted_.load(); }

 private:
  std::function<void()> on_interrupt_;
  std::atomic<bool> interrupted_{false};
  ShutdownSignalWatcher watcher_;  // last: its thread uses the members above
};

}  // namespace meshsmooth::client
