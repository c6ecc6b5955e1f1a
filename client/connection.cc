#include "client/connection.h"

#include <chrono>

#include "absl/strings/str_cat.h"
#include "core/io/file_bytes.h"
#include "core/shutdown_signals.h"

namespace meshsmooth::client {

absl::StatusOr<std::shared_ptr<grpc::Channel>> Connect(const ConnectionOptions& options,
                                                       std::unique_ptr<server::Server>& embedded) {
  if (options.server.empty()) {
    server::ServerOptions o;
    o.log_jobs = false;
    o.workers = 1;
    absl::StatusOr<std::unique_ptr<server::Server>> s = server::Server::Start(o, /*listen=*/false);
    if (!s.ok()) return s.status();
    embedded = std::move(*s);
    return embedded->InProcessChannel();
  }
  std::shared_ptr<grpc::ChannelCredentials> creds = grpc::InsecureChannelCredentials();
  if (!options.tls_ca.empty()) {
    absl::StatusOr<std::string> ca = ReadFileBytes(options.tls_ca);
    if (!ca.ok()) return absl::InvalidArgumentError(absl::StrCat("the CA file: ", ca.status().message()));
    grpc::SslCredentialsOptions ssl;
    ssl.pem_root_certs = std::move(*ca);
    creds = grpc::SslCredentials(ssl);
  }
  return grpc::CreateChannel(options.server, creds);
}

absl::Status PrepareContext(const ConnectionOptions& options, grpc::ClientContext& context) {
  context.set_deadline(std::chrono::system_clock::now() +
                       std::chrono::milliseconds(static_cast<int64_t>(options.timeout_seconds * 1000)));
  if (!options.token_file.empty()) {
    absl::StatusOr<std::string> token = ReadTokenFile(options.token_file);
    if (!token.ok()) return token.status();
    context.AddMetadata("authorization", "Bearer " + *token);
  }
  return absl::OkStatus();
}

InterruptWatcher::InterruptWatcher(grpc::ClientContext* context) : context_(context) {
  thread_ = std::thread([this] {
    // Wakes every 100 ms to see whether the call is over.
    while (!stop_.load()) {
      if (WaitForShutdownSignal(std::chrono::milliseconds(100)) != 0) {
        interrupted_.store(true);
        context_->TryCancel();
        return;
      }
    }
  });
}

InterruptWatcher::~InterruptWatcher() {
  stop_.store(true);
  thread_.join();
}

}  // namespace meshsmooth::client
