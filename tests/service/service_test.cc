// The service end to end, in-process and over loopback TCP, through the same client code as
// the CLI (CallSmooth).
#include <algorithm>
#include <atomic>
#include <cmath>
#include <fstream>
#include <future>
#include <limits>
#include <sstream>
#include <thread>

#include "client/smooth_client.h"
#include "core/features/ridges.h"
#include "core/io/draco_codec.h"
#include "core/io/file_bytes.h"
#include "draco/compression/decode.h"
#include "draco/mesh/mesh.h"
#include "gtest/gtest.h"
#include "server/server.h"
#include "tests/flow_fixtures.h"
#include "tests/hostile_inputs.h"
#include "tests/service/service_fixtures.h"
#include "tests/test_data.h"

namespace meshsmooth {
namespace {

using client::CallSmooth;
using client::SmoothOutcome;
using server::Server;
using server::ServerOptions;
using namespace meshsmooth::testing;

// Every flow through the service equals the core's own result, bit for bit, on the lossless
// path (in-process for every flow, and once over loopback TCP).
TEST(ServiceTest, EveryFlowEqualsTheCoreBitForBit) {
  const Mesh mesh = FloatMesh(NoisySphere(3));
  const std::string draco = *EncodeDraco(mesh);
  auto in_process = StartServer();
  auto tcp = StartServer({}, /*listen=*/true);
  ASSERT_TRUE(in_process && tcp);
  auto tcp_channel =
      grpc::CreateChannel("127.0.0.1:" + std::to_string(tcp->port()), grpc::InsecureChannelCredentials());
  for (const std::string& flow : FlowNames()) {
    SCOPED_TRACE(flow);
    Mesh expected = mesh;
    ASSERT_TRUE(Smooth(expected, Params(flow, 7)).ok());
    for (auto channel : {in_process->InProcessChannel(), tcp_channel}) {
      absl::StatusOr<SmoothOutcome> out = Call(channel, Spec(flow, 7), draco);
      ASSERT_TRUE(out.ok()) << out.status();
      absl::StatusOr<Mesh> got = DecodeDraco(out->result);
      ASSERT_TRUE(got.ok());
      ASSERT_EQ(got->triangles, mesh.triangles);
      ASSERT_EQ(got->positions.size(), expected.positions.size());
      for (size_t i = 0; i < expected.positions.size(); ++i) {
        ASSERT_EQ(got->positions[i], RoundToFloat(expected.positions[i])) << "vertex " << i;
      }
      EXPECT_EQ(out->summary.parameters().iterations_run(), 7u);
      EXPECT_EQ(out->accepted.input().vertices(), mesh.num_vertices());
      EXPECT_GE(out->progress_events, 1);
    }
  }
}

// However fast the iterations run, at most ~10 progress events a second reach the client.
TEST(ServiceTest, ProgressIsThrottled) {
  auto server = StartServer();
  const std::string draco = *EncodeDraco(FloatMesh(NoisySphere(3)));
  const auto t0 = std::chrono::steady_clock::now();
  absl::StatusOr<SmoothOutcome> out = Call(server->InProcessChannel(), Spec("taubin", 5000), draco);
  const double seconds = SecondsSince(t0);
  ASSERT_TRUE(out.ok()) << out.status();
  EXPECT_GE(out->progress_events, 1);
  EXPECT_LE(out->progress_events, 10.0 * seconds + 3.0) << seconds << " s";
  EXPECT_LT(out->progress_events, 5000 / 10);
}

// A streamed default job names every phase, in order; iteration numbers come only from the
// smoothing with the chosen flow, rise to its count and stop there, at the summary's count. A
// small mesh is its own sample: its choice is the result, and no smoothing phase follows.
TEST(ServiceTest, DefaultJobProgressNamesEveryPhaseAndEndsAtTheSummarysCount) {
  auto server = StartServer();
  for (int level : {4, 6}) {  // 2,562 vertices, 40,962 (chooses on a sample)
    SCOPED_TRACE(level);
    const std::string draco = *EncodeDraco(FloatMesh(NoisySphere(level)));
    std::vector<v1::Progress> events;
    auto stub = v1::MeshSmoother::NewStub(server->InProcessChannel());
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(120));
    const v1::JobSpec spec;  // the default job: no parameters
    absl::StatusOr<SmoothOutcome> out = CallSmooth(
        *stub, ctx, spec, draco, [&](const v1::Progress& p) { events.push_back(p); }, 256 << 10);
    ASSERT_TRUE(out.ok()) << out.status();
    const uint32_t count = out->summary.parameters().iterations_run();
    const std::string flow = out->summary.parameters().flow();
    ASSERT_GT(count, 0u);
    ASSERT_GE(events.size(), 3u);
    EXPECT_EQ(events.front().phase(), v1::PROGRESS_PHASE_NOISE_ESTIMATE);
    EXPECT_EQ(events.back().phase(), v1::PROGRESS_PHASE_WRITING);
    std::vector<std::string> tried;
    uint32_t last = 0;
    for (const v1::Progress& e : events) {
      EXPECT_NE(e.phase(), v1::PROGRESS_PHASE_UNSPECIFIED);
      EXPECT_LE(e.iteration(), count);
      if (e.phase() == v1::PROGRESS_PHASE_CHOOSING) {
        EXPECT_EQ(last, 0u) << "choosing after smoothing began";
        EXPECT_EQ(e.iteration(), 0u);
        tried.push_back(e.flow());
      }
      if (e.phase() == v1::PROGRESS_PHASE_SMOOTHING) {
        EXPECT_EQ(e.flow(), flow);
        EXPECT_EQ(e.total(), count);
        EXPECT_GT(e.iteration(), last);
        last = e.iteration();
      }
    }
    EXPECT_EQ(tried, (std::vector<std::string>{"bilaplacian", "bilateral_normal"}));
    EXPECT_EQ(last, level == 4 ? 0u : count);
  }
}

TEST(ServiceTest, MeshAbove20MiBGoesThrough) {
  Mesh big = TwoRatePlane(1000, 760);  // 762,761 vertices
  AddUniformNoise(big, 0.3, 3);
  big = FloatMesh(std::move(big));
  const std::string draco = *EncodeDraco(big);
  ASSERT_GT(draco.size(), 20u << 20) << "the test mesh must exceed 20 MiB";
  auto server = StartServer();
  absl::StatusOr<SmoothOutcome> out = Call(server->InProcessChannel(), Spec("laplacian", 2), draco);
  ASSERT_TRUE(out.ok()) << out.status();
  EXPECT_GT(out->result.size(), 20u << 20);
  absl::StatusOr<Mesh> got = DecodeDraco(out->result);
  ASSERT_TRUE(got.ok());
  EXPECT_EQ(got->positions.size(), big.positions.size());
}

TEST(ServiceTest, CancellingMidJobFreesTheWorker) {
  BusyServer busy;
  busy.long_job.ctx.TryCancel();
  const absl::Status cancelled = busy.long_job.running.get().status();
  EXPECT_EQ(cancelled.code(), absl::StatusCode::kCancelled) << cancelled;
  // The only worker is free again: a small job starts at once.
  const auto t0 = std::chrono::steady_clock::now();
  absl::StatusOr<SmoothOutcome> next =
      Call(busy.server->InProcessChannel(), Spec("laplacian", 3), *EncodeDraco(Icosphere(2)));
  ASSERT_TRUE(next.ok()) << next.status();
  EXPECT_LT(next->summary.timings().queue_seconds(), 1.0);
  EXPECT_LT(SecondsSince(t0), 5.0);
}

TEST(ServiceTest, FullQueueIsRefusedAtOnce) {
  ServerOptions o;
  o.queue_depth = 1;
  BusyServer busy(o);
  RunningLongJob& a = busy.long_job;
  grpc::ClientContext b;
  auto run_b = std::async(std::launch::async, [&] { return CallSmooth(*a.stub, b, a.spec, a.draco); });
  // B waits in the queue; C finds it full.
  WaitForQueuedJobs(*busy.server, 1);
  ASSERT_EQ(busy.server->service().queued_jobs(), 1);
  const auto t0 = std::chrono::steady_clock::now();
  const absl::Status c =
      Call(busy.server->InProcessChannel(), Spec("laplacian", 1), *EncodeDraco(Icosphere(1))).status();
  EXPECT_LT(SecondsSince(t0), 2.0);  // at once
  ExpectStatus(c, absl::StatusCode::kResourceExhausted, "queue is full");
  a.ctx.TryCancel();
  b.TryCancel();
  EXPECT_EQ(a.running.get().status().code(), absl::StatusCode::kCancelled);
  EXPECT_EQ(run_b.get().status().code(), absl::StatusCode::kCancelled);
}

// Each bad input gets its status and a message that names the problem.
TEST(ServiceTest, BadInputsAreRefusedWithClearMessages) {
  ServerOptions o;
  o.max_upload_bytes = 100'000;
  o.max_iterations = 500;
  o.max_vertices = 5000;
  auto server = StartServer(o);
  auto channel = server->InProcessChannel();
  const std::string sphere = *EncodeDraco(Icosphere(2));

  const std::string point_cloud = DracoPointCloud();

  struct Case {
    std::string name;
    v1::JobSpec spec;
    std::string draco;
    absl::StatusCode code;
    std::string words;
  };
  v1::JobSpec bad_step = Spec("mcf", 3);
  bad_step.set_step(-1.0);
  v1::JobSpec bad_eps = Spec("median", 3);
  bad_eps.set_epsilon(1.5);
  v1::JobSpec bad_quant = Spec("median", 3);
  bad_quant.mutable_output()->set_quantization_bits(31);
  const std::vector<Case> cases = {
      {"corrupt draco", Spec("median", 3), "DRACO this is not a mesh", absl::StatusCode::kInvalidArgument, "Draco"},
      {"point cloud", Spec("median", 3), point_cloud, absl::StatusCode::kInvalidArgument, "point cloud"},
      {"no mesh", Spec("median", 3), "", absl::StatusCode::kInvalidArgument, "no mesh"},
      {"unknown flow", Spec("smoothest", 3), sphere, absl::StatusCode::kInvalidArgument, "unknown flow 'smoothest'"},
      {"step out of range", bad_step, sphere, absl::StatusCode::kInvalidArgument, "step"},
      {"epsilon out of range", bad_eps, sphere, absl::StatusCode::kInvalidArgument, "epsilon"},
      {"quantization out of range", bad_quant, sphere, absl::StatusCode::kInvalidArgument, "quantization_bits"},
      {"iterations above the limit", Spec("median", 501), sphere, absl::StatusCode::kInvalidArgument, "limit of 500"},
      {"upload above the limit", Spec("median", 3), *EncodeDraco(Icosphere(5)), absl::StatusCode::kResourceExhausted,
       "upload exceeds"},
  };
  for (const Case& c : cases) {
    const absl::Status s = Call(channel, c.spec, c.draco).status();
    EXPECT_EQ(s.code(), c.code) << c.name << ": " << s;
    EXPECT_NE(s.message().find(c.words), std::string::npos) << c.name << ": " << s;
  }
  // Above the vertex limit but within the upload limit: icosphere(4) has 2562 vertices.
  ServerOptions small = o;
  small.max_vertices = 1000;
  auto s2 = StartServer(small);
  const absl::Status too_big = Call(s2->InProcessChannel(), Spec("median", 3), *EncodeDraco(Icosphere(4))).status();
  ExpectStatus(too_big, absl::StatusCode::kResourceExhausted, "limit of 1000");

  // Raw streams the client library would never send: chunk first, two specs, empty request.
  auto raw = [&](const std::vector<v1::SmoothRequest>& msgs) { return RawCall(channel, msgs); };
  v1::SmoothRequest spec_msg, chunk_msg, empty_msg;
  *spec_msg.mutable_spec() = Spec("median", 3);
  chunk_msg.set_mesh_chunk(sphere);
  grpc::Status g = raw({chunk_msg});
  EXPECT_EQ(g.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(g.error_message().find("first message must be a JobSpec"), std::string::npos) << g.error_message();
  g = raw({spec_msg, spec_msg, chunk_msg});
  EXPECT_EQ(g.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(g.error_message().find("second JobSpec"), std::string::npos) << g.error_message();
  g = raw({});
  EXPECT_EQ(g.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(g.error_message().find("without a JobSpec"), std::string::npos) << g.error_message();
  g = raw({spec_msg, empty_msg});
  EXPECT_EQ(g.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
}

TEST(ServiceTest, DivergingFlowEndsWithAClearError) {
  auto server = StartServer();
  v1::JobSpec spec = Spec("mcf", 200);
  spec.set_step(10.0);
  const absl::Status s = Call(server->InProcessChannel(), spec, *EncodeDraco(FloatMesh(NoisySphere(3)))).status();
  ExpectStatus(s, absl::StatusCode::kFailedPrecondition, "diverged at iteration");
}

// Every method of the service authenticates (MeshSmootherService::Authenticate, each handler's
// first step): the two below are all the service has; a new method fails the count until it is
// checked here too.
TEST(ServiceTest, BearerTokenIsRequiredWhenConfigured) {
  ASSERT_EQ(v1::SmoothRequest::descriptor()->file()->FindServiceByName("MeshSmoother")->method_count(), 10)
      << "check the new method's authentication below";
  ServerOptions o;
  o.auth_token = "s3cret-token";
  auto server = StartServer(o, /*listen=*/true);
  auto channel = grpc::CreateChannel("127.0.0.1:" + std::to_string(server->port()), grpc::InsecureChannelCredentials());
  const std::string draco = *EncodeDraco(Icosphere(2));
  for (const std::string token : {"", "wrong", "s3cret-token-but-longer"}) {
    const absl::Status s = Call(channel, Spec("median", 2), draco, token).status();
    EXPECT_EQ(s.code(), absl::StatusCode::kUnauthenticated) << "token '" << token << "': " << s;
  }
  EXPECT_TRUE(Call(channel, Spec("median", 2), draco, "s3cret-token").ok());
  auto stub = v1::MeshSmoother::NewStub(channel);
  v1::ListFlowsResponse flows;
  grpc::ClientContext no_token;
  EXPECT_EQ(stub->ListFlows(&no_token, {}, &flows).error_code(), grpc::StatusCode::UNAUTHENTICATED);
  grpc::ClientContext with_token;
  with_token.AddMetadata("authorization", "Bearer s3cret-token");
  EXPECT_TRUE(stub->ListFlows(&with_token, {}, &flows).ok());
  const std::vector<FlowInfo> catalogue = DescribeFlows();
  ASSERT_EQ(flows.flows_size(), static_cast<int>(catalogue.size()));
  for (int i = 0; i < flows.flows_size(); ++i) {  // the constraints beyond the ranges, as the catalogue states them
    const v1::FlowInfo& f = flows.flows(i);
    EXPECT_EQ(f.name(), catalogue[i].name);
    EXPECT_EQ(f.constraints_size(), static_cast<int>(catalogue[i].constraints.size())) << f.name();
  }
  EXPECT_EQ(flows.flows(1).name(), "taubin");
  ASSERT_EQ(flows.flows(1).constraints_size(), 2);
  EXPECT_NE(flows.flows(1).constraints(1).find("taubin_pass_band < 1/step - 1"), std::string::npos);

  // The job methods check the token first: UNAUTHENTICATED without it; with it, this server
  // (no --job-store) answers UNIMPLEMENTED.
  for (const char* token : {"", "s3cret-token"}) {
    const grpc::StatusCode want = *token ? grpc::StatusCode::UNIMPLEMENTED : grpc::StatusCode::UNAUTHENTICATED;
    const auto context = [&] {
      auto c = std::make_unique<grpc::ClientContext>();
      if (*token) c->AddMetadata("authorization", std::string("Bearer ") + token);
      return c;
    };
    v1::Job job;
    v1::SubmitResponse submitted;
    v1::ListJobsResponse listed;
    v1::DeleteJobResponse deleted;
    EXPECT_EQ(stub->GetJob(context().get(), {}, &job).error_code(), want) << token;
    EXPECT_EQ(stub->ListJobs(context().get(), {}, &listed).error_code(), want) << token;
    EXPECT_EQ(stub->CancelJob(context().get(), {}, &job).error_code(), want) << token;
    EXPECT_EQ(stub->DeleteJob(context().get(), {}, &deleted).error_code(), want) << token;
    EXPECT_EQ(stub->QueryUpload(context().get(), {}, &submitted).error_code(), want) << token;
    {
      auto c = context();
      auto writer = stub->Submit(c.get(), &submitted);
      writer->WritesDone();
      EXPECT_EQ(writer->Finish().error_code(), want) << token;
    }
    {
      auto c = context();
      v1::JobEvent event;
      auto reader = stub->WatchJob(c.get(), {});
      while (reader->Read(&event)) {
      }
      EXPECT_EQ(reader->Finish().error_code(), want) << token;
    }
    {
      auto c = context();
      v1::FetchResultResponse piece;
      auto reader = stub->FetchResult(c.get(), {});
      while (reader->Read(&piece)) {
      }
      EXPECT_EQ(reader->Finish().error_code(), want) << token;
    }
  }
}

TEST(ServiceTest, SixteenConcurrentClientsAgainstTwoWorkers) {
  ServerOptions o;
  o.workers = 2;
  auto server = StartServer(o, /*listen=*/true);
  auto channel = grpc::CreateChannel("127.0.0.1:" + std::to_string(server->port()), grpc::InsecureChannelCredentials());
  std::vector<std::future<bool>> clients;
  for (int i = 0; i < 16; ++i) {
    clients.push_back(std::async(std::launch::async, [&, i] {
      const std::string flow = FlowNames()[i % FlowNames().size()];
      Mesh mesh = FloatMesh(NoisySphere(3, 0.3, 100 + i));
      Mesh expected = mesh;
      if (!Smooth(expected, Params(flow, 5)).ok()) return false;
      absl::StatusOr<SmoothOutcome> out = Call(channel, Spec(flow, 5), *EncodeDraco(mesh));
      if (!out.ok()) {
        ADD_FAILURE() << "client " << i << ": " << out.status();
        return false;
      }
      absl::StatusOr<Mesh> got = DecodeDraco(out->result);
      if (!got.ok() || got->positions.size() != expected.positions.size()) return false;
      for (size_t v = 0; v < expected.positions.size(); ++v) {
        if (!(got->positions[v] == RoundToFloat(expected.positions[v]))) return false;
      }
      return true;
    }));
  }
  int ok = 0;
  for (auto& c : clients) ok += c.get();
  EXPECT_EQ(ok, 16);
}

// SIGTERM's grace: a job running when shutdown begins finishes within the grace and delivers its
// whole result; one still running when the grace ends is cancelled with UNAVAILABLE, and
// Shutdown counts it as cut.
TEST(ServiceTest, GracefulShutdownLetsRunningJobsFinishThenCancels) {
  ServerOptions o;
  o.workers = 2;
  o.grace_seconds = 6.0;
  auto server = StartServer(o);
  ASSERT_TRUE(server);
  RunningLongJob long_job(server->InProcessChannel());  // one worker busy until cancelled

  // The other worker: a job of ~0.5 s on an idle core, shutdown begun at its first progress event.
  const Mesh mesh = FloatMesh(NoisySphere(5));
  const v1::JobSpec spec = Spec("taubin", 400);
  Mesh expected = mesh;
  ASSERT_TRUE(Smooth(expected, Params("taubin", 400)).ok());
  const std::string draco = *EncodeDraco(mesh);
  auto stub = v1::MeshSmoother::NewStub(server->InProcessChannel());
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(120));
  std::promise<void> started;
  std::atomic<bool> signalled{false};
  std::atomic<std::chrono::steady_clock::time_point> delivered{};
  auto short_job = std::async(std::launch::async, [&] {
    auto out = CallSmooth(*stub, ctx, spec, draco, [&](const v1::Progress&) {
      if (!signalled.exchange(true)) started.set_value();
    });
    delivered.store(std::chrono::steady_clock::now());
    return out;
  });
  ASSERT_EQ(started.get_future().wait_for(std::chrono::seconds(60)), std::future_status::ready);

  const auto t0 = std::chrono::steady_clock::now();
  const int cut = server->Shutdown();
  const double shutdown_seconds = SecondsSince(t0);
  absl::StatusOr<SmoothOutcome> out = short_job.get();
  const double delivered_seconds = std::chrono::duration<double>(delivered.load() - t0).count();
  std::printf("the running job delivered %.3f s into the shutdown; shutdown took %.3f s (grace 6 s)\n",
              delivered_seconds, shutdown_seconds);

  ASSERT_TRUE(out.ok()) << out.status();
  EXPECT_GT(delivered_seconds, 0.0) << "the job ended before the shutdown began: nothing was let finish";
  EXPECT_LT(delivered_seconds, o.grace_seconds);
  EXPECT_EQ(out->summary.parameters().iterations_run(), 400u);
  absl::StatusOr<Mesh> got = DecodeDraco(out->result);
  ASSERT_TRUE(got.ok()) << got.status();
  ASSERT_EQ(got->positions.size(), expected.positions.size());
  for (size_t i = 0; i < expected.positions.size(); ++i) {
    ASSERT_EQ(got->positions[i], RoundToFloat(expected.positions[i])) << "vertex " << i;
  }

  EXPECT_EQ(cut, 1);
  ExpectStatus(long_job.running.get().status(), absl::StatusCode::kUnavailable, "grace");
  EXPECT_GE(shutdown_seconds, o.grace_seconds * 0.95);
  EXPECT_LT(shutdown_seconds, o.grace_seconds + 2.0);
}

// SIGTERM's order: a queued job ends at once with UNAVAILABLE (its client may send it to another
// replica), the running one keeps the grace, then ends; Shutdown returns soon after the grace.
TEST(ServiceTest, ShutdownEndsQueuedJobsAtOnceAndRunningOnesAfterTheGrace) {
  ServerOptions o;
  o.grace_seconds = 1.0;
  BusyServer busy(o);
  const RunningLongJob& long_job = busy.long_job;
  grpc::ClientContext b;
  std::atomic<std::chrono::steady_clock::time_point> queued_ended{};
  auto queued = std::async(std::launch::async, [&] {
    auto out = CallSmooth(*long_job.stub, b, long_job.spec, long_job.draco);
    queued_ended.store(std::chrono::steady_clock::now());
    return out;
  });
  WaitForQueuedJobs(*busy.server, 1);
  ASSERT_EQ(busy.server->service().queued_jobs(), 1);
  const auto t0 = std::chrono::steady_clock::now();
  busy.server->Shutdown();
  const double shutdown_seconds = SecondsSince(t0);
  const absl::Status q = queued.get().status();
  const double queued_seconds = std::chrono::duration<double>(queued_ended.load() - t0).count();
  std::printf("shutdown took %.3f s (grace 1 s); the queued job ended %.3f s after it began\n", shutdown_seconds,
              queued_seconds);
  EXPECT_GE(shutdown_seconds, 0.95);
  EXPECT_LT(shutdown_seconds, 2.0);
  ExpectStatus(q, absl::StatusCode::kUnavailable, "did not start");
  EXPECT_LT(queued_seconds, 0.5);
  ExpectStatus(busy.long_job.running.get().status(), absl::StatusCode::kUnavailable, "grace");
}

// --max-queue-wait: a job that finds no worker in time is refused with RESOURCE_EXHAUSTED (the
// CLI retries it, elsewhere where it can) instead of waiting behind a long job.
TEST(ServiceTest, JobsWaitingLongerThanMaxQueueWaitAreRefused) {
  ServerOptions o;
  o.max_queue_wait_seconds = 0.3;
  BusyServer busy(o);
  const auto t0 = std::chrono::steady_clock::now();
  const absl::Status w =
      Call(busy.server->InProcessChannel(), Spec("laplacian", 1), *EncodeDraco(Icosphere(2))).status();
  const double waited = SecondsSince(t0);
  std::printf("refused after %.3f s (--max-queue-wait 0.3 s)\n", waited);
  ExpectStatus(w, absl::StatusCode::kResourceExhausted, "--max-queue-wait");
  EXPECT_GE(waited, 0.3);
  EXPECT_LT(waited, 1.5);
  EXPECT_EQ(busy.server->service().queued_jobs(), 0);  // the pool only holds a cancelled task, if any
  busy.long_job.ctx.TryCancel();
  EXPECT_EQ(busy.long_job.running.get().status().code(), absl::StatusCode::kCancelled);
}

// Draco's own bitstreams (0.9-2.2, Edgebreaker and sequential, attributes, non-manifold)
// through the service: attributes intact, no crack at seams; point clouds refused.
TEST(ServiceTest, DracosOwnFilesKeepAttributesAndSeams) {
  MESHSMOOTH_REQUIRE_SHARED("draco");
  auto server = StartServer();
  int meshes = 0, clouds = 0;
  for (const auto& entry : std::filesystem::directory_iterator(SharedData("draco"))) {
    if (entry.path().extension() != ".drc") continue;
    const std::string name = entry.path().filename().string();
    SCOPED_TRACE(name);
    absl::StatusOr<std::string> read = ReadFileBytes(entry.path().string());
    ASSERT_TRUE(read.ok()) << read.status();
    const std::string& bytes = *read;
    draco::DecoderBuffer buf;
    buf.Init(bytes.data(), bytes.size());
    const bool is_cloud = draco::Decoder::GetEncodedGeometryType(&buf).value() == draco::POINT_CLOUD;
    // Laplacian: stable on every file (car.drc's coarse CAD parts make the explicit curvature
    // flows diverge at their default step, which is the flow's business, not the codec's).
    absl::StatusOr<SmoothOutcome> out = Call(server->InProcessChannel(), Spec("laplacian", 3), bytes);
    if (is_cloud) {
      ++clouds;
      ASSERT_FALSE(out.ok());
      EXPECT_EQ(out.status().code(), absl::StatusCode::kInvalidArgument);
      EXPECT_NE(out.status().message().find("point cloud"), std::string::npos) << out.status();
      continue;
    }
    ++meshes;
    ASSERT_TRUE(out.ok()) << out.status();
    draco::DecoderBuffer in_buf, out_buf;
    in_buf.Init(bytes.data(), bytes.size());
    out_buf.Init(out->result.data(), out->result.size());
    draco::Decoder decoder;
    auto before = decoder.DecodeMeshFromBuffer(&in_buf);
    auto after = decoder.DecodeMeshFromBuffer(&out_buf);
    ASSERT_TRUE(before.ok() && after.ok());
    const draco::Mesh &a = *before.value(), &b = *after.value();
    ASSERT_EQ(a.num_points(), b.num_points());
    ASSERT_EQ(a.num_faces(), b.num_faces());
    ASSERT_EQ(a.num_attributes(), b.num_attributes());
    for (int i = 0; i < a.num_attributes(); ++i) {
      const draco::PointAttribute *pa = a.attribute(i), *pb = b.attribute(i);
      ASSERT_EQ(pa->attribute_type(), pb->attribute_type());
      ASSERT_EQ(pa->num_components(), pb->num_components());
      if (pa->attribute_type() == draco::GeometryAttribute::POSITION ||
          pa->attribute_type() == draco::GeometryAttribute::NORMAL) {
        continue;
      }
      // Every other attribute: the same value at every point.
      for (uint32_t p = 0; p < a.num_points(); ++p) {
        std::array<double, 4> va{}, vb{};
        pa->ConvertValue<double>(pa->mapped_index(draco::PointIndex(p)), pa->num_components(), va.data());
        pb->ConvertValue<double>(pb->mapped_index(draco::PointIndex(p)), pb->num_components(), vb.data());
        ASSERT_EQ(va, vb) << draco::GeometryAttribute::TypeToString(pa->attribute_type()) << " point " << p;
      }
    }
    // Normals are recomputed from the smoothed positions: each normal value of the upload is
    // the normalised sum of the area-weighted normals of the faces of the points that use it
    // (grouped by the upload's normal values: the re-encoded file may merge equal values).
    const draco::PointAttribute* na = a.GetNamedAttribute(draco::GeometryAttribute::NORMAL);
    if (const draco::PointAttribute* nb = b.GetNamedAttribute(draco::GeometryAttribute::NORMAL); nb && na) {
      const draco::PointAttribute* pb = b.GetNamedAttribute(draco::GeometryAttribute::POSITION);
      auto get = [](const draco::PointAttribute* att, draco::PointIndex p) {
        std::array<double, 3> v{};
        att->ConvertValue<double>(att->mapped_index(p), 3, v.data());
        return Vec3{v[0], v[1], v[2]};
      };
      std::map<uint32_t, Vec3> sums;
      for (uint32_t f = 0; f < b.num_faces(); ++f) {
        const draco::Mesh::Face& face = b.face(draco::FaceIndex(f));
        const Vec3 fa = get(pb, face[0]), fb = get(pb, face[1]), fc = get(pb, face[2]);
        for (int k = 0; k < 3; ++k) sums[na->mapped_index(face[k]).value()] += Cross(fb - fa, fc - fa);
      }
      for (uint32_t p = 0; p < b.num_points(); ++p) {
        const Vec3 sum = sums[na->mapped_index(draco::PointIndex(p)).value()];
        if (!(Norm(sum) > 1e-12)) continue;
        const Vec3 expected = sum * (1.0 / Norm(sum)), got = get(nb, draco::PointIndex(p));
        ASSERT_LT(Norm(got - expected), 1e-4) << "normal of point " << p;
      }
    }
    // Seams: points that shared a position still do (no crack); positions stay finite.
    const draco::PointAttribute *pos_a = a.GetNamedAttribute(draco::GeometryAttribute::POSITION),
                                *pos_b = b.GetNamedAttribute(draco::GeometryAttribute::POSITION);
    std::map<std::array<double, 3>, std::array<double, 3>> moved;
    int seams = 0;
    for (uint32_t p = 0; p < a.num_points(); ++p) {
      std::array<double, 3> qa{}, qb{};
      pos_a->ConvertValue<double>(pos_a->mapped_index(draco::PointIndex(p)), 3, qa.data());
      pos_b->ConvertValue<double>(pos_b->mapped_index(draco::PointIndex(p)), 3, qb.data());
      ASSERT_TRUE(std::isfinite(qb[0]) && std::isfinite(qb[1]) && std::isfinite(qb[2]));
      auto [it, inserted] = moved.emplace(qa, qb);
      if (!inserted) {
        ++seams;
        ASSERT_EQ(it->second, qb) << "crack at point " << p;
      }
    }
    if (name == "cube_att.drc") {
      EXPECT_GT(seams, 0);
      EXPECT_EQ(out->accepted.input().seam_points(), 16);  // 24 points, 8 corners
    }
  }
  EXPECT_GE(meshes, 20);
  EXPECT_EQ(clouds, 4);
}

// Ridges and ravines (the paper's Section 5) through the service.

// The test shapes: a noisy icosphere (closed: every vertex classified) and a noisy cosine
// height field (open: crests are ridges, troughs ravines, boundary vertices unclassified).
std::vector<std::pair<std::string, Mesh>> FeatureShapes() {
  Mesh wave = CosineHeightField(0.5, 2, 16, 14);
  AddUniformNoise(wave, 0.1, 7);
  return {{"noisy icosphere(3)", FloatMesh(NoisySphere(3))}, {"noisy cosine field", FloatMesh(std::move(wave))}};
}

v1::JobSpec FeatureSpec(uint32_t iterations, double min_abs_curvature) {
  v1::JobSpec spec = Spec("median", iterations);
  spec.mutable_features()->set_enabled(true);
  spec.mutable_features()->set_min_abs_curvature(min_abs_curvature);
  return spec;
}

// Ids of the attributes of a Draco mesh whose metadata entry "name" is `name`.
std::vector<int> AttributesNamed(const draco::Mesh& dm, const std::string& name) {
  std::vector<int> ids;
  for (int32_t i = 0; i < dm.num_attributes(); ++i) {
    const draco::AttributeMetadata* md = dm.GetAttributeMetadataByAttributeId(i);
    std::string value;
    if (md != nullptr && md->GetEntryString("name", &value) && value == name) ids.push_back(i);
  }
  return ids;
}

// "id:unique_id:type:name ..." of every attribute, for failure messages.
std::string DescribeAttributes(const draco::Mesh& dm) {
  std::string out;
  for (int32_t i = 0; i < dm.num_attributes(); ++i) {
    const draco::AttributeMetadata* md = dm.GetAttributeMetadataByAttributeId(i);
    std::string name = "-";
    if (md != nullptr) md->GetEntryString("name", &name);
    out += std::to_string(i) + ":" + std::to_string(dm.attribute(i)->unique_id()) + ":" +
           draco::GeometryAttribute::TypeToString(dm.attribute(i)->attribute_type()) + ":" + name + " ";
  }
  return out;
}

std::unique_ptr<draco::Mesh> DecodeDracoMesh(const std::string& bytes) {
  draco::DecoderBuffer buf;
  buf.Init(bytes.data(), bytes.size());
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&buf);
  EXPECT_TRUE(decoded.ok()) << decoded.status().error_msg_string();
  return decoded.ok() ? std::move(decoded).value() : nullptr;
}

// The result's three attributes and the summary's counts equal DetectFeatures() on the core's
// own smoothing of the same input, vertex for vertex (the service is bit-identical to the core).
void ExpectFeaturesEqualTheCore(const absl::StatusOr<SmoothOutcome>& out, const Mesh& input, int iterations,
                                double min_abs_curvature, Features* core_out = nullptr) {
  ASSERT_TRUE(out.ok()) << out.status();
  Mesh expected = input;
  ASSERT_TRUE(Smooth(expected, Params("median", iterations)).ok());
  FeatureOptions options;
  options.min_abs_curvature = min_abs_curvature;
  const Features core = DetectFeatures(expected, BuildTopology(expected), options);
  const size_t n = expected.positions.size();
  ASSERT_EQ(core.labels.size(), n);
  int64_t classified = 0;
  for (uint8_t v : core.curvature.valid) classified += v != 0;

  ASSERT_TRUE(out->summary.has_features());
  const v1::FeatureCounts& counts = out->summary.features();
  EXPECT_EQ(counts.ridge_vertices(), core.ridges);
  EXPECT_EQ(counts.ravine_vertices(), core.ravines);
  EXPECT_EQ(counts.classified_vertices(), classified);
  EXPECT_GE(counts.detect_seconds(), 0.0);

  absl::StatusOr<Mesh> got = DecodeDraco(out->result);
  ASSERT_TRUE(got.ok()) << got.status();
  ASSERT_EQ(got->positions.size(), n);
  for (size_t i = 0; i < n; ++i) ASSERT_EQ(got->positions[i], RoundToFloat(expected.positions[i])) << "vertex " << i;

  absl::StatusOr<std::vector<float>> labels = DecodeDracoAttribute(out->result, kFeatureLabelAttribute);
  absl::StatusOr<std::vector<float>> kmax = DecodeDracoAttribute(out->result, kKmaxAttribute);
  absl::StatusOr<std::vector<float>> kmin = DecodeDracoAttribute(out->result, kKminAttribute);
  ASSERT_TRUE(labels.ok()) << labels.status();
  ASSERT_TRUE(kmax.ok()) << kmax.status();
  ASSERT_TRUE(kmin.ok()) << kmin.status();
  ASSERT_EQ(labels->size(), n);
  ASSERT_EQ(kmax->size(), n);
  ASSERT_EQ(kmin->size(), n);
  int64_t ridges = 0, ravines = 0;
  for (size_t i = 0; i < n; ++i) {
    ASSERT_EQ((*labels)[i], static_cast<float>(core.labels[i])) << "label of vertex " << i;
    ASSERT_EQ((*kmax)[i], static_cast<float>(core.curvature.kmax[i])) << "kmax of vertex " << i;
    ASSERT_EQ((*kmin)[i], static_cast<float>(core.curvature.kmin[i])) << "kmin of vertex " << i;
    ridges += (*labels)[i] == 1.0f;
    ravines += (*labels)[i] == 2.0f;
  }
  EXPECT_EQ(ridges, counts.ridge_vertices());
  EXPECT_EQ(ravines, counts.ravine_vertices());
  EXPECT_EQ(ridges + ravines + std::count(labels->begin(), labels->end(), 0.0f), static_cast<int64_t>(n))
      << "every label is 0, 1 or 2";

  // The attribute types of the contract: uint8 labels, float32 curvatures, one component each.
  std::unique_ptr<draco::Mesh> dm = DecodeDracoMesh(out->result);
  ASSERT_TRUE(dm);
  for (const auto& [name, type] : {std::pair<std::string, draco::DataType>{kFeatureLabelAttribute, draco::DT_UINT8},
                                   {kKmaxAttribute, draco::DT_FLOAT32},
                                   {kKminAttribute, draco::DT_FLOAT32}}) {
    const std::vector<int> ids = AttributesNamed(*dm, name);
    ASSERT_EQ(ids.size(), 1u) << name;
    const draco::PointAttribute* a = dm->attribute(ids[0]);
    EXPECT_EQ(a->attribute_type(), draco::GeometryAttribute::GENERIC) << name;
    EXPECT_EQ(a->data_type(), type) << name;
    EXPECT_EQ(a->num_components(), 1) << name;
  }
  if (core_out != nullptr) *core_out = core;
}

TEST(ServiceFeatureTest, CountsAndAttributesEqualTheCore) {
  auto server = StartServer();
  ASSERT_TRUE(server);
  int64_t total_ridges = 0, total_ravines = 0;
  for (const auto& [name, mesh] : FeatureShapes()) {
    SCOPED_TRACE(name);
    const std::string draco = *EncodeDraco(mesh);
    Features unthresholded;
    {
      SCOPED_TRACE("min_abs_curvature 0");
      ExpectFeaturesEqualTheCore(Call(server->InProcessChannel(), FeatureSpec(10, 0.0), draco), mesh, 10, 0.0,
                                 &unthresholded);
    }
    if (::testing::Test::HasFatalFailure()) return;
    total_ridges += unthresholded.ridges;
    total_ravines += unthresholded.ravines;
    if (name == "noisy icosphere(3)") {
      int64_t valid = 0;
      for (uint8_t v : unthresholded.curvature.valid) valid += v != 0;
      EXPECT_EQ(valid, mesh.num_vertices()) << "every vertex of a closed, smooth sphere is classified";
    }
    // A threshold between the smallest and largest |kappa| of the features keeps only some.
    std::vector<double> kappas;
    for (size_t i = 0; i < unthresholded.labels.size(); ++i) {
      if (unthresholded.labels[i] == 1) kappas.push_back(unthresholded.curvature.kmax[i]);
      if (unthresholded.labels[i] == 2) kappas.push_back(-unthresholded.curvature.kmin[i]);
    }
    ASSERT_GE(kappas.size(), 2u);
    std::sort(kappas.begin(), kappas.end());
    const double threshold = kappas[kappas.size() / 2];
    Features thresholded;
    {
      SCOPED_TRACE("min_abs_curvature " + std::to_string(threshold));
      ExpectFeaturesEqualTheCore(Call(server->InProcessChannel(), FeatureSpec(10, threshold), draco), mesh, 10,
                                 threshold, &thresholded);
    }
    if (::testing::Test::HasFatalFailure()) return;
    EXPECT_LT(thresholded.ridges + thresholded.ravines, unthresholded.ridges + unthresholded.ravines);
    EXPECT_GT(thresholded.ridges + thresholded.ravines, 0);
  }
  // The shapes have both kinds, so the comparison above is not one of empty label sets.
  EXPECT_GT(total_ridges, 0);
  EXPECT_GT(total_ravines, 0);
}

TEST(ServiceFeatureTest, WithoutFeaturesNoCountsAndNoAttributes) {
  auto server = StartServer();
  ASSERT_TRUE(server);
  const Mesh mesh = FeatureShapes()[0].second;
  const std::string draco = *EncodeDraco(mesh);
  v1::JobSpec disabled = Spec("median", 5);
  disabled.mutable_features()->set_enabled(false);  // present but off
  disabled.mutable_features()->set_min_abs_curvature(0.5);
  for (const v1::JobSpec& spec : {Spec("median", 5), disabled}) {
    absl::StatusOr<SmoothOutcome> out = Call(server->InProcessChannel(), spec, draco);
    ASSERT_TRUE(out.ok()) << out.status();
    EXPECT_FALSE(out->summary.has_features());
    for (const char* name : {kFeatureLabelAttribute, kKmaxAttribute, kKminAttribute}) {
      const absl::Status s = DecodeDracoAttribute(out->result, name).status();
      EXPECT_EQ(s.code(), absl::StatusCode::kNotFound) << name << ": " << s;
    }
    std::unique_ptr<draco::Mesh> dm = DecodeDracoMesh(out->result);
    ASSERT_TRUE(dm);
    EXPECT_EQ(dm->num_attributes(), 1) << "positions only";
  }
}

TEST(ServiceFeatureTest, BadMinAbsCurvatureIsRefused) {
  auto server = StartServer();
  ASSERT_TRUE(server);
  const std::string draco = *EncodeDraco(Icosphere(2));
  for (double bad : {-0.5, -std::numeric_limits<double>::min(), std::numeric_limits<double>::quiet_NaN(),
                     std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()}) {
    SCOPED_TRACE(bad);
    const absl::Status s = Call(server->InProcessChannel(), FeatureSpec(3, bad), draco).status();
    ExpectStatus(s, absl::StatusCode::kInvalidArgument, "features.min_abs_curvature");
  }
  // Valid thresholds (0 = none, positive) go through.
  for (double ok : {0.0, 2.5}) {
    EXPECT_TRUE(Call(server->InProcessChannel(), FeatureSpec(3, ok), draco).ok()) << ok;
  }
}

// A result that already carries the attributes, smoothed again with features: the attributes
// are replaced (one of each name, the new values), not added a second time.
TEST(ServiceFeatureTest, ResmoothingReplacesTheFeatureAttributes) {
  auto server = StartServer();
  ASSERT_TRUE(server);
  const Mesh mesh = FeatureShapes()[1].second;
  absl::StatusOr<SmoothOutcome> first = Call(server->InProcessChannel(), FeatureSpec(5, 0.0), *EncodeDraco(mesh));
  ASSERT_TRUE(first.ok()) << first.status();
  absl::StatusOr<SmoothOutcome> second = Call(server->InProcessChannel(), FeatureSpec(5, 0.0), first->result);
  ASSERT_TRUE(second.ok()) << second.status();
  std::unique_ptr<draco::Mesh> a = DecodeDracoMesh(first->result), b = DecodeDracoMesh(second->result);
  ASSERT_TRUE(a && b);
  EXPECT_EQ(a->num_attributes(), 4);  // positions and the three
  EXPECT_EQ(b->num_attributes(), a->num_attributes());
  for (const char* name : {kFeatureLabelAttribute, kKmaxAttribute, kKminAttribute}) {
    EXPECT_EQ(AttributesNamed(*b, name).size(), 1u)
        << name << "; first result: " << DescribeAttributes(*a) << "; second: " << DescribeAttributes(*b);
  }
  // The values are those of the second smoothing: the core's median on the first result.
  absl::StatusOr<Mesh> first_mesh = DecodeDraco(first->result);
  ASSERT_TRUE(first_mesh.ok()) << first_mesh.status();
  first_mesh->colors.clear();
  ExpectFeaturesEqualTheCore(second, *first_mesh, 5, 0.0);
  // And a third round keeps it at one of each.
  absl::StatusOr<SmoothOutcome> third = Call(server->InProcessChannel(), FeatureSpec(2, 0.0), second->result);
  ASSERT_TRUE(third.ok()) << third.status();
  std::unique_ptr<draco::Mesh> c = DecodeDracoMesh(third->result);
  ASSERT_TRUE(c);
  EXPECT_EQ(c->num_attributes(), 4);
  EXPECT_EQ(AttributesNamed(*c, kKmaxAttribute).size(), 1u);
}

}  // namespace
}  // namespace meshsmooth

namespace meshsmooth {
namespace {

// Server limits: concurrent calls, job time, and the client's own deadline.
TEST(ServiceLimitsTest, ConcurrentCallsJobSecondsAndClientDeadline) {
  ServerOptions o;
  o.workers = 2;
  o.max_concurrent_streams = 1;
  o.max_job_seconds = 0.5;
  auto server = StartServer(o);
  RunningLongJob a(server->InProcessChannel());
  const absl::Status second = Call(server->InProcessChannel(), Spec("median", 2), *EncodeDraco(Icosphere(2))).status();
  ExpectStatus(second, absl::StatusCode::kResourceExhausted, "concurrent");
  const absl::Status timed_out = a.running.get().status();  // A runs into --max-job-seconds
  ExpectStatus(timed_out, absl::StatusCode::kDeadlineExceeded, "time limit");

  // The client's deadline cancels the job on the server, and the worker is free again.
  ServerOptions p;
  p.workers = 1;
  auto s2 = StartServer(p);
  auto stub2 = v1::MeshSmoother::NewStub(s2->InProcessChannel());
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(2));
  const absl::Status late = CallSmooth(*stub2, ctx, a.spec, a.draco).status();
  EXPECT_EQ(late.code(), absl::StatusCode::kDeadlineExceeded) << late;
  absl::StatusOr<SmoothOutcome> next = Call(s2->InProcessChannel(), Spec("laplacian", 3), *EncodeDraco(Icosphere(2)));
  ASSERT_TRUE(next.ok()) << next.status();
  EXPECT_LT(next->summary.timings().queue_seconds(), 1.0);
}

// A port another server listens on is refused, naming the cause, rather than shared: with
// gRPC's default SO_REUSEPORT the second server would start and take part of the traffic.
TEST(ServiceTest, BusyPortIsRefusedNotShared) {
  auto first = StartServer({}, /*listen=*/true);
  ASSERT_TRUE(first);
  ServerOptions o;
  o.log_jobs = false;
  o.listen = "127.0.0.1:" + std::to_string(first->port());
  const absl::Status s = Server::Start(o).status();
  ExpectStatus(s, absl::StatusCode::kFailedPrecondition, "address in use");
  EXPECT_NE(s.message().find(o.listen), std::string::npos) << s;
  // The first one serves on.
  auto tcp = grpc::CreateChannel(o.listen, grpc::InsecureChannelCredentials());
  EXPECT_TRUE(Call(tcp, Spec("laplacian", 2), *EncodeDraco(Icosphere(2))).ok());
}

// TLS with a self-signed certificate made at test time by the openssl CLI.
TEST(ServiceTlsTest, TlsServerAcceptsTlsClientsOnly) {
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / "meshsmooth_tls";
  std::filesystem::create_directories(dir);
  const std::string key = (dir / "key.pem").string(), cert = (dir / "cert.pem").string();
  const std::string cmd =
      "openssl req -x509 -newkey rsa:2048 -nodes -subj /CN=localhost -addext "
      "subjectAltName=DNS:localhost -days 1 -keyout " +
      key + " -out " + cert + " >/dev/null 2>&1";
  if (std::system(cmd.c_str()) != 0) GTEST_SKIP() << "openssl CLI not available";
  ServerOptions o;
  o.tls_cert_file = cert;
  o.tls_key_file = key;
  auto server = StartServer(o, /*listen=*/true);
  ASSERT_TRUE(server);
  const std::string target = "localhost:" + std::to_string(server->port());
  grpc::SslCredentialsOptions ssl;
  absl::StatusOr<std::string> pem = ReadFileBytes(cert);
  ASSERT_TRUE(pem.ok()) << pem.status();
  ssl.pem_root_certs = *pem;
  auto tls = grpc::CreateChannel(target, grpc::SslCredentials(ssl));
  absl::StatusOr<SmoothOutcome> out = Call(tls, Spec("median", 2), *EncodeDraco(Icosphere(2)));
  EXPECT_TRUE(out.ok()) << out.status();
  auto plain = grpc::CreateChannel(target, grpc::InsecureChannelCredentials());
  auto stub = v1::MeshSmoother::NewStub(plain);
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(5));
  v1::ListFlowsResponse flows;
  EXPECT_FALSE(stub->ListFlows(&ctx, {}, &flows).ok());

  ServerOptions half;
  half.tls_cert_file = cert;
  half.listen = "127.0.0.1:0";
  const absl::Status s = Server::Start(half).status();
  ExpectStatus(s, absl::StatusCode::kFailedPrecondition, "--tls-key");
}

}  // namespace
}  // namespace meshsmooth
