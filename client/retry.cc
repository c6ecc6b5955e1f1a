#include "client/retry.h"

#include <algorithm>
#include <cmath>

namespace meshsmooth::client {

bool Retryable(const absl::Status& status, const CallState& state) {
  const bool code = status.code() == absl::StatusCode::kUnavailable ||
                    (status.code() == absl::StatusCode::kResourceExhausted && state.transient_exhaustion);
  return code && !state.result_started;
}

std::chrono::milliseconds BackoffDelay(const RetryPolicy& policy, int retry, std::mt19937_64& rng) {
  const double cap = std::min<double>(static_cast<double>(policy.max_backoff.count()),
                                      static_cast<double>(policy.initial_backoff.count()) *
                                          std::pow(policy.backoff_multiplier, std::max(0, retry - 1)));
  std::uniform_real_distribution<double> jitter(0.0, std::max(0.0, cap));
  return std::chrono::milliseconds(static_cast<int64_t>(jitter(rng)));
}

RetryingSmooth::RetryingSmooth(RetryPolicy policy, Prepare prepare, std::chrono::system_clock::time_point deadline,
                               OnRetry on_retry)
    : policy_(policy), prepare_(std::move(prepare)), deadline_(deadline), on_retry_(std::move(on_retry)) {}

absl::StatusOr<SmoothOutcome> RetryingSmooth::Run(v1::MeshSmoother::StubInterface& stub, const v1::JobSpec& spec,
                                                  std::string_view draco,
                                                  const std::function<void(const v1::Progress&)>& on_progress,
                                                  size_t chunk_bytes) {
  std::mt19937_64 rng(std::random_device{}());
  attempts_ = 0;
  for (;;) {
    grpc::ClientContext context;
    if (absl::Status s = prepare_(context); !s.ok()) return s;
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (cancelled_) return absl::CancelledError("cancelled");
      context_ = &context;
    }
    ++attempts_;
    CallState state;
    const bool last = attempts_ >= policy_.max_attempts;
    absl::StatusOr<SmoothOutcome> outcome =
        CallSmooth(stub, context, spec, draco, on_progress, chunk_bytes, &state, last ? release_ : nullptr);
    {
      std::lock_guard<std::mutex> lock(mu_);
      context_ = nullptr;
    }
    if (outcome.ok() || attempts_ >= policy_.max_attempts || !Retryable(outcome.status(), state)) return outcome;
    const std::chrono::milliseconds wait = BackoffDelay(policy_, attempts_, rng);
    if (std::chrono::system_clock::now() + wait >= deadline_) return outcome;  // no time for another
    if (on_retry_) on_retry_(attempts_, outcome.status(), wait);
    std::unique_lock<std::mutex> lock(mu_);
    if (cv_.wait_for(lock, wait, [this] { return cancelled_; })) return absl::CancelledError("cancelled");
  }
}

void RetryingSmooth::Cancel() {
  std::lock_guard<std::mutex> lock(mu_);
  cancelled_ = true;
  if (context_ != nullptr) context_->TryCancel();
  cv_.notify_all();
}

bool RetryingSmooth::cancelled() {
  std::lock_guard<std::mutex> lock(mu_);
  return cancelled_;
}

}  // namespace meshsmooth::client
