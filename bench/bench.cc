// meshsmooth_bench: how fast the flows run, beside their peers, against the memory bandwidth,
// and through the service. Prints Markdown; docs/performance.md is its output.
//
//   build/bench/meshsmooth_bench [--quick] [--runs 5] [--no-service] [--no-peers]
//                                [--levels 6,7,8,9] [--only LABEL,...] [FILE ...]
//
// --levels picks the icosphere levels (none: "--levels ''"); --only keeps the flows whose
// label contains one of the given words (e.g. --only "U0,mcf") and the peers compared with them.
//
// Meshes: noisy icospheres of 40,962 / 163,842 / 655,362 / 2,621,442 vertices (levels 6-9,
// deterministic), plus any mesh file given. Every time is the median of --runs runs.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <omp.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <map>
#include <numeric>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_format.h"
#include "bench/peers.h"
#include "draco/compression/decode.h"
#include "draco/compression/encode.h"
#include "client/smooth_client.h"
#include "core/io/draco_codec.h"
#include "core/flows/flow.h"
#include "core/flows/flow_table.h"
#include "core/flows/reorder.h"
#include "base/huge_pages.h"
#include "core/io/file_bytes.h"
#include "core/io/mesh_io.h"
#include "core/measure/metrics.h"
#include "core/shapes/parametric.h"
#include "core/shapes/added_noise.h"
#include "core/topology.h"
#include "server/server.h"

namespace meshsmooth::bench {
namespace {

using Clock = std::chrono::steady_clock;

double Ms(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double, std::milli>(b - a).count(); }

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : (v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]));
}

struct Options {
  int runs = 5;
  bool quick = false, service = true, peers = true, default_job_only = false;
  std::vector<int> levels = {6, 7, 8, 9};
  std::vector<std::string> only;  // empty: every flow
  std::vector<std::string> files;

  bool Wanted(const std::string& label) const {
    if (only.empty()) return true;
    for (const std::string& w : only) {
      if (label.find(w) != std::string::npos) return true;
    }
    return false;
  }
};

std::vector<std::string> SplitCommas(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  for (std::string part; std::getline(in, part, ',');) {
    if (!part.empty()) out.push_back(part);
  }
  return out;
}

// STREAM-like triad a = b + s c on three arrays of `bytes` each; GB/s counting 24 bytes per
// element (two reads, one write), best of 5 as STREAM reports.
double Triad(size_t bytes, int threads) {
  const size_t n = bytes / sizeof(double);
  std::vector<double> a(n), b(n), c(n);
#pragma omp parallel for num_threads(threads) schedule(static)
  for (size_t i = 0; i < n; ++i) {
    a[i] = 0.0;
    b[i] = 1.0;
    c[i] = 2.0;
  }
  const int reps = std::max<int>(5, static_cast<int>((1 << 28) / std::max<size_t>(n, 1)));
  double best = 0.0;
  for (int r = 0; r < 5; ++r) {
    const auto t0 = Clock::now();
    for (int k = 0; k < reps; ++k) {
      const double s = 1.0 + 1e-9 * k;
#pragma omp parallel for num_threads(threads) schedule(static)
      for (size_t i = 0; i < n; ++i) a[i] = b[i] + s * c[i];
    }
    const double sec = Ms(t0, Clock::now()) / 1000.0;
    best = std::max(best, 24.0 * static_cast<double>(n) * reps / sec / 1e9);
  }
  if (a[n / 2] < 0) std::printf(" ");  // keep the loop observable
  return best;
}

// Bytes one iteration must move in our layout (no write-allocate, as the triad counts): the
// positions read (24), ring offsets (4), neighbour indices (4 x valence), role (1), positions
// written (24); neighbour positions are assumed to hit cache. Taubin and bilaplacian make two
// such passes; taubin also a displacement pass over the iteration start (48).
double BytesPerVertex(FlowId flow, double mean_valence) {
  const double pass = 24 + 4 + 4 * mean_valence + 1 + 24;
  if (flow == FlowId::kTaubin) return 2 * pass + 48;
  if (flow == FlowId::kBilaplacian) return 2 * pass;
  return pass;
}

struct Variant {
  std::string label;
  FlowParams params;
};

