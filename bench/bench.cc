// meshsmooth_bench: how fast the flows run, beside their peers, against the memory bandwidth,
// and through the service. Prints Markdown; docs/performance.md is its output.
//
//   build/bench/meshsmooth_bench [--quick] [--runs 5] [--no-service] [--no-peers]
//                                [--levels 6,7,8,9] [--only LABEL,...] [--normal-filter-table] [--service-only]
//                                [--metrics] [FILE ...]
//
// --levels picks the icosphere levels (none: "--levels ''"); --only keeps the flows whose
// label contains one of the given words (e.g. --only "U0,mcf") and the peers compared with them.
// --normal-filter-table prints only the table of bilateral_normal's iteration against laplacian
// U0 on each mesh (normal_filter_speed.h), which the full run prints for the files given.
// --service-only prints only the service table ("Through the service"); --metrics runs its
// servers with Prometheus metrics on (--metrics-listen), to compare with a run without.
//
// Meshes: noisy icospheres of 40,962 / 163,842 / 655,362 / 2,621,442 vertices (levels 6-9,
// deterministic), plus any mesh file given. Every time is the median of --runs runs.
//
// This file holds the options and the order of the tables; each table's tool has a file of its
// own: bandwidth.cc, flow_speed.cc, normal_filter_speed.cc, peer_*.cc, peak_memory.cc,
// service_speed.cc, service_floor.cc.
#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "base/huge_pages.h"
#include "base/kernel_environment.h"
#include "bench/bandwidth.h"
#include "bench/bench_common.h"
#include "bench/flow_speed.h"
#include "bench/normal_filter_speed.h"
#include "bench/peak_memory.h"
#include "bench/peers.h"
#include "bench/service_floor.h"
#include "bench/service_speed.h"
#include "core/flows/reorder.h"
#include "core/io/mesh_io.h"
#include "core/topology.h"

