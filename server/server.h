// A running meshsmoothd: the MeshSmoother service plus gRPC health and reflection, listening on
// TCP (optionally TLS) and reachable in-process, and with options.metrics_listen its Prometheus
// endpoint. Used by main.cc, the CLI's embedded mode and the tests.
#pragma once

#include <memory>

#include "absl/status/statusor.h"
#include "grpcpp/grpcpp.h"
#include "server/metrics.h"
#include "server/options.h"
#include "server/service.h"

namespace meshsmooth::server {

class Server {
 public:
  // Starts listening on options.listen (when `listen` is false, only the in-process channel
  // serves) and on options.metrics_listen when set. FailedPrecondition when an address cannot be
  // bound or TLS files cannot be read.
  static absl::StatusOr<std::unique_ptr<Server>> Start(const ServerOptions& options, bool listen = true);
  ~Server();

  int port() const { return port_; }  // the bound port (useful with port 0)
  int metrics_port() const;           // the metrics endpoint's port; 0 without one
  std::shared_ptr<grpc::Channel> InProcessChannel();
  MeshSmootherService& service() { return *service_; }

  // Graceful shutdown, in order: health NOT_SERVING, new calls, uploads and queued jobs end with
  // UNAVAILABLE; running jobs get options.grace_seconds to finish, and it returns as soon as the
  // last has sent its result; the rest end with UNAVAILABLE; then gRPC stops (within 0.2 s:
  // open health watches and reflection streams are cancelled). Returns how many running jobs
  // the grace cut (0 on a second call). The metrics endpoint serves until the Server is gone.
  int Shutdown();

 private:
  Server() = default;
  ServerOptions options_;
  std::unique_ptr<MetricsExporter> metrics_;  // before service_: it outlives the service
  std::unique_ptr<MeshSmootherService> service_;
  std::unique_ptr<grpc::Server> server_;
  int port_ = 0;
  bool shut_down_ = false;
};

// Maximum receive size of one message: a 1 MiB chunk plus framing.
inline constexpr int kMaxReceiveMessageBytes = static_cast<int>(kMaxChunkBytes) + (64 << 10);

}  // namespace meshsmooth::server