std::vector<Variant> Variants() {
  auto make = [](const std::string& flow) {
    FlowParams p;
    p.flow = ParseFlowName(flow).value();
    return p;
  };
  FlowParams u1 = make("laplacian"), taubin_u1 = make("taubin");
  u1.weights = taubin_u1.weights = UmbrellaWeights::kInverseDistance;
  FlowParams adaptive = make("median");
  adaptive.adaptive = AdaptiveMode::kRing2;
  return {{"laplacian U0", make("laplacian")}, {"laplacian U1", u1},       {"taubin U0", make("taubin")},
          {"taubin U1", taubin_u1},          {"bilaplacian", make("bilaplacian")}, {"mcf", make("mcf")},
          {"mcf_tangential", make("mcf_tangential")}, {"median", make("median")},
          {"median + adaptive ring2", adaptive}};
}

struct OurTiming {
  double per_iteration_ms = -1.0;  // (T(K) - T(1)) / (K - 1): the iterations alone
  double setup_ms = 0.0;           // T(1) - per_iteration: copies, h, reordering, allocation
};

// Median of `runs` runs of `iterations` and of 1 iteration of `p` on `mesh`.
OurTiming TimeOurs(const Mesh& mesh, const Topology& topo, FlowParams p, int iterations, int threads, int runs) {
  p.threads = threads;
  // T(1) in the layout Smooth() picks for `iterations`, so that T(K) - T(1) is the iterations.
  p.reorder = MortonOrderPaysOff(topo, iterations) ? ReorderMode::kAlways : ReorderMode::kNever;
  auto once = [&](int k) {
    p.iterations = k;
    Mesh m = mesh;
    const auto t0 = Clock::now();
    absl::StatusOr<FlowResult> res = Smooth(m, topo, p);
    const double ms = Ms(t0, Clock::now());
    if (!res.ok()) {
      std::fprintf(stderr, "bench: %s failed: %s\n", std::string(FlowName(p.flow.value_or(kDefaultFlow))).c_str(), std::string(res.status().message()).c_str());
      return -1.0;
    }
    return ms;
  };
  // One untimed call first: otherwise the first run's T(K) pays for memory the allocator had
  // not yet taken from the system, and T(K) - T(1) overstates an iteration (most for a large
  // mesh run after a smaller one; docs/performance.md).
  if (once(1) < 0) return {};
  std::vector<double> per, setup;
  for (int r = 0; r < runs; ++r) {
    const double tk = once(iterations), t1 = once(1);
    if (tk < 0 || t1 < 0) return {};
    const double it = (tk - t1) / std::max(1, iterations - 1);
    per.push_back(it);
    setup.push_back(t1 - it);
  }
  return {Median(per), Median(setup)};
}

// The ceiling of our layout: a plain CSR U0 loop (no roles, statistics, caps or checks) over
// the same Morton-ordered arrays Smooth() runs on; ms per iteration, median of `runs`.
double PlainU0Ms(const Mesh& mesh, int iterations, int threads, int runs) {
  const int32_t n = mesh.num_vertices();
  const std::vector<int32_t> order = MortonOrder(mesh.positions);  // new -> old
  std::vector<int32_t> rank(n);
  for (int32_t i = 0; i < n; ++i) rank[order[i]] = i;
  Mesh m;
  m.positions.resize(n);
  for (int32_t i = 0; i < n; ++i) m.positions[i] = mesh.positions[order[i]];
  m.triangles = mesh.triangles;
  for (Triangle& t : m.triangles) {
    for (int32_t& v : t) v = rank[v];
  }
  const Topology topo = BuildTopology(m);
  const int32_t* off = topo.ring_offsets.data();
  const int32_t* ring = topo.ring.data();
  std::vector<Vec3> cur = m.positions, next(n);
  std::vector<double> t;
  for (int r = 0; r < runs; ++r) {
    const auto t0 = Clock::now();
    for (int k = 0; k < iterations; ++k) {
      const Vec3* p = cur.data();
      Vec3* q = next.data();
#pragma omp parallel for schedule(static) num_threads(threads)
      for (int32_t v = 0; v < n; ++v) {
        Vec3 sum;
        for (int32_t i = off[v]; i < off[v + 1]; ++i) sum += p[ring[i]];
        const int32_t d = off[v + 1] - off[v];
        q[v] = d > 0 ? p[v] + (sum * (1.0 / d) - p[v]) * 0.5 : p[v];
      }
      cur.swap(next);
    }
    t.push_back(Ms(t0, Clock::now()) / iterations);
  }
  return Median(t);
}

