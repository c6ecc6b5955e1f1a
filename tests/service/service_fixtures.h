// Shared by the service tests: an in-process or loopback server, a job spec, one call through
// the CLI's client code, and a job that runs until cancelled.
#pragma once

#include <atomic>
#include <chrono>
#include <future>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "client/smooth_client.h"
#include "core/io/draco_codec.h"
#include "core/vec3.h"
#include "gtest/gtest.h"
#include "server/server.h"
#include "tests/flow_fixtures.h"

namespace meshsmooth::testing {

using client::CallSmooth;
using client::SmoothOutcome;

// Positions rounded to float32, as a Draco upload holds them.
inline Mesh FloatMesh(Mesh m) {
  for (Vec3& p : m.positions) p = RoundToFloat(p);
  return m;
}

// A server with these options, quiet (no job or refusal lines); listening on a free loopback
// port when `listen`, else reachable in-process only.
inline std::unique_ptr<server::Server> StartServer(server::ServerOptions o = {}, bool listen = false) {
  o.log_jobs = false;
  o.log_refusals = false;
  if (listen) o.listen = "127.0.0.1:0";
  absl::StatusOr<std::unique_ptr<server::Server>> s = server::Server::Start(o, listen);
  EXPECT_TRUE(s.ok()) << s.status();
  return s.ok() ? std::move(*s) : nullptr;
}

// Seconds on the steady clock from `t0` to now.
inline double SecondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Waits until `server` holds at least `n` queued jobs, or 30 s; the caller asserts the count.
inline void WaitForQueuedJobs(server::Server& server, int n) {
  for (int i = 0; i < 3000 && server.service().queued_jobs() < n; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

// `s` has `code` and a message with `words` in it.
inline void ExpectStatus(const absl::Status& s, absl::StatusCode code, const std::string& words) {
  EXPECT_EQ(s.code(), code) << s;
  EXPECT_NE(s.message().find(words), std::string::npos) << "expected '" << words << "' in: " << s;
}

// A spec for `flow` with `iterations`, everything else default.
inline v1::JobSpec Spec(const std::string& flow, uint32_t iterations) {
  v1::JobSpec spec;
  spec.set_flow(flow);
  spec.set_iterations(iterations);
  return spec;
}

// One Smooth call with a 120 s deadline, in 256 KiB chunks.
inline absl::StatusOr<SmoothOutcome> Call(std::shared_ptr<grpc::Channel> channel, const v1::JobSpec& spec,
                                          const std::string& draco, const std::string& token = "") {
  auto stub = v1::MeshSmoother::NewStub(channel);
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(120));
  if (!token.empty()) ctx.AddMetadata("authorization", "Bearer " + token);
  return CallSmooth(*stub, ctx, spec, draco, nullptr, 256 << 10);
}

// A Smooth stream written message by message and read to its end by the test.
class OpenStream {
 public:
  OpenStream(std::shared_ptr<grpc::Channel> channel, std::chrono::seconds deadline)
      : stub_(v1::MeshSmoother::NewStub(channel)) {
    ctx_.set_deadline(std::chrono::system_clock::now() + deadline);
    stream_ = stub_->Smooth(&ctx_);
  }
  bool Write(const v1::SmoothRequest& m) { return stream_->Write(m); }
  // Half-closes, reads every response, and returns the final status.
  grpc::Status Finish() {
    stream_->WritesDone();
    return Drain();
  }
  // Reads every response without half-closing (the server ends the call), and the status.
  grpc::Status Drain() {
    v1::SmoothResponse r;
    while (stream_->Read(&r)) {
    }
    return stream_->Finish();
  }

 private:
  std::unique_ptr<v1::MeshSmoother::Stub> stub_;
  grpc::ClientContext ctx_;
  std::unique_ptr<grpc::ClientReaderWriter<v1::SmoothRequest, v1::SmoothResponse>> stream_;
};

// One message of a Smooth stream: the spec, or a mesh chunk.
inline v1::SmoothRequest SpecMessage(const v1::JobSpec& spec) {
  v1::SmoothRequest m;
  *m.mutable_spec() = spec;
  return m;
}

inline v1::SmoothRequest ChunkMessage(std::string bytes) {
  v1::SmoothRequest m;
  m.set_mesh_chunk(std::move(bytes));
  return m;
}

// A raw Smooth stream of `messages` (what the client library would never send), then
// half-close; the call's final status.
inline grpc::Status RawCall(std::shared_ptr<grpc::Channel> channel, const std::vector<v1::SmoothRequest>& messages) {
  OpenStream stream(channel, std::chrono::seconds(120));
  for (const auto& m : messages) {
    if (!stream.Write(m)) break;
  }
  return stream.Finish();
}

// A job that runs "forever" until cancelled: icosphere(6), many iterations.
struct LongJob {
  std::string draco = *EncodeDraco(FloatMesh(NoisySphere(6)));
  v1::JobSpec spec = Spec("median", 10000);  // the server's default limit; ~20 s on one core

  // Starts the call on `ctx` and returns once its first progress event arrived (the job is
  // running on a worker), or after 60 s.
  std::future<absl::StatusOr<SmoothOutcome>> Start(v1::MeshSmoother::Stub& stub, grpc::ClientContext& ctx) {
    auto started = std::make_shared<std::promise<void>>();
    auto signalled = std::make_shared<std::atomic<bool>>(false);
    std::future<void> running = started->get_future();
    auto call = std::async(std::launch::async, [this, &stub, &ctx, started, signalled] {
      return CallSmooth(stub, ctx, spec, draco, [started, signalled](const v1::Progress&) {
        if (!signalled->exchange(true)) started->set_value();
      });
    });
    EXPECT_EQ(running.wait_for(std::chrono::seconds(60)), std::future_status::ready) << "the long job never started";
    return call;
  }
};

// A LongJob running on a worker of the server behind `channel` once constructed; `ctx` cancels
// it and `running` is its outcome. The stub, spec and upload stay for the test's own calls.
struct RunningLongJob : LongJob {
  explicit RunningLongJob(std::shared_ptr<grpc::Channel> channel)
      : stub(v1::MeshSmoother::NewStub(channel)), running(Start(*stub, ctx)) {}

  std::unique_ptr<v1::MeshSmoother::Stub> stub;
  grpc::ClientContext ctx;
  std::future<absl::StatusOr<SmoothOutcome>> running;  // declared last: its call uses the members above
};

// A server with options `o` but one worker, which a LongJob keeps busy once constructed.
struct BusyServer {
  explicit BusyServer(server::ServerOptions o = {})
      : server(StartServer(OneWorker(o))), long_job(server->InProcessChannel()) {}

  static server::ServerOptions OneWorker(server::ServerOptions o) {
    o.workers = 1;
    return o;
  }

  std::unique_ptr<server::Server> server;
  RunningLongJob long_job;  // after `server`: it runs there
};

}  // namespace meshsmooth::testing
