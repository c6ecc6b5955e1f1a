// The client's retry rules (client/retry.h): which failures are retried, and the backoff.
#include "client/retry.h"

#include <algorithm>
#include <chrono>

#include "gtest/gtest.h"

namespace meshsmooth::client {
namespace {

using std::chrono::milliseconds;

TEST(RetryTest, OnlyCapacityAndAvailabilityBeforeAnyResult) {
  CallState fresh, accepted, streaming;
  accepted.accepted = true;
  streaming.accepted = streaming.result_started = true;
  EXPECT_TRUE(Retryable(absl::UnavailableError("shutting down"), fresh));
  EXPECT_TRUE(Retryable(absl::ResourceExhaustedError("queue full"), fresh));
  EXPECT_TRUE(Retryable(absl::UnavailableError("cancelled after the grace"), accepted));
  EXPECT_FALSE(Retryable(absl::UnavailableError("went away mid-result"), streaming));
  for (const absl::Status& s :
       {absl::InvalidArgumentError("x"), absl::DeadlineExceededError("x"), absl::CancelledError("x"),
        absl::FailedPreconditionError("x"), absl::UnauthenticatedError("x"), absl::InternalError("x")}) {
    EXPECT_FALSE(Retryable(s, fresh)) << s;
  }
}

TEST(RetryTest, BackoffIsJitteredBelowAnExponentialCap) {
  RetryPolicy p;  // 200 ms, x2, at most 5 s
  std::mt19937_64 rng(7);
  const milliseconds caps[] = {milliseconds(200),  milliseconds(400),  milliseconds(800), milliseconds(1600),
                               milliseconds(3200), milliseconds(5000), milliseconds(5000)};
  for (int retry = 1; retry <= 7; ++retry) {
    milliseconds lo = milliseconds::max(), hi = milliseconds::zero();
    for (int i = 0; i < 2000; ++i) {
      const milliseconds d = BackoffDelay(p, retry, rng);
      lo = std::min(lo, d);
      hi = std::max(hi, d);
    }
    const milliseconds cap = caps[retry - 1];
    EXPECT_GE(lo.count(), 0) << retry;
    EXPECT_LE(hi, cap) << retry;
    // Full jitter: the waits cover the range, not one value.
    EXPECT_LT(lo.count(), cap.count() / 10) << retry;
    EXPECT_GT(hi.count(), cap.count() * 9 / 10) << retry;
  }
}

}  // namespace
}  // namespace meshsmooth::client
