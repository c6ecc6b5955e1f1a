// A cancel flag and a deadline that long steps of a job (decode, topology, metrics, features,
// encode) poll between blocks of work, so that a cancelled or timed-out job frees its worker
// within a fraction of a second whatever the mesh. The flows take one through RunControl.
#pragma once

#include <atomic>
#include <chrono>

#include "absl/status/status.h"

namespace meshsmooth {

class StopToken {
 public:
  using Clock = std::chrono::steady_clock;

  // Never fires.
  StopToken() = default;
  // Fires once `*cancel` is true (null: never) or the clock reaches `deadline`.
  StopToken(const std::atomic<bool>* cancel, Clock::time_point deadline) : cancel_(cancel), deadline_(deadline) {}

  // Each cause apart: a flow run ends on the first and returns its last iteration on the second.
  bool Cancelled() const { return cancel_ != nullptr && cancel_->load(std::memory_order_relaxed); }
  bool PastDeadline() const { return deadline_ != Clock::time_point::max() && Clock::now() >= deadline_; }

  // True once cancelled or past the deadline. Reads the clock: poll it every few thousand
  // items, not per item.
  bool Fired() const { return Cancelled() || PastDeadline(); }

  // Cancelled when cancelled, DeadlineExceeded past the deadline, else OK.
  absl::Status Check() const {
    if (Cancelled()) return absl::CancelledError("cancelled");
    if (PastDeadline()) return absl::DeadlineExceededError("past the deadline");
    return absl::OkStatus();
  }

  Clock::time_point deadline() const { return deadline_; }

 private:
  const std::atomic<bool>* cancel_ = nullptr;
  Clock::time_point deadline_ = Clock::time_point::max();
};

// How many items a loop runs between two polls of a StopToken.
inline constexpr int kStopPollInterval = 4096;

}  // namespace meshsmooth
