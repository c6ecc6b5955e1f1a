#include "client/connection.h"

#include <arpa/inet.h>

#include <algorithm>
#include <chrono>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "client/local_run.h"
#include "core/io/file_bytes.h"

namespace meshsmooth::client {
namespace {

// Schemes of gRPC's name resolvers: a target starting with one goes to gRPC as it is.
constexpr std::string_view kSchemes[] = {"dns:", "ipv4:", "ipv6:", "unix:", "unix-abstract:", "vsock:", "xds:"};

// Keepalive of the CLI's channel: a ping every 30 s without traffic, the connection given up 10 s
// after an unanswered one, also while a queued job sends nothing (meshsmoothd accepts a ping
// every 10 s without data; README, "Running many replicas").
constexpr int kKeepaliveTimeMs = 30'000;
constexpr int kKeepaliveTimeoutMs = 10'000;

struct ListEntry {
  int family;  // AF_INET or AF_INET6
  std::string address;
};

// One "IP:PORT" of a --server list.
absl::StatusOr<ListEntry> ParseListEntry(const std::string& entry) {
  const auto bad = [&](const char* why) {
    return absl::InvalidArgumentError(
        absl::StrCat("'", entry, "' ", why,
                     "; a list is IP:PORT,IP:PORT (IPv4, localhost or [IPv6]); for host names use dns:///NAME:PORT"));
  };
  const size_t colon = entry.rfind(':');
  if (colon == std::string::npos) return bad("has no port");
  int port = 0;
  if (!absl::SimpleAtoi(absl::string_view(entry).substr(colon + 1), &port) || port < 1 || port > 65535)
    return bad("has no valid port");
  std::string host(entry.substr(0, colon));
  unsigned char ip[16];
  if (host.size() > 2 && host.front() == '[' && host.back() == ']') {
    if (inet_pton(AF_INET6, host.substr(1, host.size() - 2).c_str(), ip) != 1) return bad("is not an IPv6 address");
    return ListEntry{AF_INET6, entry};
  }
  if (host == "localhost") host = "127.0.0.1";
  if (inet_pton(AF_INET, host.c_str(), ip) != 1) return bad("is not an IP address");
  return ListEntry{AF_INET, absl::StrCat(host, ":", port)};
}

}  // namespace

absl::StatusOr<std::string> ChannelTarget(const std::string& server, bool shuffle) {
  std::string scheme;
  std::vector<std::string> addresses;
  for (const char* list_scheme : {"ipv4:", "ipv6:"}) {
    if (server.rfind(list_scheme, 0) == 0) {
      scheme = list_scheme;
      addresses = absl::StrSplit(absl::string_view(server).substr(scheme.size()), ',');
    }
  }
  if (scheme.empty()) {
    for (std::string_view s : kSchemes) {
      if (std::string_view(server).substr(0, s.size()) == s) return server;
    }
    if (server.find(',') == std::string::npos) return server;  // one host:port: gRPC's DNS resolver
    int family = 0;
    for (const std::string& entry : std::vector<std::string>(absl::StrSplit(server, ',', absl::SkipWhitespace()))) {
      absl::StatusOr<ListEntry> e = ParseListEntry(entry);
      if (!e.ok()) return e.status();
      if (family != 0 && e->family != family) {
        return absl::InvalidArgumentError("a list mixes IPv4 and IPv6 addresses; gRPC takes one family");
      }
      family = e->family;
      addresses.push_back(e->address);
    }
    if (addresses.empty()) return absl::InvalidArgumentError("an empty list of addresses");
    scheme = family == AF_INET ? "ipv4:" : "ipv6:";
  }
  if (shuffle) std::shuffle(addresses.begin(), addresses.end(), std::mt19937_64(std::random_device{}()));
  return absl::StrCat(scheme, absl::StrJoin(addresses, ","));
}

std::string ServiceConfigJson(int retries) {
  std::string retry_policy;
  if (retries > 0) {
    // gRPC caps maxAttempts at 5; backoff with full jitter, within the call's deadline.
    retry_policy = absl::StrCat(R"(,"retryPolicy":{"maxAttempts":)", std::min(retries + 1, 5),
                                R"(,"initialBackoff":"0.2s","maxBackoff":"5s","backoffMultiplier":2,)",
                                R"("retryableStatusCodes":["UNAVAILABLE","RESOURCE_EXHAUSTED"]})");
  }
  // The Smooth entry is more specific than the service's: it leaves Smooth to RetryingSmooth.
  return absl::StrCat(R"({"loadBalancingConfig":[{"round_robin":{}}],"methodConfig":[)",
                      R"({"name":[{"service":"meshsmooth.v1.MeshSmoother"}])", retry_policy, "},",
                      R"({"name":[{"service":"meshsmooth.v1.MeshSmoother","method":"Smooth"}]}]})");
}

absl::StatusOr<std::shared_ptr<grpc::Channel>> Connect(const ConnectionOptions& options,
                                                       std::unique_ptr<server::Server>& embedded) {
  if (options.server.empty()) {
    absl::StatusOr<std::unique_ptr<server::Server>> s =
        server::Server::Start(LocalServerOptions(options.max_memory_bytes), /*listen=*/false);
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
  absl::StatusOr<std::string> target = ChannelTarget(options.server, /*shuffle=*/true);
  if (!target.ok()) return target.status();
  grpc::ChannelArguments args;
  args.SetServiceConfigJSON(ServiceConfigJson(options.retries));
  args.SetInt(GRPC_ARG_KEEPALIVE_TIME_MS, kKeepaliveTimeMs);
  args.SetInt(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, kKeepaliveTimeoutMs);
  args.SetInt(GRPC_ARG_HTTP2_MAX_PINGS_WITHOUT_DATA, 0);  // keep pinging while a job waits in a queue
  return grpc::CreateCustomChannel(*target, creds, args);
}

std::chrono::system_clock::time_point CallDeadline(const ConnectionOptions& options) {
  return std::chrono::system_clock::now() +
         std::chrono::milliseconds(static_cast<int64_t>(options.timeout_seconds * 1000));
}

absl::Status WithConnectionHint(const absl::Status& status, const ConnectionOptions& options) {
  if (status.code() != absl::StatusCode::kUnavailable || options.server.empty()) return status;
  const char* hint = nullptr;
  const std::string message = absl::AsciiStrToLower(status.message());
  if (options.tls_ca.empty() && absl::StrContains(status.message(), "Socket closed")) {
    hint = "the server may require TLS: --tls-ca FILE";
  } else if (!options.tls_ca.empty() && absl::StrContains(message, "certificate verify failed")) {
    // The server speaks TLS, but its certificate chain does not lead to a CA of the file.
    hint = "the server's certificate is not signed by a CA in --tls-ca";
  } else if (!options.tls_ca.empty() && absl::StrContains(message, "handshake")) {
    hint = "the server may not use TLS: leave out --tls-ca";
  }
  if (hint == nullptr) return status;
  return absl::Status(status.code(), absl::StrCat(status.message(), " (", hint, ")"));
}

absl::Status PrepareContext(const ConnectionOptions& options, grpc::ClientContext& context,
                            std::chrono::system_clock::time_point deadline) {
  context.set_deadline(deadline);
  if (!options.token_file.empty()) {
    absl::StatusOr<std::string> token = ReadTokenFile(options.token_file);
    if (!token.ok()) return token.status();
    context.AddMetadata("authorization", "Bearer " + *token);
  }
  return absl::OkStatus();
}

}  // namespace meshsmooth::client
