#include "server/server.h"

#include <algorithm>
#include <chrono>

#include "absl/strings/str_cat.h"
#include "core/io/file_bytes.h"
#include "grpcpp/ext/proto_server_reflection_plugin.h"
#include "grpcpp/health_check_service_interface.h"

namespace meshsmooth::server {

absl::StatusOr<std::unique_ptr<Server>> Server::Start(const ServerOptions& options, bool listen) {
  std::unique_ptr<Server> s(new Server());
  s->options_ = options;
  std::shared_ptr<grpc::ServerCredentials> creds = grpc::InsecureServerCredentials();
  if (!options.tls_cert_file.empty() || !options.tls_key_file.empty()) {
    if (options.tls_cert_file.empty() || options.tls_key_file.empty()) {
      return absl::FailedPreconditionError("TLS needs both --tls-cert and --tls-key");
    }
    absl::StatusOr<std::string> cert = ReadFileBytes(options.tls_cert_file), key = ReadFileBytes(options.tls_key_file);
    // FailedPrecondition whatever errno said: the server cannot start as configured.
    if (!cert.ok()) return absl::FailedPreconditionError(cert.status().message());
    if (!key.ok()) return absl::FailedPreconditionError(key.status().message());
    grpc::SslServerCredentialsOptions ssl;
    ssl.pem_key_cert_pairs.push_back({*key, *cert});
    creds = grpc::SslServerCredentials(ssl);
  }
  if (!options.metrics_listen.empty()) {
    absl::StatusOr<std::unique_ptr<MetricsExporter>> metrics = MetricsExporter::Start(options.metrics_listen);
    if (!metrics.ok()) return metrics.status();
    s->metrics_ = *std::move(metrics);
  }
  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  s->service_ = std::make_unique<MeshSmootherService>(options, s->metrics_ ? s->metrics_->events() : NoMetrics());
  grpc::ServerBuilder builder;
  if (listen) builder.AddListeningPort(options.listen, creds, &s->port_);
  builder.RegisterService(s->service_.get());
  builder.SetMaxReceiveMessageSize(kMaxReceiveMessageBytes);
  builder.SetMaxSendMessageSize(-1);
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_TIME_MS, 60'000);
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, 20'000);
  builder.AddChannelArgument(GRPC_ARG_HTTP2_MIN_RECV_PING_INTERVAL_WITHOUT_DATA_MS, 10'000);
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_PERMIT_WITHOUT_CALLS, 1);
  s->server_ = builder.BuildAndStart();
  if (s->server_ == nullptr || (listen && s->port_ == 0)) {
    return absl::FailedPreconditionError(absl::StrCat("cannot listen on ", options.listen));
  }
  s->server_->GetHealthCheckService()->SetServingStatus(true);
  if (s->metrics_) s->metrics_->SetGaugeSource([service = s->service_.get()] { return service->Gauges(); });
  return s;
}

Server::~Server() {
  Shutdown();
  if (metrics_) metrics_->SetGaugeSource(nullptr);  // before the service goes
}

int Server::metrics_port() const { return metrics_ ? metrics_->port() : 0; }

std::shared_ptr<grpc::Channel> Server::InProcessChannel() {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(-1);
  args.SetMaxSendMessageSize(-1);
  return server_->InProcessChannel(args);
}

int Server::Shutdown() {
  if (shut_down_ || server_ == nullptr) return 0;
  shut_down_ = true;
  const double grace = std::clamp(options_.grace_seconds, 0.0, 1e6);
  server_->GetHealthCheckService()->SetServingStatus(false);
  const int cut = service_->DrainAndStop(
      std::chrono::steady_clock::now() +
      std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(grace)));
  // Every job has ended by now. What is left are health watches and reflection streams, which
  // gRPC cancels at once, and, when the grace cut jobs, their calls sending UNAVAILABLE, which
  // get a short deadline first.
  server_->Shutdown(std::chrono::system_clock::now() + std::chrono::milliseconds(cut > 0 ? 200 : 0));
  server_->Wait();
  return cut;
}

}  // namespace meshsmooth::server
