// Completion callbacks of kept jobs (JobSpec.callback_url): when a job of the job store ends, an
// HTTP POST of the job as JSON, signed with HMAC-SHA256 under meshsmoothd's
// --callback-secret-file, retried with exponential backoff. libcurl's multi interface runs every
// delivery on one thread of its own, so a slow or dead receiver never holds a worker or a gRPC
// reaction.
#pragma once

#include <chrono>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>

#include "absl/status/status.h"
#include "meshsmooth/v1/smoothing.pb.h"
#include "server/options.h"

namespace meshsmooth::server {

// How deliveries are made; the defaults are the documented ones (smoothing.proto, callback_url).
struct CallbackOptions {
  int attempts = 8;                                   // POSTs of one callback at most
  std::chrono::milliseconds first_delay{1000};        // before the second; doubled before each next
  std::chrono::milliseconds max_delay{60'000};        // the doubling stops here
  std::chrono::milliseconds request_timeout{10'000};  // one POST, connect to last byte
  std::chrono::milliseconds connect_timeout{5'000};   // its TCP (and TLS) connect
};

// OK for a URL a callback may go to: http:// or https://, a host, at most 2,048 characters;
// otherwise InvalidArgument naming callback_url and saying why.
absl::Status CheckCallbackUrl(std::string_view url);

// The body of a job's callback: `job` without its spec in proto3's JSON mapping, with the
// field names of smoothing.proto.
std::string CallbackBody(const v1::Job& job);

// "sha256=" and the lowercase hex HMAC-SHA256 of `body` under `secret`: the header
// X-Meshsmooth-Signature.
std::string CallbackSignature(std::string_view secret, std::string_view body);

// Delivers callbacks on a thread of its own. Thread-safe.
class CallbackSender {
 public:
  CallbackSender(std::string secret, LogFormat log_format, CallbackOptions options = {});
  ~CallbackSender();  // Stop()
  CallbackSender(const CallbackSender&) = delete;
  CallbackSender& operator=(const CallbackSender&) = delete;

  // Queues the POST of `job` (an ended job whose spec names a callback_url) and returns at once.
  void Send(const v1::Job& job);
  // Ends every delivery at once, sent or not (a pending retry is dropped, with a log line).
  void Stop();

 private:
  struct Delivery;
  void Loop();

  const std::string secret_;
  const LogFormat log_format_;
  const CallbackOptions options_;
  std::mutex mu_;
  std::deque<std::unique_ptr<Delivery>> incoming_;
  bool stopping_ = false;
  void* multi_ = nullptr;  // CURLM*, owned by the thread once it runs
  std::thread thread_;
};

}  // namespace meshsmooth::server