struct NamedMesh {
  std::string name;
  Mesh mesh;
};

// The normal-filtering flow's parts on `mesh`, beside laplacian U0 (ms per U0 iteration with 1
// and 2 threads): one filter pass and one vertex pass (differences of runs that do one more per
// iteration), one round with the default parameters and the set-up (face graph and, on a
// scattered large mesh, the Morton-ordered copy), each the median of `runs`.
// docs/normal-filtering.md ("Speed") explains the rows.
void NormalFilterRows(const Mesh& mesh, const Topology& topo, const double u0_ms[2], int hw, int runs) {
  constexpr int kIterations = 4;
  auto total_ms = [&](const FlowParams& p) {
    std::vector<double> t;
    for (int r = 0; r < runs; ++r) {
      Mesh m = mesh;
      const auto t0 = Clock::now();
      absl::StatusOr<FlowResult> res = Smooth(m, topo, p);
      t.push_back(res.ok() ? Ms(t0, Clock::now()) : -1.0);
    }
    return Median(t);
  };
  double filter[2], vertex[2], round[2], setup[2];
  for (int k = 0; k < 2; ++k) {
    FlowParams base;
    base.flow = FlowId::kBilateralNormal;
    base.threads = k == 0 ? 1 : std::min(2, hw);
    base.iterations = kIterations;
    // In the layout a job of 20 iterations runs in, whatever the count here.
    base.reorder = MortonOrderPaysOff(topo, 20 * PassesPerIteration(base)) ? ReorderMode::kAlways : ReorderMode::kNever;
    FlowParams one = base;  // one filter pass and one vertex pass per iteration
    one.normal_filter.normal_iterations = one.normal_filter.vertex_iterations = 1;
    FlowParams two_filters = one, two_updates = one, single = base;
    two_filters.normal_filter.normal_iterations = 2;
    two_updates.normal_filter.vertex_iterations = 2;
    single.iterations = 1;
    const double t_one = total_ms(one), t_base = total_ms(base), t_single = total_ms(single);
    filter[k] = (total_ms(two_filters) - t_one) / kIterations;
    vertex[k] = (total_ms(two_updates) - t_one) / kIterations;
    round[k] = (t_base - t_single) / (kIterations - 1);
    setup[k] = t_single - round[k];
  }
  std::printf("\n| bilateral_normal (default parameters) | ms, 1 thread | 2 threads | / laplacian U0 iteration, 1 thread | 2 threads |\n|---|---|---|---|---|\n");
  auto row = [&](const char* what, const double* t) {
    std::printf("| %s | %.2f | %.2f | %.2fx | %.2fx |\n", what, t[0], t[1], t[0] / u0_ms[0], t[1] / u0_ms[1]);
  };
  row("one filter pass over the face normals", filter);
  row("one vertex pass (update and guards)", vertex);
  row("one iteration (1 filter pass, 5 vertex passes, face geometry)", round);
  row("set-up (face graph, any Morton copy) and first touch of the buffers", setup);
}

Mesh NoisyIcosphere(int level) {
  Mesh m = Icosphere(level);
  AddUniformNoise(m, 0.3, 1);
  return m;
}

int IterationsFor(int32_t n) { return std::clamp(static_cast<int>(40'000'000 / std::max(n, 1)), 3, 200); }

// Peak resident memory of one job (upload bytes, decode, topology, smoothing, encoded result),
// measured in a fresh process (this binary re-run with --peak-child, so no thread pool is
// inherited across fork) from VmHWM after resetting it.
double StatusKb(const char* key) {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind(key, 0) == 0) return std::atof(line.c_str() + std::strlen(key));
  }
  return -1.0;
}

