// The client's retry rules (client/retry.h): which failures are retried, and the backoff.
#include "client/retry.h"

#include <algorithm>
#include <chrono>

#include "core/io/draco_codec.h"
#include "grpcpp/create_channel.h"
#include "gtest/gtest.h"
#include "tests/flow_fixtures.h"
#include "tests/service/service_fixtures.h"

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

// The CLI's upload goes as soon as no attempt can need it again: after the last attempt has
// sent it, never after an attempt that a retry may follow.
TEST(RetryTest, UploadIsReleasedOnceTheLastAttemptHasSentIt) {
  const std::string draco = *EncodeDraco(testing::FloatMesh(testing::NoisySphere(2)));
  const auto deadline = std::chrono::system_clock::now() + std::chrono::seconds(30);
  auto prepare = [deadline](grpc::ClientContext& ctx) {
    ctx.set_deadline(deadline);
    return absl::OkStatus();
  };
  auto server = testing::StartServer();
  ASSERT_TRUE(server);
  auto live = v1::MeshSmoother::NewStub(server->InProcessChannel());
  // Nothing listens on port 1: every attempt fails with UNAVAILABLE, which is retried.
  auto dead = v1::MeshSmoother::NewStub(grpc::CreateChannel("127.0.0.1:1", grpc::InsecureChannelCredentials()));
  struct Case {
    v1::MeshSmoother::Stub* stub;
    int attempts, released;
    bool ok;
  } cases[] = {{live.get(), 1, 1, true}, {live.get(), 3, 0, true}, {dead.get(), 2, 1, false}};
  for (const Case& c : cases) {
    SCOPED_TRACE(::testing::Message() << "max_attempts " << c.attempts << (c.ok ? ", live server" : ", no server"));
    RetryPolicy policy;
    policy.max_attempts = c.attempts;
    policy.initial_backoff = milliseconds(1);
    RetryingSmooth call(policy, prepare, deadline);
    int released = 0;
    call.ReleaseAfterLastSend([&] { ++released; });
    absl::StatusOr<SmoothOutcome> out = call.Run(*c.stub, testing::Spec("laplacian", 3), draco);
    EXPECT_EQ(out.ok(), c.ok) << out.status();
    if (!c.ok) {
      EXPECT_EQ(out.status().code(), absl::StatusCode::kUnavailable) << out.status();
    }
    EXPECT_EQ(call.attempts(), c.ok ? 1 : c.attempts);
    EXPECT_EQ(released, c.released);
  }
}

}  // namespace
}  // namespace meshsmooth::client
