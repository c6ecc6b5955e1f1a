// Load and faults together: 32 concurrent clients on two workers, each sending a mix
// of valid jobs and hostile requests over loopback TCP. Every valid job must come back equal
// to the core's own Smooth() of the same input, every hostile one must end with its status,
// and at the end the server still serves and its memory stayed below the admission budget
// plus a fixed margin. Not timed: the assertions are on results, statuses and memory.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <fstream>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_join.h"
#include "core/io/draco_codec.h"
#include "core/shapes/parametric.h"
#include "gtest/gtest.h"
#include "tests/hostile_inputs.h"
#include "tests/service/service_fixtures.h"

namespace meshsmooth {
namespace {

using namespace meshsmooth::testing;

constexpr int kClients = 32;
constexpr int kRoundsPerClient = 6;
constexpr int64_t kBudgetBytes = 64 << 20;
// What the test process holds besides the admitted bytes: code, gRPC's buffers (at most one
// message of 1 MiB + 64 KiB per open call), the running jobs' meshes, the clients' inputs,
// results and expected meshes. Unrefused, a 27- to 30-bit quantization would take 0.5-3.7 GB.
constexpr int64_t kRssMarginBytes = 320 << 20;

// Peak resident memory of this process (VmHWM), in bytes; 0 when /proc cannot tell.
int64_t PeakRssBytes() {
  std::ifstream in("/proc/self/status");
  std::string key;
  int64_t kib = 0;
  while (in >> key) {
    if (key == "VmHWM:" && in >> kib) return kib * 1024;
  }
  return 0;
}

// "" when `s` has `code` and `words` in its message, else what went wrong.
std::string Expect(const absl::Status& s, absl::StatusCode code, const std::string& words) {
  if (s.code() == code && s.message().find(words) != std::string::npos) return "";
  return absl::StrCat("expected ", absl::StatusCodeToString(code), " with '", words, "', got ", s.ToString());
}

std::string Expect(const grpc::Status& g, absl::StatusCode code, const std::string& words) {
  return Expect(client::FromGrpc(g), code, words);
}

// The inputs, encoded once and shared by all clients (read only).
struct Inputs {
  std::string sphere = *EncodeDraco(FloatMesh(NoisySphere(3)));
  std::string long_job = *EncodeDraco(FloatMesh(NoisySphere(5)));
  std::string index_past_points = RawDraco(TorusWithIndexPastThePoints());
  std::string two_positions = RawDraco(TwoRateTorus(20), 2);
  std::string extreme = [] {
    Mesh m = TwoRateTorus(20);
    m.positions[7].x = 3.4e38;
    return RawDraco(m);
  }();
  std::string fan = *EncodeDraco(Fan(120000));
  std::string point_cloud = DracoPointCloud();
};

// A valid job: the service's result against the core's Smooth() of the same input, positions
// equal to the float32 of the core's (lossless) or within half a grid step of it (quantized). Retries
// while the server answers RESOURCE_EXHAUSTED (queue, calls or memory budget), as a client
// should; the count of retries is added to `retries`.
std::string ValidJob(std::shared_ptr<grpc::Channel> channel, const std::string& flow, int iterations, uint64_t seed,
                     uint32_t bits, std::atomic<int>& retries) {
  const Mesh input = FloatMesh(NoisySphere(3, 0.3, seed));
  Mesh expected = input;
  if (!Smooth(expected, Params(flow, iterations)).ok()) return "the core refused the valid job";
  v1::JobSpec spec = Spec(flow, static_cast<uint32_t>(iterations));
  spec.mutable_output()->set_quantization_bits(bits);
  absl::StatusOr<SmoothOutcome> out = absl::ResourceExhaustedError("not tried");
  for (int attempt = 0; attempt < 200 && out.status().code() == absl::StatusCode::kResourceExhausted; ++attempt) {
    if (attempt > 0) {
      retries.fetch_add(1);
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    out = Call(channel, spec, *EncodeDraco(input));
  }
  if (!out.ok()) return "valid job failed: " + out.status().ToString();
  absl::StatusOr<Mesh> got = DecodeDraco(out->result);
  if (!got.ok()) return "result does not decode: " + got.status().ToString();
  if (got->triangles != input.triangles) return "result faces differ";
  if (got->positions.size() != expected.positions.size()) return "result vertex count differs";
  BoundingBox box;
  for (const Vec3& p : expected.positions) box.Add(RoundToFloat(p));
  // Half a grid step, plus the float32 rounding of Draco's dequantized values.
  const double extent = box.max_extent();
  const double tolerance = bits == 0 ? 0.0 : extent / (std::pow(2.0, bits) - 1.0) * 0.5 + 1e-6 * extent;
  for (size_t v = 0; v < expected.positions.size(); ++v) {
    const Vec3 d = got->positions[v] - RoundToFloat(expected.positions[v]);
    if (std::max({std::abs(d.x), std::abs(d.y), std::abs(d.z)}) > tolerance) {
      return absl::StrCat("vertex ", v, " differs from the core's by ", Norm(d));
    }
  }
  return "";
}

TEST(LoadAndFaultTest, ThirtyTwoClientsMixValidAndHostileRequestsOnTwoWorkers) {
  server::ServerOptions o;
  o.workers = 2;
  o.threads_per_job = 1;
  o.max_upload_bytes = 4 << 20;
  o.max_buffered_bytes = kBudgetBytes;
  o.upload_idle_seconds = 1.0;
  auto server = StartServer(o, /*listen=*/true);
  ASSERT_TRUE(server);
  const std::string target = "127.0.0.1:" + std::to_string(server->port());
  const Inputs in;
  std::atomic<int> retries{0};

  using Case = std::function<std::string(std::shared_ptr<grpc::Channel>)>;
  const absl::StatusCode kInvalid = absl::StatusCode::kInvalidArgument;
  const absl::StatusCode kExhausted = absl::StatusCode::kResourceExhausted;
  std::vector<std::pair<std::string, Case>> cases;
  // Valid jobs, every flow, lossless and quantized.
  for (size_t f = 0; f < FlowNames().size(); ++f) {
    const std::string flow(FlowNames()[f]);
    cases.push_back({"valid " + flow,
                     [&, flow, f](auto ch) { return ValidJob(ch, flow, 10, 100 + f, f % 2 == 0 ? 0 : 12, retries); }});
  }
  // Hostile uploads and specs, each with its status.
  auto hostile = [&](const std::string& name, v1::JobSpec spec, const std::string* bytes, absl::StatusCode code,
                     const std::string& words) {
    cases.push_back({name, [&, spec, bytes, code, words](auto ch) {
                       return Expect(Call(ch, spec, *bytes).status(), code, words);
                     }});
  };
  auto with_output = [](v1::JobSpec spec, uint32_t bits, bool edgebreaker) {
    spec.mutable_output()->set_quantization_bits(bits);
    spec.mutable_output()->set_edgebreaker(edgebreaker);
    return spec;
  };
  static const std::string kGarbage = "DRACO this is not a mesh at all";
  const std::string truncated = in.sphere.substr(0, in.sphere.size() / 3);
  hostile("garbage", Spec("median", 3), &kGarbage, kInvalid, "Draco");
  hostile("truncated", Spec("median", 3), &truncated, kInvalid, "Draco");
  hostile("point cloud", Spec("median", 3), &in.point_cloud, kInvalid, "point cloud");
  hostile("index past the points", with_output(Spec("mcf", 3), 12, true), &in.index_past_points, kInvalid,
          "refers to point 65535");
  hostile("two positions", with_output(Spec("median", 3), 0, true), &in.two_positions, kInvalid,
          "2 POSITION attributes");
  hostile("extreme coordinate", with_output(Spec("median", 3), 22, false), &in.extreme, kInvalid,
          "has a coordinate of 3.4e+38");
  hostile("30-bit quantization", with_output(Spec("median", 3), 30, false), &in.sphere, kInvalid, "quantization_bits");
  v1::JobSpec bad_enum = Spec("laplacian", 3);
  bad_enum.set_weights(static_cast<v1::UmbrellaWeights>(99));
  hostile("unknown enum", bad_enum, &in.sphere, kInvalid, "weights: unknown value 99");
  v1::JobSpec ring2 = Spec("median", 3);
  ring2.mutable_adaptive()->set_mode(v1::ADAPTIVE_MODE_RING2);
  hostile("fan with second rings", ring2, &in.fan, kExhausted, "valence 120000");
  v1::JobSpec diverging = Spec("mcf", 200);
  diverging.set_step(10.0);
  hostile("diverging flow", diverging, &in.sphere, absl::StatusCode::kFailedPrecondition, "diverged");
  cases.push_back({"chunk above 1 MiB", [&](auto ch) {
                     return Expect(
                         RawCall(ch, {SpecMessage(Spec("median", 3)), ChunkMessage(std::string((1 << 20) + 1, 'x'))}),
                         kExhausted, "per chunk");
                   }});
  cases.push_back({"upload above the limit", [&](auto ch) {
                     std::vector<v1::SmoothRequest> messages = {SpecMessage(Spec("median", 3))};
                     for (int i = 0; i < 5; ++i) messages.push_back(ChunkMessage(std::string(1 << 20, 'x')));
                     // The memory budget may refuse it first while other uploads hold it.
                     const grpc::Status g = RawCall(ch, messages);
                     const bool budget = g.error_message().find("memory budget") != std::string::npos;
                     return Expect(g, kExhausted, budget ? "memory budget" : "upload exceeds this server's limit");
                   }});
  cases.push_back({"chunk before the spec", [&](auto ch) {
                     return Expect(RawCall(ch, {ChunkMessage(in.sphere)}), kInvalid, "first message must be a JobSpec");
                   }});
  cases.push_back({"idle upload", [&](auto ch) {
                     OpenStream idle(ch, std::chrono::seconds(30));
                     idle.Write(SpecMessage(Spec("median", 3)));
                     return Expect(idle.Drain(), absl::StatusCode::kDeadlineExceeded, "no message for 1 s");
                   }});
  cases.push_back({"cancelled mid-job", [&](auto ch) {
                     auto stub = v1::MeshSmoother::NewStub(ch);
                     grpc::ClientContext ctx;
                     const absl::Status s =
                         CallSmooth(*stub, ctx, Spec("median", 5000), in.long_job, [&ctx](const v1::Progress&) {
                           ctx.TryCancel();
                         }).status();
                     return Expect(s, absl::StatusCode::kCancelled, "");
                   }});
  cases.push_back({"client deadline", [&](auto ch) {
                     auto stub = v1::MeshSmoother::NewStub(ch);
                     grpc::ClientContext ctx;
                     ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::milliseconds(300));
                     return Expect(CallSmooth(*stub, ctx, Spec("median", 5000), in.long_job).status(),
                                   absl::StatusCode::kDeadlineExceeded, "");
                   }});

  // Each client has its own connection and runs its share of the cases, spread so that every
  // case runs several times and valid and hostile requests interleave.
  std::mutex mu;
  std::vector<std::string> failures;
  std::vector<int> runs(cases.size(), 0);
  std::vector<std::thread> clients;
  for (int c = 0; c < kClients; ++c) {
    clients.emplace_back([&, c] {
      grpc::ChannelArguments args;
      args.SetInt("meshsmooth.test.client", c);  // a connection of its own
      auto channel = grpc::CreateCustomChannel(target, grpc::InsecureChannelCredentials(), args);
      // Connected first: a fresh channel's first attempt can fail ("No such file or directory"
      // from 127.0.0.1 under load, as meshsmooth_load saw), which would fail every call of this
      // client without reaching the server; the cases are about the server's answers.
      if (!channel->WaitForConnected(std::chrono::system_clock::now() + std::chrono::seconds(30))) {
        std::lock_guard<std::mutex> lock(mu);
        failures.push_back("client " + std::to_string(c) + ": no connection within 30 s");
        return;
      }
      for (int r = 0; r < kRoundsPerClient; ++r) {
        const size_t k = (static_cast<size_t>(c) * 7 + static_cast<size_t>(r) * 11) % cases.size();
        const std::string failure = cases[k].second(channel);
        std::lock_guard<std::mutex> lock(mu);
        ++runs[k];
        if (!failure.empty()) failures.push_back(cases[k].first + ": " + failure);
      }
    });
  }
  for (std::thread& t : clients) t.join();

  EXPECT_TRUE(failures.empty()) << failures.size() << " failures:\n" << absl::StrJoin(failures, "\n");
  for (size_t k = 0; k < cases.size(); ++k) EXPECT_GE(runs[k], 2) << cases[k].first;
  // Still serving, every byte given back.
  EXPECT_EQ(ValidJob(grpc::CreateChannel(target, grpc::InsecureChannelCredentials()), "median", 3, 7, 0, retries), "");
  for (int i = 0; i < 200 && server->service().buffered_bytes() > 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_EQ(server->service().buffered_bytes(), 0);
#if defined(__SANITIZE_ADDRESS__)
  std::printf("peak RSS %lld MiB (not checked under AddressSanitizer: its shadow memory and quarantine count)\n",
              static_cast<long long>(PeakRssBytes() >> 20));
#else
  const int64_t peak = PeakRssBytes();
  EXPECT_LT(peak, kBudgetBytes + kRssMarginBytes) << "peak RSS " << (peak >> 20) << " MiB";
  std::printf("peak RSS %lld MiB, %d retries on RESOURCE_EXHAUSTED\n", static_cast<long long>(peak >> 20),
              retries.load());
#endif
}

}  // namespace
}  // namespace meshsmooth