int PeakChild(const std::string& draco_path) {
  absl::StatusOr<std::string> bytes = ReadFileBytes(draco_path);
  if (!bytes.ok()) return 1;
  std::string draco = std::move(*bytes);
  { std::ofstream("/proc/self/clear_refs") << "5"; }
  const double base = StatusKb("VmRSS:");
  std::string upload = draco;  // the job's own copy of the upload
  std::string().swap(draco);
  absl::StatusOr<DracoMesh> dm = DracoMesh::Decode(upload);
  if (!dm.ok()) return 1;
  std::string().swap(upload);
  Mesh mesh = dm->TakeWelded();
  const Topology topo = BuildTopology(mesh);
  const std::vector<Vec3> input = mesh.positions;  // the job keeps the input positions for the displacement
  FlowParams p;
  p.flow = FlowId::kMedian;
  p.iterations = 5;
  if (!Smooth(mesh, topo, p).ok()) return 1;
  absl::StatusOr<std::string> out = dm->Encode(mesh);
  if (!out.ok()) return 1;
  std::printf("%f\n", (StatusKb("VmHWM:") - base) * 1024.0 / mesh.num_vertices());
  return input.empty() ? 1 : 0;
}

double PeakBytesPerVertex(const Mesh& mesh, const std::string& self) {
  Mesh fm = mesh;
  for (Vec3& p : fm.positions) p = RoundToFloat(p);
  const std::string path = "/tmp/meshsmooth_bench_peak.drc";
  if (!WriteFileBytes(path, *EncodeDraco(fm)).ok()) return -1.0;
  double value = -1.0;
  if (std::FILE* f = popen((self + " --peak-child " + path).c_str(), "r")) {
    if (std::fscanf(f, "%lf", &value) != 1) value = -1.0;
    pclose(f);
  }
  std::remove(path.c_str());
  return value;
}

// Where a job's time goes besides smoothing, step by step as smooth_job.cc runs them (medians).
void ServiceBreakdown(const NamedMesh& nm, int runs) {
  Mesh mesh = nm.mesh;
  for (Vec3& p : mesh.positions) p = RoundToFloat(p);
  const std::string draco = *EncodeDraco(mesh);
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
    const std::vector<Vec3> input = m.positions;
    auto t5 = Clock::now();
    absl::StatusOr<Displacement> d = CompareMeshes(input, m);
    auto t6 = Clock::now();
    absl::StatusOr<std::string> enc = dm->Encode(m);
    auto t7 = Clock::now();
    t["Draco decode (points)"].push_back(Ms(t0, t1));
    t["Draco decode + weld (DracoMesh::Decode)"].push_back(Ms(t1, t2));
    t["BuildTopology (validation)"].push_back(Ms(t2, t3));
    t["ComputeMetrics (once; a job runs it twice)"].push_back(Ms(t3, t4));
    t["copy of the input (for the displacement)"].push_back(Ms(t4, t5));
    t["CompareMeshes"].push_back(Ms(t5, t6));
    t["DracoMesh::Encode"].push_back(Ms(t6, t7));
    if (!plain.ok() || !d.ok() || !enc.ok() || before.area < 0) std::printf(" ");
  }
  std::printf("\n### Service job steps, %s (medians of %d)\n\n| step | ms |\n|---|---|\n", nm.name.c_str(), runs);
  for (const char* k : {"Draco decode (points)", "Draco decode + weld (DracoMesh::Decode)",
                        "BuildTopology (validation)", "ComputeMetrics (once; a job runs it twice)",
                        "copy of the input (for the displacement)", "CompareMeshes", "DracoMesh::Encode"}) {
    std::printf("| %s | %.1f |\n", k, Median(t[k]));
  }
}

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
  auto server = server::Server::Start(o);
  if (!server.ok()) return server.status();
  auto channel = grpc::CreateChannel("127.0.0.1:" + std::to_string((*server)->port()), grpc::InsecureChannelCredentials());
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

