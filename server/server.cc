#include "server/server.h"

#include <netdb.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>

#include "absl/strings/str_cat.h"
#include "core/io/file_bytes.h"
#include "grpcpp/ext/proto_server_reflection_plugin.h"
#include "grpcpp/health_check_service_interface.h"

namespace meshsmooth::server {
namespace {

// Why `listen` ("host:port") cannot be bound, as ": <reason>" for the start failure's message:
// gRPC's builder only says that it failed. Binds a socket of its own as gRPC would
// (SO_REUSEADDR, no SO_REUSEPORT); empty when that works or the address does not resolve.
std::string WhyNotListening(const std::string& listen) {
  const size_t colon = listen.rfind(':');
  if (colon == std::string::npos) return ": no port (give host:port)";
  std::string host = listen.substr(0, colon);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE;
  addrinfo* found = nullptr;
  if (getaddrinfo(host.empty() ? nullptr : host.c_str(), listen.c_str() + colon + 1, &hints, &found) != 0) {
    return ": the host does not resolve to a local address";
  }
  std::string why;
  for (const addrinfo* a = found; a != nullptr && why.empty(); a = a->ai_next) {
    const int fd = socket(a->ai_family, a->ai_socktype, a->ai_protocol);
    if (fd < 0) continue;
    const int one = 1;
    setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    if (bind(fd, a->ai_addr, a->ai_addrlen) != 0) {
      why = errno == EADDRINUSE ? ": address in use (another process listens on that port)"
                                : absl::StrCat(": ", std::strerror(errno));
    }
    close(fd);
  }
  freeaddrinfo(found);
  return why;
}

}  // namespace

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
  std::unique_ptr<JobStore> store;
  if (!options.job_store.empty()) {
    absl::StatusOr<std::unique_ptr<JobStore>> opened = JobStore::Open(options.job_store, {options.job_lease_seconds});
    if (!opened.ok()) return opened.status();
    store = *std::move(opened);
  }
  s->service_ = std::make_unique<MeshSmootherService>(options, s->metrics_ ? s->metrics_->events() : NoMetrics(),
                                                      std::move(store));
  grpc::ServerBuilder builder;
  if (listen) builder.AddListeningPort(options.listen, creds, &s->port_);
  builder.RegisterService(s->service_.get());
  builder.SetMaxReceiveMessageSize(kMaxReceiveMessageBytes);
  builder.SetMaxSendMessageSize(-1);
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_TIME_MS, 60'000);
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, 20'000);
  builder.AddChannelArgument(GRPC_ARG_HTTP2_MIN_RECV_PING_INTERVAL_WITHOUT_DATA_MS, 10'000);
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_PERMIT_WITHOUT_CALLS, 1);
  // gRPC sets SO_REUSEPORT by default on Linux: a second server on a busy port would then start
  // and take a share of the first one's connections. Without it the bind fails.
  builder.AddChannelArgument(GRPC_ARG_ALLOW_REUSEPORT, 0);
  s->server_ = builder.BuildAndStart();
  if (s->server_ == nullptr || (listen && s->port_ == 0)) {
    return absl::FailedPreconditionError(
        absl::StrCat("cannot listen on ", options.listen, listen ? WhyNotListening(options.listen) : ""));
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