namespace meshsmooth::bench {
namespace {

struct Options {
  int runs = 5;
  bool quick = false, service = true, peers = true, default_job_only = false, normal_filter_table = false;
  bool service_only = false;
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

// The non-empty parts of a comma-separated list.
std::vector<std::string> SplitCommas(const std::string& s) { return absl::StrSplit(s, ',', absl::SkipEmpty()); }

// The section of one mesh: our flows' speed (with the plain loop's ceiling against `bw2`, the
// DRAM bandwidth on 2 threads), bilateral_normal's parts, the peers beside the flows they
// compare with, and the peak memory of a job (measured by re-running `self`).
void MeshSection(const NamedMesh& nm, const Options& opt, const std::vector<Peer>& peers, double bw2, int hw,
                 const std::string& self) {
  const Topology topo = BuildTopology(nm.mesh);
  const int32_t n = nm.mesh.num_vertices();
  const int iterations = IterationsFor(n);
  const double valence = static_cast<double>(topo.ring.size()) / std::max(n, 1);
  std::printf("\n## %s (%d vertices, %d iterations per run, %s)\n\n", nm.name.c_str(), n, iterations,
              MortonOrderPaysOff(topo, iterations) ? "run in Morton order" : "run in its own order");
  std::printf(
      "| flow | ms/iteration, 1 thread | 2 threads | speed-up | Mvertex-it/s (2 threads) | bytes/vertex | share of "
      "DRAM bound (2 threads) | set-up ms (1 thread) |\n|---|---|---|---|---|---|---|---|\n");
  std::map<std::string, double> ours_1t;  // variant -> ms per iteration
  double u0_ms = 0.0, u0_ms2[2] = {0.0, 0.0};
  for (const Variant& v : Variants()) {
    if (!opt.Wanted(v.label) && v.label != "laplacian U0") continue;  // U0 is every ratio's base
    const OurTiming one = TimeOurs(nm.mesh, topo, v.params, iterations, 1, opt.runs);
    const OurTiming two = TimeOurs(nm.mesh, topo, v.params, iterations, std::min(2, hw), opt.runs);
    const double t1 = one.per_iteration_ms, t2 = two.per_iteration_ms;
    ours_1t[v.label] = t1;
    if (v.label == "laplacian U0") u0_ms = u0_ms2[0] = t1, u0_ms2[1] = t2;
    const double bytes = BytesPerVertex(v.params.flow.value_or(kDefaultFlow), valence);
    const double gbs = bytes * n / (t2 / 1000.0) / 1e9;
    std::printf("| %s | %.2f | %.2f | %.2fx | %.0f | %.0f | %.0f%% | %.1f |\n", v.label.c_str(), t1, t2, t1 / t2,
                n / (t2 / 1000.0) / 1e6, bytes, 100.0 * gbs / bw2, one.setup_ms);
  }
  {
    const double t1 = PlainU0Ms(nm.mesh, topo, iterations, 1, opt.runs);
    const double t2 = PlainU0Ms(nm.mesh, topo, iterations, std::min(2, hw), opt.runs);
    const double bytes = BytesPerVertex(FlowId::kLaplacian, valence);
    std::printf(
        "| (reference) plain CSR U0 loop, same order, no checks | %.2f | %.2f | %.2fx | %.0f | %.0f | %.0f%% "
        "| - |\n",
        t1, t2, t1 / t2, n / (t2 / 1000.0) / 1e6, bytes, 100.0 * bytes * n / (t2 / 1000.0) / 1e9 / bw2);
  }
  if (opt.Wanted("bilateral_normal")) NormalFilterRows(nm.mesh, topo, u0_ms2, hw, opt.runs);
  std::string ratios;  // none when --only left the cotangent flows out
  for (const char* flow : {"mcf", "mcf_tangential", "median"}) {
    const auto it = ours_1t.find(flow);
    if (it != ours_1t.end()) ratios += absl::StrFormat(" %s %.2fx", flow, it->second / u0_ms);
  }
  if (!ratios.empty()) std::printf("\nCotangent flows against laplacian U0 (1 thread):%s.\n", ratios.c_str());
  if (!peers.empty()) {
    std::printf(
        "\n| peer (1 thread) | ms/iteration | ours | ours ms/iteration | peer / ours |\n|---|---|---|---|---|\n");
    for (const Peer& peer : peers) {
      if (!ours_1t.count(peer.ours)) continue;
      std::vector<double> t;
      const int peer_iterations = std::max(1, iterations / 4);
      for (int r = 0; r < opt.runs; ++r) t.push_back(peer.run(nm.mesh, peer_iterations).ms / peer_iterations);
      const double theirs = Median(t), ours = ours_1t[peer.ours];
      std::printf("| %s | %.2f | %s | %.2f | %.1fx |\n", peer.name.c_str(), theirs, peer.ours.c_str(), ours,
                  theirs / ours);
    }
  }
  const double peak = PeakBytesPerVertex(nm.mesh, self);
  std::printf(
      "\nPeak memory of a job (median, 5 iterations; upload, decode, topology, smoothing, encoded result): %.0f "
      "bytes/vertex.\n",
      peak);
}

}  // namespace
}  // namespace meshsmooth::bench

int main(int argc, char** argv) {
  meshsmooth::UseHugePagesForLargeBuffers(argv);  // first: may re-execute the program
  meshsmooth::ApplyKernelEnvironment();
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
    } else if (a == "--only" && i + 1 < argc) {
      opt.only = SplitCommas(argv[++i]);
    } else if (a == "--runs" && i + 1 < argc) {
      opt.runs = std::max(1, std::atoi(argv[++i]));
    } else if (a == "--no-service") {
      opt.service = false;
    } else if (a == "--no-peers") {
      opt.peers = false;
    } else if (a == "--service-only") {
      opt.service_only = true;
    } else if (a == "--metrics") {
      SetServiceMetrics(true);
    } else if (a == "--default-job-only") {
      opt.default_job_only = true;
    } else if (a == "--normal-filter-table") {
      opt.normal_filter_table = true;
    } else if (a == "--peak-child" && i + 1 < argc) {
      return PeakChild(argv[i + 1]);
    } else if (a == "--help" || a == "-h") {
      std::printf(
          "usage: %s [--quick] [--runs N] [--no-service] [--no-peers] [--levels 6,7,8,9] [--only LABEL,...] "
          "[--default-job-only] [--normal-filter-table] [--service-only] [--metrics] [MESH_FILE ...]\n",
          argv[0]);
      return 0;
    } else {
      opt.files.push_back(a);
    }
  }
  std::setvbuf(stdout, nullptr, _IOLBF, 0);  // rows appear as they are measured
  if (opt.default_job_only) opt.levels.clear();
  if (opt.normal_filter_table) opt.service = false;
  if (opt.service_only) opt.default_job_only = false;
  char self_buf[4096] = {};
  const ssize_t self_len = readlink("/proc/self/exe", self_buf, sizeof self_buf - 1);
  const std::string self = self_len > 0 ? std::string(self_buf, self_len) : std::string(argv[0]);
  const int hw = omp_get_max_threads();
  std::printf("# meshsmooth performance\n\nMachine: %d hardware threads. Command: `", hw);
  for (int i = 0; i < argc; ++i) std::printf("%s%s", i ? " " : "", argv[i]);
  std::printf("`. Times are medians of %d runs.\n", opt.runs);

  double bw2 = 0.0;
  if (!opt.default_job_only && !opt.normal_filter_table && !opt.service_only) {
    std::printf(
        "\n## Memory bandwidth (STREAM-like triad, 24 bytes per element)\n\n| arrays | 1 thread | 2 threads "
        "|\n|---|---|---|\n");
    const double cache1 = Triad(256 << 10, 1), cache2 = Triad(256 << 10, std::min(2, hw));
    std::printf("| 3 x 256 KiB (cache) | %.1f GB/s | %.1f GB/s |\n", cache1, cache2);
    const size_t big = opt.quick ? (size_t{256} << 20) : (size_t{1} << 30);
    const double bw1 = Triad(big, 1);
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

  if (opt.service && !opt.service_only) {
    std::printf(
        "\n## The default job through the service (loopback TCP, no JobSpec field set; clean, and with Gaussian "
        "noise of 0.2 h along the normals)\n\n| mesh | noise (h) | iterations, stop (noise estimate, h) | total ms | "
        "decode+validate | smooth | encode |\n|---|---|---|---|---|---|---|\n");
    for (const NamedMesh& nm : meshes) DefaultJobRows(nm, "", opt.runs);
    // The normal-filtering flow's default job on the files given (docs/performance.md, "The default job on the
    // dragon").
    if (opt.Wanted("bilateral_normal")) {
      for (size_t i = opt.levels.size(); i < meshes.size(); ++i) {
        DefaultJobRows(meshes[i], "bilateral_normal", opt.runs);
      }
    }
  }
  if (opt.default_job_only) return 0;
  // bilateral_normal's iteration against laplacian U0, on the files given (or every mesh with
  // --normal-filter-table).
  const size_t first_table_mesh = opt.normal_filter_table ? 0 : opt.levels.size();
  if (!opt.service_only && opt.Wanted("bilateral_normal") && first_table_mesh < meshes.size()) {
    std::printf("\n## bilateral_normal's iteration against laplacian U0\n");
    NormalFilterIterationHeader();
    for (size_t i = first_table_mesh; i < meshes.size(); ++i) {
      NormalFilterIterationRow(meshes[i].name, meshes[i].mesh, BuildTopology(meshes[i].mesh), hw, opt.runs);
    }
  }
  if (opt.normal_filter_table) return 0;

  std::vector<Peer> peers;
  if (opt.peers) peers = AllPeers();
  if (!opt.service_only) {
    for (const NamedMesh& nm : meshes) MeshSection(nm, opt, peers, bw2, hw, self);
  }
  if (opt.service) {
    std::printf("\n## Through the service (loopback TCP, laplacian U0, 10 iterations, lossless sequential Draco)\n\n");
    std::printf(
        "| mesh | upload | total ms | decode+validate | queue | smooth | encode | overhead (total - smooth) | bare "
        "Draco decode+encode | overhead / bare | DracoMesh::Decode (welds) + Encode |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|\n");
    std::map<std::string, double> bare_ms;
    for (const NamedMesh& nm : meshes) {
      if (nm.mesh.num_vertices() < 600'000) continue;
      bare_ms[nm.name] = ServiceRow(nm, 10, opt.runs);
    }
    for (const NamedMesh& nm : meshes) {
      if (opt.service_only) break;  // the table's rows only
      if (nm.mesh.num_vertices() < 600'000 || nm.mesh.num_vertices() >= 1'000'000) continue;
      ServiceBreakdown(nm, opt.runs);
      ServiceFloor(nm, opt.runs, bare_ms[nm.name]);
    }
  }
  return 0;
}
