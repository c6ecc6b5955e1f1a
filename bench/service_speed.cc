#include "bench/service_speed.h"

#include <cstdio>
#include <map>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/smooth_client.h"
#include "core/io/draco_codec.h"
#include "core/measure/metrics.h"
#include "core/shapes/added_noise.h"
#include "core/topology.h"
#include "draco/compression/decode.h"
#include "draco/compression/encode.h"
#include "server/server.h"

namespace meshsmooth::bench {
namespace {

bool g_metrics = false;  // SetServiceMetrics

// Times of `runs` calls of one job through a one-worker server on loopback TCP (ms), and what
// the last call's summary says about its iterations.
struct ServiceTimes {
  std::vector<double> total, smooth, decode, encode, queue;
  int iterations = 0;
  std::string stop_reason;
  double noise_estimate = 0.0;
};

absl::StatusOr<ServiceTimes> TimeThroughService(const std::string& draco, const v1::JobSpec& spec, int runs) {
  server::ServerOptions o;
  o.listen = "127.0.0.1:0";
  o.log_jobs = false;
  o.workers = 1;
  if (g_metrics) o.metrics_listen = "127.0.0.1:0";
  auto server = server::Server::Start(o);
  if (!server.ok()) return server.status();
  auto channel =
      grpc::CreateChannel("127.0.0.1:" + std::to_string((*server)->port()), grpc::InsecureChannelCredentials());
  auto stub = v1::MeshSmoother::NewStub(channel);
  ServiceTimes t;
  for (int r = 0; r < runs; ++r) {
    grpc::ClientContext ctx;
    const auto t0 = Clock::now();
    absl::StatusOr<client::SmoothOutcome> out = client::CallSmooth(*stub, ctx, spec, draco);
    const double ms = Ms(t0, Clock::now());
    if (!out.ok()) {
      (*server)->Shutdown();
      return out.status();
    }
    const v1::Summary& s = out->summary;
    t.total.push_back(ms);
    t.smooth.push_back(1000 * s.timings().smooth_seconds());
    t.decode.push_back(1000 * s.timings().decode_seconds());
    t.encode.push_back(1000 * s.timings().encode_seconds());
    t.queue.push_back(1000 * s.timings().queue_seconds());
    t.iterations = static_cast<int>(s.parameters().iterations_run());
    t.stop_reason = s.parameters().stop_reason();
    t.noise_estimate = s.parameters().noise_estimate();
  }
  (*server)->Shutdown();
  return t;
}

}  // namespace

void SetServiceMetrics(bool on) { g_metrics = on; }

void DefaultJobRows(const NamedMesh& nm, const std::string& flow, int runs) {
  v1::JobSpec spec;
  spec.set_flow(flow);
  const std::string label = flow.empty() ? nm.name : absl::StrCat(nm.name, " (", flow, ")");
  for (double sigma : {0.0, 0.2}) {
    Mesh mesh = nm.mesh;
    if (sigma > 0.0) AddNormalNoise(mesh, sigma, 1);
    absl::StatusOr<ServiceTimes> t = TimeThroughService(DracoUpload(std::move(mesh)), spec, runs);
    if (!t.ok()) {
      std::printf("| %s | %g | failed: %s |\n", label.c_str(), sigma, std::string(t.status().message()).c_str());
      continue;
    }
    std::printf("| %s | %g | %d, %s (%.3f) | %.0f | %.0f | %.0f | %.0f |\n", label.c_str(), sigma, t->iterations,
                t->stop_reason.c_str(), t->noise_estimate, Median(t->total), Median(t->decode), Median(t->smooth),
                Median(t->encode));
  }
}

double ServiceRow(const NamedMesh& nm, int iterations, int runs) {
  const std::string draco = DracoUpload(nm.mesh);
  // The floor: Draco alone decoding these bytes and encoding the decoded mesh with the
  // service's settings (lossless, sequential, speed 5) - no welding, no copy into our mesh.
  std::vector<double> bare, ours;
  for (int r = 0; r < runs; ++r) {
    const auto t0 = Clock::now();
    draco::DecoderBuffer in;
    in.Init(draco.data(), draco.size());
    draco::Decoder decoder;
    auto decoded = decoder.DecodeMeshFromBuffer(&in);
    draco::Encoder encoder;
    encoder.SetSpeedOptions(5, 5);
    encoder.SetEncodingMethod(draco::MESH_SEQUENTIAL_ENCODING);
    draco::EncoderBuffer out;
    if (!decoded.ok() || !encoder.EncodeMeshToBuffer(*decoded.value(), &out).ok()) return -1.0;
    const auto t1 = Clock::now();
    absl::StatusOr<DracoMesh> dm = DracoMesh::Decode(draco);
    absl::StatusOr<std::string> enc = dm->Encode(dm->TakeWelded());
    bare.push_back(Ms(t0, t1));
    ours.push_back(Ms(t1, Clock::now()));
  }
  v1::JobSpec spec;
  spec.set_flow("laplacian");
  spec.set_iterations(static_cast<uint32_t>(iterations));
  absl::StatusOr<ServiceTimes> t = TimeThroughService(draco, spec, runs);
  if (!t.ok()) {
    std::printf("| %s | failed: %s |\n", nm.name.c_str(), std::string(t.status().message()).c_str());
    return -1.0;
  }
  const double overhead = Median(t->total) - Median(t->smooth);
  std::printf("| %s | %.1f MB | %.0f | %.0f | %.0f | %.0f | %.0f | %.0f | %.0f | %.2f | %.0f |\n", nm.name.c_str(),
              draco.size() / 1e6, Median(t->total), Median(t->decode), Median(t->queue), Median(t->smooth),
              Median(t->encode), overhead, Median(bare), overhead / Median(bare), Median(ours));
  return Median(bare);
}

void ServiceBreakdown(const NamedMesh& nm, int runs) {
  const std::string draco = DracoUpload(nm.mesh);
  std::map<std::string, std::vector<double>> t;
  for (int r = 0; r < runs; ++r) {
    auto t0 = Clock::now();
    absl::StatusOr<Mesh> plain = DecodeDraco(draco);
    auto t1 = Clock::now();
    absl::StatusOr<DracoMesh> dm = DracoMesh::Decode(draco);
    auto t2 = Clock::now();
    Mesh m = dm->TakeWelded();
    ValidationReport report;
    const Topology topo = BuildTopology(m, &report);
    auto t3 = Clock::now();
    const MeshMetrics before = ComputeMetrics(m, topo);
    auto t4 = Clock::now();
    const std::vector<Vec3> input = dm->InputPositions();  // as the job, after its run
    auto t5 = Clock::now();
    absl::StatusOr<Displacement> d = CompareMeshes(input, m);
    auto t6 = Clock::now();
    absl::StatusOr<std::string> enc = dm->Encode(m);
    auto t7 = Clock::now();
    t["Draco decode (points)"].push_back(Ms(t0, t1));
    t["Draco decode + weld (DracoMesh::Decode)"].push_back(Ms(t1, t2));
    t["BuildTopology (validation)"].push_back(Ms(t2, t3));
    t["ComputeMetrics (once; a job runs it twice)"].push_back(Ms(t3, t4));
    t["input positions made anew (for the displacement)"].push_back(Ms(t4, t5));
    t["CompareMeshes"].push_back(Ms(t5, t6));
    t["DracoMesh::Encode"].push_back(Ms(t6, t7));
    if (!plain.ok() || !d.ok() || !enc.ok() || before.area < 0) std::printf(" ");  // keep the steps observable
  }
  std::printf("\n### Service job steps, %s (medians of %d)\n\n| step | ms |\n|---|---|\n", nm.name.c_str(), runs);
  for (const char* k : {"Draco decode (points)", "Draco decode + weld (DracoMesh::Decode)",
                        "BuildTopology (validation)", "ComputeMetrics (once; a job runs it twice)",
                        "input positions made anew (for the displacement)", "CompareMeshes", "DracoMesh::Encode"}) {
    std::printf("| %s | %.1f |\n", k, Median(t[k]));
  }
}

}  // namespace meshsmooth::bench
