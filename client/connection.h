// How the CLI reaches the service: a meshsmoothd at HOST:PORT (TLS and a bearer token when
// asked), or the same service started in-process; each call's deadline and credentials; and
// Ctrl-C during a call.
#pragma once

#include <atomic>
#include <memory>
#include <string>
#include <thread>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "grpcpp/grpcpp.h"
#include "server/server.h"

namespace meshsmooth::client {

struct ConnectionOptions {
  std::string server;      // HOST:PORT; empty = an in-process server
  std::string token_file;  // bearer token (ReadTokenFile)
  std::string tls_ca;      // PEM roots; enables TLS
  double timeout_seconds = 3600.0;
};

// The channel to `options.server`, or to an in-process server started here and kept alive in
// `embedded`. InvalidArgument when the CA file cannot be read; the in-process server's own
// errors when it cannot start.
absl::StatusOr<std::shared_ptr<grpc::Channel>> Connect(const ConnectionOptions& options,
                                                       std::unique_ptr<server::Server>& embedded);

// Sets the call's deadline and, with a token file, its "authorization: Bearer" metadata.
// InvalidArgument when the token file cannot be read or is blank.
absl::Status PrepareContext(const ConnectionOptions& options, grpc::ClientContext& context);

// Ctrl-C while a call runs: SIGINT/SIGTERM (blocked in every thread by main()) are waited for
// on a thread of this object's own, and the first one cancels the call on the server.
class InterruptWatcher {
 public:
  explicit InterruptWatcher(grpc::ClientContext* context);
  ~InterruptWatcher();
  InterruptWatcher(const InterruptWatcher&) = delete;
  InterruptWatcher& operator=(const InterruptWatcher&) = delete;

  bool interrupted() const { return interrupted_.load(); }

 private:
  grpc::ClientContext* context_;
  std::atomic<bool> stop_{false}, interrupted_{false};
  std::thread thread_;
};

}  // namespace meshsmooth::client
