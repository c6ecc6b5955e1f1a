// The client's retry rules (client/retry.h): which failures are retried, and the backoff.
#include "client/retry.h"

#include <algorithm>
#include <chrono>
#include <vector>

#include "core/io/draco_codec.h"
#include "grpcpp/create_channel.h"
#include "gtest/gtest.h"
#include "tests/flow_fixtures.h"
#include "tests/service/service_fixtures.h"

namespace meshsmooth::client {
namespace {

using std::chrono::milliseconds;

TEST(RetryTest, OnlyCapacityAndAvailabilityBeforeAnyResult) {
  CallState fresh, accepted, streaming, transient;
  accepted.accepted = true;
  streaming.accepted = streaming.result_started = true;
  transient.transient_exhaustion = true;
  EXPECT_TRUE(Retryable(absl::UnavailableError("shutting down"), fresh));
  EXPECT_TRUE(Retryable(absl::ResourceExhaustedError("queue full"), transient));
  // Without the server's word that it is its capacity: a limit the request exceeds.
  EXPECT_FALSE(Retryable(absl::ResourceExhaustedError("above this server's limit"), fresh));
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
    double sum = 0;
    const int samples = 2000;
    for (int i = 0; i < samples; ++i) {
      const milliseconds d = BackoffDelay(p, retry, rng);
      lo = std::min(lo, d);
      hi = std::max(hi, d);
      sum += static_cast<double>(d.count());
    }
    const milliseconds cap = caps[retry - 1];
    EXPECT_LE(hi, cap) << retry;
    // Full jitter: the waits cover the range, not one value, and spread evenly over it (uniform
    // on [0, cap]: a mean of cap / 2, whose spread over 2000 samples is 0.7 % of the cap).
    EXPECT_LT(lo.count(), cap.count() / 10) << retry;
    EXPECT_GT(hi.count(), cap.count() * 9 / 10) << retry;
    EXPECT_NEAR(sum / samples, cap.count() / 2.0, cap.count() * 0.05) << retry;
  }
}

// RetryingSmooth against a server that is never there: max_attempts attempts, the retries told
// in order (1, 2, 3) with UNAVAILABLE, each wait below its exponential cap and actually waited.
TEST(RetryTest, EachRetryWaitsItsBackoffUntilTheAttemptsRunOut) {
  const auto deadline = std::chrono::system_clock::now() + std::chrono::seconds(60);
  RetryPolicy policy;
  policy.max_attempts = 4;
  policy.initial_backoff = milliseconds(40);
  policy.max_backoff = milliseconds(100);
  struct Retry {
    int number;
    absl::StatusCode code;
    milliseconds wait;
    std::chrono::steady_clock::time_point told;
  };
  std::vector<Retry> retries;
  std::vector<std::chrono::steady_clock::time_point> attempt_starts;
  RetryingSmooth call(
      policy,
      [&](grpc::ClientContext& ctx) {
        attempt_starts.push_back(std::chrono::steady_clock::now());
        ctx.set_deadline(deadline);
        return absl::OkStatus();
      },
      deadline,
      [&](int retry, const absl::Status& s, milliseconds wait) {
        retries.push_back({retry, s.code(), wait, std::chrono::steady_clock::now()});
      });
  // Nothing listens on port 1: every attempt fails with UNAVAILABLE at once.
  auto dead = v1::MeshSmoother::NewStub(grpc::CreateChannel("127.0.0.1:1", grpc::InsecureChannelCredentials()));
  const std::string draco = *EncodeDraco(testing::FloatMesh(testing::NoisySphere(1)));
  const absl::Status s = call.Run(*dead, testing::Spec("laplacian", 1), draco).status();
  EXPECT_EQ(s.code(), absl::StatusCode::kUnavailable) << s;
  EXPECT_EQ(call.attempts(), 4);
  ASSERT_EQ(retries.size(), 3u);
  ASSERT_EQ(attempt_starts.size(), 4u);
  const milliseconds caps[] = {milliseconds(40), milliseconds(80), milliseconds(100)};
  for (int i = 0; i < 3; ++i) {
    SCOPED_TRACE(::testing::Message() << "retry " << i + 1);
    EXPECT_EQ(retries[i].number, i + 1);
    EXPECT_EQ(retries[i].code, absl::StatusCode::kUnavailable);
    EXPECT_LE(retries[i].wait, caps[i]);
    // The next attempt starts no sooner than the wait told (1 ms for the clock's rounding).
    EXPECT_GE(attempt_starts[i + 1] - retries[i].told, retries[i].wait - milliseconds(1));
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

// The server says in the trailing metadata which RESOURCE_EXHAUSTED a retry can fix: a full
// queue is retried up to the policy's attempts, a mesh above --max-vertices or an upload above
// --max-upload-bytes is sent once.
TEST(RetryTest, LimitsTheMeshExceedsAreSentOnceAFullQueueAgain) {
  const std::string draco = *EncodeDraco(testing::FloatMesh(testing::NoisySphere(2)));  // 162 vertices
  const auto deadline = std::chrono::system_clock::now() + std::chrono::seconds(60);
  auto prepare = [deadline](grpc::ClientContext& ctx) {
    ctx.set_deadline(deadline);
    return absl::OkStatus();
  };
  RetryPolicy policy;
  policy.max_attempts = 3;
  policy.initial_backoff = milliseconds(1);
  struct Case {
    const char* limit;
    server::ServerOptions options;
  };
  std::vector<Case> cases(2);
  cases[0].limit = "--max-vertices";
  cases[0].options.max_vertices = 100;
  cases[1].limit = "--max-upload-bytes";
  cases[1].options.max_upload_bytes = 100;
  for (const Case& c : cases) {
    SCOPED_TRACE(c.limit);
    auto server = testing::StartServer(c.options);
    ASSERT_TRUE(server);
    auto stub = v1::MeshSmoother::NewStub(server->InProcessChannel());
    RetryingSmooth call(policy, prepare, deadline);
    const absl::Status s = call.Run(*stub, testing::Spec("laplacian", 3), draco).status();
    testing::ExpectStatus(s, absl::StatusCode::kResourceExhausted, c.limit);
    EXPECT_EQ(call.attempts(), 1);
  }

  server::ServerOptions o;
  o.queue_depth = 0;
  testing::BusyServer busy(o);  // its one worker busy, no room to wait
  RetryingSmooth call(policy, prepare, deadline);
  const absl::Status s = call.Run(*busy.long_job.stub, testing::Spec("laplacian", 3), draco).status();
  testing::ExpectStatus(s, absl::StatusCode::kResourceExhausted, "queue is full");
  EXPECT_EQ(call.attempts(), 3);
  busy.long_job.ctx.TryCancel();
  EXPECT_EQ(busy.long_job.running.get().status().code(), absl::StatusCode::kCancelled);
}

// What a client in another language reads: the trailing metadata of smoothing.proto.
TEST(RetryTest, ResourceExhaustedCarriesTransientOrPermanent) {
  const std::string draco = *EncodeDraco(testing::FloatMesh(testing::NoisySphere(2)));
  server::ServerOptions o;
  o.max_vertices = 100;
  auto server = testing::StartServer(o);
  ASSERT_TRUE(server);
  auto stub = v1::MeshSmoother::NewStub(server->InProcessChannel());
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
  CallState state;
  state.transient_exhaustion = true;
  EXPECT_EQ(CallSmooth(*stub, ctx, testing::Spec("laplacian", 3), draco, nullptr, 1 << 20, &state).status().code(),
            absl::StatusCode::kResourceExhausted);
  EXPECT_FALSE(state.transient_exhaustion);
  const auto& trailers = ctx.GetServerTrailingMetadata();
  ASSERT_EQ(trailers.count("meshsmooth-exhausted"), 1u);
  EXPECT_EQ(trailers.find("meshsmooth-exhausted")->second, "permanent");

  server::ServerOptions q;
  q.queue_depth = 0;
  testing::BusyServer busy(q);
  grpc::ClientContext full;
  full.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
  CallState refused;
  EXPECT_EQ(CallSmooth(*busy.long_job.stub, full, testing::Spec("laplacian", 3), draco, nullptr, 1 << 20, &refused)
                .status()
                .code(),
            absl::StatusCode::kResourceExhausted);
  EXPECT_TRUE(refused.transient_exhaustion);
  ASSERT_EQ(full.GetServerTrailingMetadata().count("meshsmooth-exhausted"), 1u);
  EXPECT_EQ(full.GetServerTrailingMetadata().find("meshsmooth-exhausted")->second, "transient");
  busy.long_job.ctx.TryCancel();
  EXPECT_EQ(busy.long_job.running.get().status().code(), absl::StatusCode::kCancelled);
}

}  // namespace
}  // namespace meshsmooth::client