// One row of the service table; returns the bare Draco decode + encode (ms), or -1 on failure.
double ServiceRow(const NamedMesh& nm, int iterations, int runs) {
  Mesh mesh = nm.mesh;
  for (Vec3& p : mesh.positions) p = RoundToFloat(p);
  const std::string draco = *EncodeDraco(mesh);
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

// The default job (a JobSpec with no field set but `flow`, empty: the default flow) through the
// service, on the mesh as it is and on a copy with Gaussian noise of 0.2 h along the normals
// (seed 1).
void DefaultJobRows(const NamedMesh& nm, const std::string& flow, int runs) {
  v1::JobSpec spec;
  spec.set_flow(flow);
  const std::string label = flow.empty() ? nm.name : absl::StrCat(nm.name, " (", flow, ")");
  for (double sigma : {0.0, 0.2}) {
    Mesh mesh = nm.mesh;
    if (sigma > 0.0) AddNormalNoise(mesh, sigma, 1);
    for (Vec3& p : mesh.positions) p = RoundToFloat(p);
    absl::StatusOr<ServiceTimes> t = TimeThroughService(*EncodeDraco(mesh), spec, runs);
    if (!t.ok()) {
      std::printf("| %s | %g | failed: %s |\n", label.c_str(), sigma, std::string(t.status().message()).c_str());
      continue;
    }
    std::printf("| %s | %g | %d, %s (%.3f) | %.0f | %.0f | %.0f | %.0f |\n", label.c_str(), sigma, t->iterations,
                t->stop_reason.c_str(), t->noise_estimate, Median(t->total), Median(t->decode), Median(t->smooth),
                Median(t->encode));
  }
}

// Raw TCP on loopback: `bytes` from a client socket to a thread that sends as many back (an
// upload and a download without gRPC, HTTP/2 or protobuf); ms, median of `runs`, -1 on failure.
double LoopbackTcpMs(size_t bytes, int runs) {
  const int listener = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof addr;
  if (listener < 0 || bind(listener, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 || listen(listener, 1) != 0 ||
      getsockname(listener, reinterpret_cast<sockaddr*>(&addr), &len) != 0) {
    if (listener >= 0) close(listener);
    return -1.0;
  }
  auto send_all = [](int fd, const char* p, size_t n) {
    for (ssize_t k = 0; n > 0; p += k, n -= static_cast<size_t>(k)) {
      if ((k = send(fd, p, n, MSG_NOSIGNAL)) <= 0) return false;
    }
    return true;
  };
  auto recv_all = [](int fd, char* p, size_t n) {
    for (ssize_t k = 0; n > 0; p += k, n -= static_cast<size_t>(k)) {
      if ((k = recv(fd, p, n, 0)) <= 0) return false;
    }
    return true;
  };
  std::thread echo([&] {
    const int fd = accept(listener, nullptr, nullptr);
    if (fd < 0) return;
    std::string buf(bytes, '\0');
    for (int r = 0; r < runs && recv_all(fd, buf.data(), bytes) && send_all(fd, buf.data(), bytes); ++r) {
    }
    close(fd);
  });
  std::vector<double> t;
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd >= 0 && connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0) {
    std::string up(bytes, 'u'), down(bytes, '\0');
    for (int r = 0; r < runs; ++r) {
      const auto t0 = Clock::now();
      if (!send_all(fd, up.data(), bytes) || !recv_all(fd, down.data(), bytes)) break;
      t.push_back(Ms(t0, Clock::now()));
    }
  }
  if (fd >= 0) close(fd);
  shutdown(listener, SHUT_RDWR);  // wakes the echo thread if no connection came
  echo.join();
  close(listener);
  return t.size() == static_cast<size_t>(runs) ? Median(t) : -1.0;
}

// The least neighbour structure a one-ring smoother needs: every vertex's unique neighbours
// (CSR) from the triangles, by a counting sort of the corners, then a sort and unique per
// vertex on all threads. No fans, kinds or counts. ms, median of `runs`.
double UniqueNeighboursMs(const Mesh& mesh, int runs) {
  const int32_t n = mesh.num_vertices();
  std::vector<double> t;
  int64_t kept = 0;
  for (int r = 0; r < runs; ++r) {
    const auto t0 = Clock::now();
    std::vector<int32_t> offsets(static_cast<size_t>(n) + 1, 0);
    for (const Triangle& tri : mesh.triangles) {
      for (int32_t v : tri) offsets[v + 1] += 2;
    }
    std::partial_sum(offsets.begin(), offsets.end(), offsets.begin());
    std::vector<int32_t> fill(offsets.begin(), offsets.end() - 1), neighbours(offsets.back()), unique(n);
    for (const Triangle& tri : mesh.triangles) {
      for (int k = 0; k < 3; ++k) {
        int32_t& at = fill[tri[k]];
        neighbours[at++] = tri[(k + 1) % 3];
        neighbours[at++] = tri[(k + 2) % 3];
      }
    }
#pragma omp parallel for schedule(static)
    for (int32_t v = 0; v < n; ++v) {
      const auto first = neighbours.begin() + offsets[v], last = neighbours.begin() + offsets[v + 1];
      std::sort(first, last);
      unique[v] = static_cast<int32_t>(std::unique(first, last) - first);
    }
    t.push_back(Ms(t0, Clock::now()));
    kept += unique[n / 2];
  }
  return kept > 0 ? Median(t) : -1.0;
}

// What any service adds to Draco's own decode and encode, measured beside the service table:
// moving the bytes both ways and building neighbours to smooth on. An overhead of 1.5x the bare
// codec leaves 0.5x for everything besides the codec itself (validation, metrics, welding
// seams, gRPC and protobuf framing, copies).
void ServiceFloor(const NamedMesh& nm, int runs, double bare_ms) {
  Mesh mesh = nm.mesh;
  for (Vec3& p : mesh.positions) p = RoundToFloat(p);
  const std::string draco = *EncodeDraco(mesh);
  const Mesh decoded = DracoMesh::Decode(draco)->TakeWelded();  // the job's input
  const double tcp = LoopbackTcpMs(draco.size(), runs), neighbours = UniqueNeighboursMs(decoded, runs);
  std::printf("\n### The least a service adds to the codec, %s (medians of %d)\n\n| step | ms |\n|---|---|\n",
              nm.name.c_str(), runs);
  std::printf("| raw TCP on loopback: the upload's %.1f MB up and as many back (no gRPC) | %.1f |\n", draco.size() / 1e6, tcp);
  std::printf("| unique neighbours of every vertex (counting sort, then sort + unique per vertex, all threads) | %.1f |\n",
              neighbours);
  std::printf("| sum | %.1f |\n", tcp + neighbours);
  std::printf("| what an overhead of 1.5x bare leaves besides the codec: 0.5 x %.0f ms | %.1f |\n", bare_ms, 0.5 * bare_ms);
}

}  // namespace
}  // namespace meshsmooth::bench

