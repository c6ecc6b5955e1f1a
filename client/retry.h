// Smooth calls retried by the client: exponential backoff with full jitter, bounded attempts,
// within the call's one deadline. gRPC's own retries (the service config's retryPolicy) stop
// once the messages sent pass the channel's retry buffer (grpc.per_rpc_retry_buffer_size,
// 256 KiB by default), so they would not retry most uploads; the client still holds its
// upload, so it replays it itself. Safe because a job is a pure function of its input.
#pragma once

#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <random>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "client/smooth_client.h"

namespace meshsmooth::client {

struct RetryPolicy {
  int max_attempts = 5;  // the first attempt included; 1 = no retry
  std::chrono::milliseconds initial_backoff{200};
  std::chrono::milliseconds max_backoff{5000};
  double backoff_multiplier = 2.0;
};

// True for a failed attempt worth another: UNAVAILABLE, or a RESOURCE_EXHAUSTED the server
// marked transient (a full queue, the memory budget: state.transient_exhaustion), before any
// result byte arrived (later the client would have to merge two outputs). Never a limit the
// request exceeds (--max-vertices, --max-upload-bytes): that fails again.
bool Retryable(const absl::Status& status, const CallState& state);

// The wait before retry number `retry` (1, 2, ...): uniform in [0, min(max_backoff,
// initial_backoff x multiplier^(retry-1))] ("full jitter", as gRPC's retryPolicy does), so
// clients refused together do not come back together.
std::chrono::milliseconds BackoffDelay(const RetryPolicy& policy, int retry, std::mt19937_64& rng);

// One Smooth job, retried per `policy`. Each attempt gets a fresh context from `prepare` (it
// sets the deadline, the same for every attempt, and the metadata); a wait that would pass the
// deadline is not started: the last attempt's status is returned. Cancel() from another thread
// (Ctrl-C) ends the attempt in flight or the wait.
class RetryingSmooth {
 public:
  using Prepare = std::function<absl::Status(grpc::ClientContext&)>;
  // Told about each retry before its wait: the retry's number, the failed attempt's status and
  // the wait.
  using OnRetry = std::function<void(int retry, const absl::Status& status, std::chrono::milliseconds wait)>;

  RetryingSmooth(RetryPolicy policy, Prepare prepare, std::chrono::system_clock::time_point deadline,
                 OnRetry on_retry = nullptr);

  absl::StatusOr<SmoothOutcome> Run(v1::MeshSmoother::StubInterface& stub, const v1::JobSpec& spec,
                                    std::string_view draco,
                                    const std::function<void(const v1::Progress&)>& on_progress = nullptr,
                                    size_t chunk_bytes = 1 << 20);

  // Called once the last attempt Run may make has sent the upload: its bytes may go then.
  void ReleaseAfterLastSend(std::function<void()> release) { release_ = std::move(release); }

  void Cancel();
  bool cancelled();
  int attempts() const { return attempts_; }  // made by the last Run

 private:
  const RetryPolicy policy_;
  const Prepare prepare_;
  const std::chrono::system_clock::time_point deadline_;
  const OnRetry on_retry_;
  std::function<void()> release_;
  int attempts_ = 0;
  std::mutex mu_;  // guards context_ and cancelled_
  std::condition_variable cv_;
  grpc::ClientContext* context_ = nullptr;
  bool cancelled_ = false;
};

}  // namespace meshsmooth::client
