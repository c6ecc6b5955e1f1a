// Hostile requests through the service: each gets a clear status and leaves the
// server serving (docs/reliability.md lists the classes and these tests).
#include <atomic>
#include <chrono>
#include <climits>
#include <fstream>
#include <functional>
#include <future>
#include <memory>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include "core/io/draco_codec.h"
#include "core/shapes/parametric.h"
#include "gtest/gtest.h"
#include "server/admission.h"
#include "tests/hostile_inputs.h"
#include "tests/service/service_fixtures.h"

namespace meshsmooth {
namespace {

using namespace meshsmooth::testing;

v1::JobSpec Output(v1::JobSpec spec, uint32_t bits, bool edgebreaker) {
  spec.mutable_output()->set_quantization_bits(bits);
  spec.mutable_output()->set_edgebreaker(edgebreaker);
  return spec;
}

// Uploads that would crash Draco's encoder or index past a buffer: refused with
// INVALID_ARGUMENT, and the server still serves.
TEST(HardeningTest, HostileDracoUploadsAreRefusedAndTheServerServesOn) {
  auto server = StartServer();
  auto channel = server->InProcessChannel();

  ExpectStatus(Call(channel, Output(Spec("mcf", 3), 12, true), RawDraco(TorusWithIndexPastThePoints())).status(),
               absl::StatusCode::kInvalidArgument, "face 5 refers to point 65535, but the mesh has 1160 points");
  ExpectStatus(Call(channel, Output(Spec("median", 3), 0, true), RawDraco(TwoRateTorus(20), 2)).status(),
               absl::StatusCode::kInvalidArgument, "2 POSITION attributes");
  Mesh extreme = TwoRateTorus(20);
  extreme.positions[7].x = 3.4e38;
  ExpectStatus(Call(channel, Output(Spec("median", 3), 22, false), RawDraco(extreme)).status(),
               absl::StatusCode::kInvalidArgument, "point 7 has a coordinate of 3.4e+38");
  Mesh isolated = Icosphere(2);
  isolated.positions.push_back({3, 3, 3});
  ExpectStatus(Call(channel, Output(Spec("median", 3), 11, true), *EncodeDraco(isolated)).status(),
               absl::StatusCode::kInvalidArgument, "Edgebreaker would drop 1 vertex");
  // 1.3 KB declaring 235 million faces: Draco's decoder would allocate 2.8 GB for them.
  ExpectStatus(Call(channel, Spec("median", 3), EdgebreakerHead(true, 1000, 235'472'908)).status(),
               absl::StatusCode::kResourceExhausted, "declares 235472908 faces");

  absl::StatusOr<SmoothOutcome> ok = Call(channel, Output(Spec("median", 3), 11, true), *EncodeDraco(Icosphere(2)));
  ASSERT_TRUE(ok.ok()) << ok.status();
  absl::StatusOr<Mesh> back = DecodeDraco(ok->result);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->num_vertices(), Icosphere(2).num_vertices());
}

// Quantization costs ~2^(bits + 2) bytes in Draco's encoder: above 24 bits the spec is refused
// before any upload byte is read.
TEST(HardeningTest, QuantizationAboveTheCapIsRefusedWithTheSpec) {
  auto server = StartServer();
  for (uint32_t bits : {25u, 27u, 30u}) {
    ExpectStatus(Call(server->InProcessChannel(), Output(Spec("median", 3), bits, false), "not even Draco").status(),
                 absl::StatusCode::kInvalidArgument, "output.quantization_bits must be 0 (lossless) or 1..24");
  }
  EXPECT_TRUE(Call(server->InProcessChannel(), Output(Spec("median", 3), 24, false), *EncodeDraco(Icosphere(2))).ok());
}

// A 2.2 MB fan whose centre has valence 120,000 validates in milliseconds (a check quadratic in
// the valence would hold a worker ~10 s); the steps that stay quadratic in a vertex's valence
// (eq. (14)'s second rings, Draco's Edgebreaker encoder) are refused for it, at once.
TEST(HardeningTest, HighValenceFanCompletesOrIsRefusedFast) {
  auto server = StartServer();
  const std::string fan = *EncodeDraco(Fan(120000));
  ASSERT_GT(fan.size(), 2'000'000u);
  absl::StatusOr<SmoothOutcome> out = Call(server->InProcessChannel(), Spec("median", 3), fan);
  ASSERT_TRUE(out.ok()) << out.status();
  EXPECT_LT(out->summary.timings().decode_seconds(), 2.0);  // quadratic: ~10 s; generous
  EXPECT_EQ(out->summary.parameters().iterations_run(), 3u);

  v1::JobSpec ring2 = Spec("median", 3);
  ring2.mutable_adaptive()->set_mode(v1::ADAPTIVE_MODE_RING2);
  for (const v1::JobSpec& spec : {Output(Spec("median", 3), 0, true), ring2}) {
    const auto t0 = std::chrono::steady_clock::now();
    const absl::Status s = Call(server->InProcessChannel(), spec, fan).status();
    ExpectStatus(s, absl::StatusCode::kResourceExhausted, "a vertex of valence 120000");
    EXPECT_LT(SecondsSince(t0), 2.0) << s;
  }
  // Both are fine on an ordinary mesh.
  EXPECT_TRUE(Call(server->InProcessChannel(), ring2, *EncodeDraco(Icosphere(3))).ok());
}

// --max-job-seconds covers the job's whole time on its worker, not only the smoothing: a job
// past it stops in whichever step it is in (here the first, decoding), with DEADLINE_EXCEEDED
// naming that step.
TEST(HardeningTest, TimeLimitCoversEveryStepOfTheJob) {
  server::ServerOptions o;
  o.max_job_seconds = 1e-6;
  auto server = StartServer(o);
  const absl::Status s = Call(server->InProcessChannel(), Spec("median", 3), *EncodeDraco(Icosphere(6))).status();
  ExpectStatus(s, absl::StatusCode::kDeadlineExceeded, "time limit of 1e-06 s while decoding the upload");
}

// A job cancelled mid-smoothing logs the iterations it ran, not iterations=0/N.
TEST(HardeningTest, CancelledJobLogsTheIterationsItRan) {
  server::ServerOptions o;
  o.workers = 1;
  o.log_jobs = true;
  absl::StatusOr<std::unique_ptr<server::Server>> server = server::Server::Start(o, /*listen=*/false);
  ASSERT_TRUE(server.ok()) << server.status();
  auto stub = v1::MeshSmoother::NewStub((*server)->InProcessChannel());
  LongJob long_job;
  ::testing::internal::CaptureStderr();
  grpc::ClientContext ctx;
  std::atomic<uint32_t> seen{0};
  auto call = std::async(std::launch::async, [&] {
    return CallSmooth(*stub, ctx, long_job.spec, long_job.draco,
                      [&](const v1::Progress& p) { seen.store(p.iteration()); });
  });
  for (int i = 0; i < 600 && seen.load() < 3; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  ctx.TryCancel();
  EXPECT_EQ(call.get().status().code(), absl::StatusCode::kCancelled);
  // The only worker takes the next job once the cancelled one has logged its line.
  EXPECT_TRUE(Call((*server)->InProcessChannel(), Spec("laplacian", 1), *EncodeDraco(Icosphere(1))).ok());
  const std::string log = ::testing::internal::GetCapturedStderr();
  std::smatch m;
  ASSERT_TRUE(std::regex_search(log, m, std::regex("iterations=(\\d+)/10000 status=CANCELLED"))) << log;
  EXPECT_GE(std::stoul(m[1]), seen.load()) << log;
  EXPECT_GE(seen.load(), 3u);
}

// Proto3 keeps enum numbers it does not know, which would run as the defaults. Each enum of the
// JobSpec refuses them with INVALID_ARGUMENT naming the field.
template <typename Enum>
void ExpectUnknownValuesRefused(const std::string& field, const std::function<void(v1::JobSpec&, Enum)>& set) {
  auto server = StartServer();
  const std::string sphere = *EncodeDraco(Icosphere(2));
  for (int32_t value : {3, 4, 99, -1, INT32_MIN, INT32_MAX}) {
    v1::JobSpec spec = Spec("laplacian", 2);
    set(spec, static_cast<Enum>(value));
    if (field == "adaptive.mode" && value == 3) continue;  // ADAPTIVE_MODE_RING2
    ExpectStatus(Call(server->InProcessChannel(), spec, sphere).status(), absl::StatusCode::kInvalidArgument,
                 field + ": unknown value " + std::to_string(value));
  }
}

TEST(HardeningTest, UnknownWeightsAreRefused) {
  ExpectUnknownValuesRefused<v1::UmbrellaWeights>("weights",
                                                  [](v1::JobSpec& s, v1::UmbrellaWeights v) { s.set_weights(v); });
}

TEST(HardeningTest, UnknownBoundaryModeIsRefused) {
  ExpectUnknownValuesRefused<v1::BoundaryMode>("boundary",
                                               [](v1::JobSpec& s, v1::BoundaryMode v) { s.set_boundary(v); });
}

TEST(HardeningTest, UnknownAdaptiveModeIsRefused) {
  ExpectUnknownValuesRefused<v1::AdaptiveMode>(
      "adaptive.mode", [](v1::JobSpec& s, v1::AdaptiveMode v) { s.mutable_adaptive()->set_mode(v); });
}

// One rule for sizes: beyond one of this server's limits (a chunk, the upload, the vertices) is
// RESOURCE_EXHAUSTED, whoever checks it: a chunk between 1 MiB + 1 and gRPC's own receive limit
// (1 MiB + 64 KiB) as much as a larger one, which gRPC itself refuses.
TEST(HardeningTest, SizesBeyondTheLimitsAreResourceExhausted) {
  server::ServerOptions o;
  o.max_upload_bytes = 3 << 20;
  auto server = StartServer(o, /*listen=*/true);
  auto channel = grpc::CreateChannel("127.0.0.1:" + std::to_string(server->port()), grpc::InsecureChannelCredentials());
  v1::SmoothRequest spec, chunk;
  *spec.mutable_spec() = Spec("median", 3);
  for (int64_t size :
       {(int64_t{1} << 20) + 1, (int64_t{1} << 20) + (32 << 10), (int64_t{1} << 20) + (128 << 10), int64_t{3} << 20}) {
    chunk.set_mesh_chunk(std::string(static_cast<size_t>(size), 'x'));
    const grpc::Status g = RawCall(channel, {spec, chunk});
    EXPECT_EQ(g.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << size << ": " << g.error_message();
  }
  chunk.set_mesh_chunk(std::string(1 << 20, 'x'));  // at the limit: read, then refused as not Draco
  grpc::Status g = RawCall(channel, {spec, chunk});
  EXPECT_EQ(g.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << g.error_message();
  g = RawCall(channel, {spec, chunk, chunk, chunk, chunk});  // 4 MiB in chunks of 1 MiB
  EXPECT_EQ(g.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << g.error_message();
  EXPECT_NE(g.error_message().find("upload exceeds this server's limit of 3145728 bytes"), std::string::npos)
      << g.error_message();
}

// Streams that send a spec and then nothing would hold their call slot for ever, and with every
// slot taken everyone else would get "too many concurrent Smooth calls". An upload that stops
// sending for --upload-idle-seconds ends with DEADLINE_EXCEEDED, and its slot is free again.
TEST(HardeningTest, IdleUploadsAreEndedAndFreeTheirSlots) {
  server::ServerOptions o;
  o.max_concurrent_streams = 4;
  o.upload_idle_seconds = 0.5;
  auto server = StartServer(o);
  auto channel = server->InProcessChannel();
  std::vector<std::unique_ptr<OpenStream>> idle;
  for (int i = 0; i < 4; ++i) {
    idle.push_back(std::make_unique<OpenStream>(channel, std::chrono::seconds(20)));
    ASSERT_TRUE(idle.back()->Write(SpecMessage(Spec("median", 3))));
  }
  const auto t0 = std::chrono::steady_clock::now();
  ExpectStatus(Call(channel, Spec("median", 3), *EncodeDraco(Icosphere(2))).status(),
               absl::StatusCode::kResourceExhausted, "too many concurrent Smooth calls");
  for (auto& stream : idle) {
    const grpc::Status g = stream->Drain();
    EXPECT_EQ(g.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED) << g.error_message();
    EXPECT_NE(g.error_message().find("no message for 0.5 s"), std::string::npos) << g.error_message();
  }
  EXPECT_LT(SecondsSince(t0), 10.0);
  // The slots are free (once gRPC has let go of the ended calls, just after their status): a
  // real job goes through.
  absl::Status next = absl::ResourceExhaustedError("not tried");
  for (int i = 0; i < 100 && next.code() == absl::StatusCode::kResourceExhausted; ++i) {
    if (i > 0) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    next = Call(channel, Spec("median", 3), *EncodeDraco(Icosphere(2))).status();
  }
  EXPECT_TRUE(next.ok()) << next;
  // A slow upload that keeps sending is not idle. Its call may come before gRPC has let go of
  // the last one (the same wait as above): a call refused for that is opened again.
  std::unique_ptr<OpenStream> slow;
  for (int i = 0; i < 100 && slow == nullptr; ++i) {
    if (i > 0) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    auto stream = std::make_unique<OpenStream>(channel, std::chrono::seconds(20));
    if (stream->Write(SpecMessage(Spec("median", 3)))) {
      slow = std::move(stream);
      continue;
    }
    const grpc::Status refused = stream->Drain();
    ASSERT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << refused.error_message();
  }
  ASSERT_NE(slow, nullptr);
  const std::string sphere = *EncodeDraco(Icosphere(2));
  for (size_t at = 0; at < sphere.size(); at += sphere.size() / 4 + 1) {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    ASSERT_TRUE(slow->Write(ChunkMessage(sphere.substr(at, sphere.size() / 4 + 1))));
  }
  EXPECT_TRUE(slow->Finish().ok());
}

// Uploads in flight and queued jobs hold their bytes against --max-buffered-bytes; an upload
// whose next chunk would go beyond it is refused with RESOURCE_EXHAUSTED before the chunk is
// kept, and the bytes come back when a job starts (its upload is decoded and freed).
TEST(HardeningTest, UploadsBeyondTheMemoryBudgetAreRefused) {
  server::ServerOptions o;
  o.workers = 1;
  o.max_buffered_bytes = 5 << 20;
  auto server = StartServer(o);
  auto channel = server->InProcessChannel();
  const std::string mib(1 << 20, 'x');
  // A holds 4 MiB (buffers of 1, 2 and 4 MiB as it grows), still uploading.
  OpenStream a(channel, std::chrono::seconds(60));
  ASSERT_TRUE(a.Write(SpecMessage(Spec("median", 3))));
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(a.Write(ChunkMessage(mib)));
  for (int i = 0; i < 200 && server->service().buffered_bytes() < (4 << 20); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_EQ(server->service().buffered_bytes(), 4 << 20);
  // B's second MiB would go beyond 5 MiB.
  OpenStream b(channel, std::chrono::seconds(60));
  ASSERT_TRUE(b.Write(SpecMessage(Spec("median", 3))));
  b.Write(ChunkMessage(mib));
  b.Write(ChunkMessage(mib));
  const grpc::Status refused = b.Finish();
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << refused.error_message();
  EXPECT_NE(refused.error_message().find("memory budget"), std::string::npos) << refused.error_message();
  // A ends (its bytes are not Draco): everything is given back, and a job fits again.
  EXPECT_EQ(a.Finish().error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  for (int i = 0; i < 200 && server->service().buffered_bytes() > 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_EQ(server->service().buffered_bytes(), 0);

  // A queued job holds its upload until a worker takes it: the worker busy with a long job,
  // a queued 4 MiB upload leaves no room for a third.
  RunningLongJob long_job(channel);
  OpenStream queued(channel, std::chrono::seconds(60));
  ASSERT_TRUE(queued.Write(SpecMessage(Spec("median", 3))));
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(queued.Write(ChunkMessage(mib)));
  std::thread finisher([&] { EXPECT_EQ(queued.Finish().error_code(), grpc::StatusCode::INVALID_ARGUMENT); });
  WaitForQueuedJobs(*server, 1);
  ASSERT_EQ(server->service().queued_jobs(), 1);
  EXPECT_EQ(server->service().buffered_bytes(), 4 << 20);
  const absl::Status third = Call(channel, Spec("median", 3), mib + mib).status();
  ExpectStatus(third, absl::StatusCode::kResourceExhausted, "memory budget");
  long_job.ctx.TryCancel();
  EXPECT_EQ(long_job.running.get().status().code(), absl::StatusCode::kCancelled);
  finisher.join();
  for (int i = 0; i < 200 && server->service().buffered_bytes() > 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_EQ(server->service().buffered_bytes(), 0);
}

// The budget's default: a quarter of MemTotal, 4 GiB when /proc/meminfo cannot be read.
TEST(HardeningTest, DefaultBudgetIsAQuarterOfTheMachinesMemory) {
  const std::string path = ::testing::TempDir() + "/meminfo";
  std::ofstream(path) << "MemFree:         1000 kB\nMemTotal:       24684084 kB\nSwapTotal: 0 kB\n";
  EXPECT_EQ(server::DefaultBufferedBytes(path), int64_t{24684084} * 1024 / 4);
  EXPECT_EQ(server::DefaultBufferedBytes(path + ".absent"), int64_t{4} << 30);
}

}  // namespace
}  // namespace meshsmooth
