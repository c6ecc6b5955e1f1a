// meshsmooth_peer: one peer smoother (bench/peers.h) as a program of its own, so that its whole
// process (start, read, smooth, write) can be timed beside the CLI's:
//
//   build/bench/meshsmooth_peer [--time T] PEER ITERATIONS IN OUT
//
// meshsmooth_peer knows every peer of the build; meshsmooth_peer_openmesh, _open3d and _cgal are
// this same file linked with one library each, so that a process loads only what a user of that
// library would (bench/CMakeLists.txt).
//
// Reads IN with our readers (OBJ, PLY, OFF, STL, Draco), runs PEER for ITERATIONS iterations,
// writes OUT with our writer (format by extension; vertex i of OUT is vertex i of IN) and prints
// one line, "PEER: N iterations; time: read Rs, smooth Ss, write Ws", S being the peer's
// smoothing call alone. Like the CLI, it re-executes itself with huge pages for inputs of 4 MiB
// and more (base/huge_pages.h), so both processes allocate the same way.
//
// Exit codes: 0 success; 1 IN could not be read or OUT written; 2 bad command line.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "base/huge_pages.h"
#include "bench/bench_common.h"
#include "bench/peers.h"
#include "core/io/mesh_io.h"

namespace meshsmooth::bench {
namespace {

constexpr int kExitFailed = 1;
constexpr int kExitUsage = 2;
constexpr int kMaxIterations = 100000;
constexpr std::uintmax_t kHugePagesMinInputBytes = 4u << 20;  // the CLI's threshold (client/main.cc)

void PrintUsage(std::FILE* to, const char* self) {
  std::fprintf(to,
               "usage: %s [--time T] PEER ITERATIONS IN OUT\n"
               "  Runs one other library's smoother on IN (OBJ, PLY, OFF, STL or .drc) for ITERATIONS\n"
               "  (0..%d) iterations and writes OUT (format by extension), vertex for vertex; prints\n"
               "  \"PEER: N iterations; time: read Rs, smooth Ss, write Ws\" (S: the smoothing call alone).\n"
               "  --time T  cgal_smooth_shape's time step in squared mean edge lengths (default %g)\n"
               "PEER, in this program:\n",
               std::filesystem::path(self).filename().c_str(), kMaxIterations, kSmoothShapeTime);
  for (const Peer& p : AllPeers()) std::fprintf(to, "  %-28s %s\n", p.id.c_str(), p.name.c_str());
  std::fprintf(to, "Exit codes: 0 success, 1 IN unreadable or OUT unwritable, 2 bad command line.\n");
}

// `s` as a whole number in [lo, hi]; false otherwise.
bool ParseInt(const std::string& s, int lo, int hi, int& out) {
  char* end = nullptr;
  const long v = std::strtol(s.c_str(), &end, 10);
  if (s.empty() || *end != '\0' || v < lo || v > hi) return false;
  out = static_cast<int>(v);
  return true;
}

int Main(int argc, char** argv) {
  std::vector<std::string> args;
  double time = kSmoothShapeTime;
  for (int i = 1; i < argc; ++i) {
    const std::string_view a = argv[i];
    if (a == "--help" || a == "-h") {
      PrintUsage(stdout, argv[0]);
      return 0;
    }
    if (a == "--time") {
      char* end = nullptr;
      time = i + 1 < argc ? std::strtod(argv[++i], &end) : 0.0;
      if (end == nullptr || *end != '\0' || !(time > 0.0)) {
        std::fprintf(stderr, "meshsmooth_peer: --time needs a number above 0\n");
        return kExitUsage;
      }
      continue;
    }
    args.emplace_back(a);
  }
  if (args.size() != 4) {
    PrintUsage(stderr, argv[0]);
    return kExitUsage;
  }
  const std::vector<Peer> peers = AllPeers(time);
  const Peer* peer = FindPeer(peers, args[0]);
  if (peer == nullptr) {
    std::fprintf(stderr, "meshsmooth_peer: unknown peer \"%s\" (--help lists the peers of this program)\n",
                 args[0].c_str());
    return kExitUsage;
  }
  int iterations = 0;
  if (!ParseInt(args[1], 0, kMaxIterations, iterations)) {
    std::fprintf(stderr, "meshsmooth_peer: ITERATIONS must be a whole number in 0..%d, not \"%s\"\n", kMaxIterations,
                 args[1].c_str());
    return kExitUsage;
  }
  if (absl::StatusOr<MeshFormat> f = FormatFromPath(args[3]); !f.ok()) {
    std::fprintf(stderr, "meshsmooth_peer: OUT: %s\n", std::string(f.status().message()).c_str());
    return kExitUsage;
  }

  const Clock::time_point t0 = Clock::now();
  absl::StatusOr<Mesh> mesh = ReadMesh(args[2]);
  if (!mesh.ok()) {
    std::fprintf(stderr, "meshsmooth_peer: %s\n", std::string(mesh.status().message()).c_str());
    return kExitFailed;
  }
  const Clock::time_point t1 = Clock::now();
  PeerRun run = peer->run(*mesh, iterations);
  mesh->positions = std::move(run.positions);
  const Clock::time_point t2 = Clock::now();
  if (absl::Status s = WriteMesh(args[3], *mesh); !s.ok()) {
    std::fprintf(stderr, "meshsmooth_peer: %s\n", std::string(s.message()).c_str());
    return kExitFailed;
  }
  std::printf("%s: %d iterations; time: read %.3fs, smooth %.6fs, write %.3fs\n", peer->id.c_str(), iterations,
              Seconds(t0, t1), run.ms / 1000.0, Seconds(t2, Clock::now()));
  return 0;
}

}  // namespace
}  // namespace meshsmooth::bench

int main(int argc, char** argv) {
  // Before anything else, as the CLI does (client/main.cc): the input's size decides. The last
  // argument but one is IN when the command line is well formed; otherwise nothing happens here.
  if (argc >= 5) {
    std::error_code error;
    const std::uintmax_t bytes = std::filesystem::file_size(argv[argc - 2], error);
    if (!error && bytes >= meshsmooth::bench::kHugePagesMinInputBytes) meshsmooth::UseHugePagesForLargeBuffers(argv);
  }
  return meshsmooth::bench::Main(argc, argv);
}