int main(int argc, char** argv) {
  meshsmooth::UseHugePagesForLargeBuffers(argv);  // first: may re-execute the program
  using namespace meshsmooth;
  using namespace meshsmooth::bench;
  Options opt;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--quick") {
      opt.quick = true;
      opt.levels = {6, 7};
    } else if (a == "--levels" && i + 1 < argc) {
      opt.levels.clear();
      for (const std::string& l : SplitCommas(argv[++i])) opt.levels.push_back(std::atoi(l.c_str()));
    } else if (a == "--only" && i + 1 < argc) opt.only = SplitCommas(argv[++i]);
    else if (a == "--runs" && i + 1 < argc) opt.runs = std::max(1, std::atoi(argv[++i]));
    else if (a == "--no-service") opt.service = false;
    else if (a == "--no-peers") opt.peers = false;
    else if (a == "--default-job-only") opt.default_job_only = true;
    else if (a == "--peak-child" && i + 1 < argc) return PeakChild(argv[i + 1]);
    else if (a == "--help" || a == "-h") {
      std::printf("usage: %s [--quick] [--runs N] [--no-service] [--no-peers] [--levels 6,7,8,9] [--only LABEL,...] [--default-job-only] [MESH_FILE ...]\n", argv[0]);
      return 0;
    } else opt.files.push_back(a);
  }
  std::setvbuf(stdout, nullptr, _IOLBF, 0);  // rows appear as they are measured
  if (opt.default_job_only) opt.levels.clear();
  char self_buf[4096] = {};
  const ssize_t self_len = readlink("/proc/self/exe", self_buf, sizeof self_buf - 1);
  const std::string self = self_len > 0 ? std::string(self_buf, self_len) : std::string(argv[0]);
  const int hw = omp_get_max_threads();
  std::printf("# meshsmooth performance\n\nMachine: %d hardware threads. Command: `", hw);
  for (int i = 0; i < argc; ++i) std::printf("%s%s", i ? " " : "", argv[i]);
  std::printf("`. Times are medians of %d runs.\n", opt.runs);

  double bw1 = 0.0, bw2 = 0.0, bw_cache1 = 0.0, bw_cache2 = 0.0;
  if (!opt.default_job_only) {
    std::printf("\n## Memory bandwidth (STREAM-like triad, 24 bytes per element)\n\n| arrays | 1 thread | 2 threads |\n|---|---|---|\n");
    bw_cache1 = Triad(256 << 10, 1);
    bw_cache2 = Triad(256 << 10, std::min(2, hw));
    std::printf("| 3 x 256 KiB (cache) | %.1f GB/s | %.1f GB/s |\n", bw_cache1, bw_cache2);
    const size_t big = opt.quick ? (size_t{256} << 20) : (size_t{1} << 30);
    bw1 = Triad(big, 1);
    bw2 = Triad(big, std::min(2, hw));
    std::printf("| 3 x %zu MiB (DRAM) | %.1f GB/s | %.1f GB/s |\n", big >> 20, bw1, bw2);
  }

  std::vector<NamedMesh> meshes;
  for (int level : opt.levels) {
    Mesh m = NoisyIcosphere(level);
    meshes.push_back({"noisy icosphere " + std::to_string(m.num_vertices()), std::move(m)});
  }
  for (const std::string& f : opt.files) {
    absl::StatusOr<Mesh> m = ReadMesh(f);
    if (!m.ok()) {
      std::fprintf(stderr, "bench: %s\n", std::string(m.status().message()).c_str());
      return 1;
    }
    meshes.push_back({f.substr(f.rfind('/') + 1), *std::move(m)});
  }

  if (opt.service) {
    std::printf("\n## The default job through the service (loopback TCP, no JobSpec field set; clean, and with "
                "Gaussian noise of 0.2 h along the normals)\n\n| mesh | noise (h) | iterations, stop (noise estimate, h) "
                "| total ms | decode+validate | smooth | encode |\n|---|---|---|---|---|---|---|\n");
    for (const NamedMesh& nm : meshes) DefaultJobRows(nm, "", opt.runs);
    // The normal-filtering flow's default job, for the files given (issue: under 2 s on the dragon).
    if (opt.Wanted("bilateral_normal")) {
      for (size_t i = opt.levels.size(); i < meshes.size(); ++i) DefaultJobRows(meshes[i], "bilateral_normal", opt.runs);
    }
  }
  if (opt.default_job_only) return 0;

  std::vector<Peer> peers;
  if (opt.peers) {
    for (auto&& list : {OpenMeshPeers(), Open3dPeers(), CgalPeers()}) peers.insert(peers.end(), list.begin(), list.end());
  }
  std::map<std::string, std::map<std::string, double>> ours_1t;  // mesh -> variant -> ms per iteration
  for (const NamedMesh& nm : meshes) {
    const Topology topo = BuildTopology(nm.mesh);
    const int32_t n = nm.mesh.num_vertices();
    const int iterations = IterationsFor(n);
    const double valence = static_cast<double>(topo.ring.size()) / std::max(n, 1);
    std::printf("\n## %s (%d vertices, %d iterations per run, %s)\n\n", nm.name.c_str(), n, iterations,
                MortonOrderPaysOff(topo, iterations) ? "run on a Morton-ordered copy" : "run in its own order");
    std::printf("| flow | ms/iteration, 1 thread | 2 threads | speed-up | Mvertex-it/s (2 threads) | bytes/vertex | share of DRAM bound (2 threads) | set-up ms (1 thread) |\n|---|---|---|---|---|---|---|---|\n");
    double u0_ms = 0.0, u0_ms2[2] = {0.0, 0.0};
    for (const Variant& v : Variants()) {
      if (!opt.Wanted(v.label) && v.label != "laplacian U0") continue;  // U0 is every ratio's base
      const OurTiming one = TimeOurs(nm.mesh, topo, v.params, iterations, 1, opt.runs);
      const OurTiming two = TimeOurs(nm.mesh, topo, v.params, iterations, std::min(2, hw), opt.runs);
      const double t1 = one.per_iteration_ms, t2 = two.per_iteration_ms;
      ours_1t[nm.name][v.label] = t1;
      if (v.label == "laplacian U0") u0_ms = u0_ms2[0] = t1, u0_ms2[1] = t2;
      const double bytes = BytesPerVertex(v.params.flow.value_or(kDefaultFlow), valence);
      const double gbs = bytes * n / (t2 / 1000.0) / 1e9;
      std::printf("| %s | %.2f | %.2f | %.2fx | %.0f | %.0f | %.0f%% | %.1f |\n", v.label.c_str(), t1, t2, t1 / t2,
                  n / (t2 / 1000.0) / 1e6, bytes, 100.0 * gbs / bw2, one.setup_ms);
    }
    {
      const double t1 = PlainU0Ms(nm.mesh, iterations, 1, opt.runs), t2 = PlainU0Ms(nm.mesh, iterations, std::min(2, hw), opt.runs);
      const double bytes = BytesPerVertex(FlowId::kLaplacian, valence);
      std::printf("| (reference) plain CSR U0 loop, same order, no checks | %.2f | %.2f | %.2fx | %.0f | %.0f | %.0f%% | - |\n", t1,
                  t2, t1 / t2, n / (t2 / 1000.0) / 1e6, bytes, 100.0 * bytes * n / (t2 / 1000.0) / 1e9 / bw2);
    }
    if (opt.Wanted("bilateral_normal")) NormalFilterRows(nm.mesh, topo, u0_ms2, hw, opt.runs);
    std::string ratios;  // none when --only left the cotangent flows out
    for (const char* flow : {"mcf", "mcf_tangential", "median"}) {
      const auto it = ours_1t[nm.name].find(flow);
      if (it != ours_1t[nm.name].end()) ratios += absl::StrFormat(" %s %.2fx", flow, it->second / u0_ms);
    }
    if (!ratios.empty()) std::printf("\nCotangent flows against laplacian U0 (1 thread):%s.\n", ratios.c_str());
    if (!peers.empty()) {
      std::printf("\n| peer (1 thread) | ms/iteration | ours | ours ms/iteration | peer / ours |\n|---|---|---|---|---|\n");
      for (const Peer& peer : peers) {
        if (!ours_1t[nm.name].count(peer.ours)) continue;
        std::vector<double> t;
        const int peer_iterations = std::max(1, iterations / 4);
        for (int r = 0; r < opt.runs; ++r) t.push_back(peer.run(nm.mesh, peer_iterations) / peer_iterations);
        const double theirs = Median(t), ours = ours_1t[nm.name][peer.ours];
        std::printf("| %s | %.2f | %s | %.2f | %.1fx |\n", peer.name.c_str(), theirs, peer.ours.c_str(), ours,
                    theirs / ours);
      }
    }
    const double peak = PeakBytesPerVertex(nm.mesh, self);
    std::printf("\nPeak memory of a job (median, 5 iterations; upload, decode, topology, smoothing, encoded result): %.0f bytes/vertex.\n", peak);
  }
  if (opt.service) {
    std::printf("\n## Through the service (loopback TCP, laplacian U0, 10 iterations, lossless sequential Draco)\n\n");
    std::printf("| mesh | upload | total ms | decode+validate | queue | smooth | encode | overhead (total - smooth) | bare Draco decode+encode | overhead / bare | DracoMesh::Decode (welds) + Encode |\n|---|---|---|---|---|---|---|---|---|---|---|\n");
    std::map<std::string, double> bare_ms;
    for (const NamedMesh& nm : meshes) {
      if (nm.mesh.num_vertices() < 600'000) continue;
      bare_ms[nm.name] = ServiceRow(nm, 10, opt.runs);
    }
    for (const NamedMesh& nm : meshes) {
      if (nm.mesh.num_vertices() < 600'000 || nm.mesh.num_vertices() >= 1'000'000) continue;
      ServiceBreakdown(nm, opt.runs);
      ServiceFloor(nm, opt.runs, bare_ms[nm.name]);
    }
  }
  return 0;
}
