// meshsmooth_time_to_quality: how long it takes to get a good mesh, with the CLI's default job
// and with other libraries' smoothers at their best iteration counts, each as a whole process.
// For each mesh and noise level (the quality benchmark's noisy inputs, bench/quality_inputs.h)
// one table: the noisy input, the CLI's default job, the flow and count it chose run
// explicitly, and each peer at its oracle count (the count, of a sweep, with the least RMS
// distance to the clean surface), with what each result measures against the clean mesh and
// its smoothing and whole-process times. `--scale` adds the default job on a 2.6M-vertex
// icosphere: time and peak memory per vertex. Markdown to stdout, progress to stderr;
// docs/performance.md ("Time to a good mesh") is its output. `--help` says the rest.
#include <fcntl.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "bench/bench_common.h"
#include "bench/peers.h"
#include "bench/quality_inputs.h"
#include "core/io/mesh_io.h"
#include "core/measure/evaluation.h"
#include "core/shapes/added_noise.h"
#include "core/shapes/parametric.h"

extern char** environ;

namespace meshsmooth::bench {
namespace {

namespace fs = std::filesystem;

constexpr int kExitFailed = 1;
constexpr int kExitUsage = 2;

constexpr char kUsage[] =
    "usage: meshsmooth_time_to_quality [--meshes a,b,...] [--sigmas 0.1,0.2,0.3] [--seed 1] [--runs 3]\n"
    "                                  [--peers a,b,...] [--counts 1,2,3,...] [--smooth-shape-time T]\n"
    "                                  [--scale] [--scale-only] [--scale-sigma 0.2] [--scale-level 9]\n"
    "                                  [--cli PATH]\n"
    "                                  [--peer-program PATH] [--shared DIR] [--workdir DIR]\n"
    "Time to a good mesh: for each mesh and sigma, the quality benchmark's noisy input (Gaussian noise\n"
    "of sigma h along the normals, h the mean edge length, from --seed; bench/quality_inputs.h),\n"
    "written as binary PLY, then one table whose rows are whole processes run on that file:\n"
    "  meshsmooth default job   `meshsmooth smooth IN -o OUT` (the CLI chooses flow and count); its\n"
    "                           smoothing time is the job summary's `time: ... smooth Xs`, its flow and\n"
    "                           count the summary's `job ...: FLOW, N iterations`\n"
    "  chosen flow, explicit    `meshsmooth smooth IN -o OUT --flow FLOW --iterations N`, same FLOW, N\n"
    "  each peer (oracle)       `meshsmooth_peer PEER N IN OUT` at the count N with the least RMS\n"
    "                           distance to the clean surface among --counts, swept in this process;\n"
    "                           the sweep stops once two counts in a row are worse than the best;\n"
    "                           a best count that ends the sweep is marked so\n"
    "Each row gives the RMS distance of the written result to the clean surface (in h), its mean\n"
    "face-normal error, the smoothing call's time (as the process printed it), the whole process's\n"
    "wall time (spawn to exit) and its peak resident memory (wait4's ru_maxrss), medians of --runs\n"
    "runs; then the ratios default smoothing / explicit smoothing, default whole process / best\n"
    "peer's whole process and default RMS / best peer's RMS (best peer: the least RMS).\n"
    "  --meshes       names as meshsmooth_quality takes them (default: fandisk, turbine,\n"
    "                 stanford-bunny, nefertiti, stanford-dragon; '' for none)\n"
    "  --sigmas       noise levels in h (default 0.1,0.2,0.3)\n"
    "  --runs         processes per row; times are medians (default 3)\n"
    "  --peers        peer names as meshsmooth_peer --help lists them (default: open3d_laplacian,\n"
    "                 open3d_taubin, openmesh_c0, openmesh_c1, cgal_smooth_shape; those this build\n"
    "                 lacks are left out with a note)\n"
    "  --counts       the iteration counts of the peers' sweep (default\n"
    "                 1,2,3,5,8,12,20,32,50,80,128,200)\n"
    "  --smooth-shape-time T  cgal_smooth_shape's time step in h^2 (default 0.03)\n"
    "  --scale        also the default job on an icosphere (--scale-level) with Gaussian noise\n"
    "                 of --scale-sigma h along the normals: time and peak memory per vertex, beside\n"
    "                 the dragon's at the same sigma when this run has it; --scale-only: only that\n"
    "  --scale-level N  the icosphere's subdivision level, 1..11 (default 9; 10: 10,485,762 vertices)\n"
    "  --cli PATH     the meshsmooth CLI (default: ../client/meshsmooth beside this program)\n"
    "  --peer-program PATH  the program that runs every peer (default: meshsmooth_peer_LIBRARY beside\n"
    "                 this program, the one linking only the peer's own library)\n"
    "  --shared DIR   the folder holding data/meshes (default: ../shared beside the source tree)\n"
    "  --workdir DIR  where the inputs and results are written (default: a new directory in the\n"
    "                 system's temporary directory, removed at the end)\n"
    "Run it alone (under the build lock when others build): every time is a wall time.\n"
    "Exit codes: 0 success, 1 a mesh, program or process failed, 2 bad command line.\n";

const std::vector<std::string> kDefaultTtqMeshes = {"fandisk", "turbine", "stanford-bunny", "nefertiti",
                                                    "stanford-dragon"};
const std::vector<std::string> kDefaultPeers = {"open3d_laplacian", "open3d_taubin", "openmesh_c0", "openmesh_c1",
                                                "cgal_smooth_shape"};

struct Options {
  std::vector<std::string> meshes = kDefaultTtqMeshes;
  std::vector<double> sigmas = {0.1, 0.2, 0.3};
  uint64_t seed = 1;
  int runs = 3;
  std::vector<std::string> peers = kDefaultPeers;
  std::vector<int> counts = {1, 2, 3, 5, 8, 12, 20, 32, 50, 80, 128, 200};
  double smooth_shape_time = kSmoothShapeTime;
  bool scale = false;
  double scale_sigma = 0.2;
  int scale_level = 9;  // Icosphere(9): 2,621,442 vertices
  fs::path cli, workdir;
  fs::path peer_program;  // empty: meshsmooth_peer_LIBRARY beside this program, per peer (PeerProgram)
  fs::path shared = fs::path(MESHSMOOTH_SOURCE_DIR) / ".." / "shared";
  fs::path self_dir;  // where this program is
};

// The program that runs `peer` as a whole process: --peer-program, else the one linking only the
// peer's library, so that its process loads no other library's code.
fs::path PeerProgram(const Options& opt, const Peer& peer) {
  return opt.peer_program.empty() ? opt.self_dir / ("meshsmooth_peer_" + peer.library) : opt.peer_program;
}

// A finished child process.
struct Process {
  int exit_code = -1;  // -1: it did not exit by itself
  double seconds = 0.0;
  double max_rss_bytes = 0.0;
  std::string out, err;
  bool ok() const { return exit_code == 0; }
};

std::string ReadText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Runs `argv` with stdin from /dev/null and stdout, stderr into files of `dir`; the time is from
// just before the spawn to the return of wait4. Fills all of `p` but its output.
void SpawnAndWait(const std::vector<std::string>& argv, const fs::path& dir, Process& p) {
  const std::string out_path = (dir / "stdout.txt").string(), err_path = (dir / "stderr.txt").string();
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 1, out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&actions, 2, err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const Clock::time_point t0 = Clock::now();
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) return;  // exit_code stays -1; the stderr file says nothing, the caller does
  int status = 0;
  rusage usage{};
  while (wait4(pid, &status, 0, &usage) < 0 && errno == EINTR) {
  }
  p.seconds = Seconds(t0, Clock::now());
  p.max_rss_bytes = 1024.0 * static_cast<double>(usage.ru_maxrss);  // Linux: kilobytes
  if (WIFEXITED(status)) p.exit_code = WEXITSTATUS(status);
}

bool WriteAll(int fd, const void* data, size_t size) {
  const char* c = static_cast<const char*>(data);
  while (size > 0) {
    const ssize_t n = write(fd, c, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    c += n;
    size -= static_cast<size_t>(n);
  }
  return true;
}

bool ReadAll(int fd, void* data, size_t size) {
  char* c = static_cast<char*>(data);
  while (size > 0) {
    const ssize_t n = read(fd, c, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    c += n;
    size -= static_cast<size_t>(n);
  }
  return true;
}

// Starts the measured processes from a small process forked before this one grows. A child's
// ru_maxrss is at least the high-water mark of the address space it was started from (exec
// keeps the larger of the two, and posix_spawn's child starts in its parent's address space), so
// children started from this process would all report its own peak: the ground truth of the
// largest mesh so far. The helper's own peak is a few MB.
class Spawner {
 public:
  // Forks the helper; call it first thing, before any thread exists. False if that failed.
  bool Start() {
    int to[2], from[2];
    if (pipe(to) != 0 || pipe(from) != 0) return false;
    pid_ = fork();
    if (pid_ < 0) return false;
    if (pid_ == 0) {
      close(to[1]);
      close(from[0]);
      Serve(to[0], from[1]);
      _exit(0);  // not exit(): the parent's stdio buffers are not the helper's to flush
    }
    close(to[0]);
    close(from[1]);
    to_ = to[1];
    from_ = from[0];
    return true;
  }

  ~Spawner() {
    if (pid_ <= 0) return;
    close(to_);  // the helper reads end of file and exits
    close(from_);
    int status = 0;
    waitpid(pid_, &status, 0);
  }

  // `argv` run by the helper (SpawnAndWait), with its output read back.
  Process Run(const std::vector<std::string>& argv, const fs::path& dir) {
    Process p;
    std::vector<std::string> request = argv;
    request.push_back(dir.string());
    const uint32_t count = static_cast<uint32_t>(request.size());
    bool ok = WriteAll(to_, &count, sizeof count);
    for (const std::string& a : request) {
      const uint32_t size = static_cast<uint32_t>(a.size());
      ok = ok && WriteAll(to_, &size, sizeof size) && WriteAll(to_, a.data(), a.size());
    }
    ok = ok && ReadAll(from_, &p.exit_code, sizeof p.exit_code) && ReadAll(from_, &p.seconds, sizeof p.seconds) &&
         ReadAll(from_, &p.max_rss_bytes, sizeof p.max_rss_bytes);
    if (!ok) {
      p.exit_code = -1;
      p.err = "the helper process that starts the programs is gone";
      return p;
    }
    p.out = ReadText(dir / "stdout.txt");
    p.err = ReadText(dir / "stderr.txt");
    if (p.exit_code == -1 && p.err.empty()) p.err = absl::StrFormat("%s did not start or did not exit", argv[0]);
    return p;
  }

 private:
  static void Serve(int in, int out) {
    for (uint32_t count = 0; ReadAll(in, &count, sizeof count);) {
      std::vector<std::string> request(count);
      for (std::string& a : request) {
        uint32_t size = 0;
        if (!ReadAll(in, &size, sizeof size)) return;
        a.resize(size);
        if (!ReadAll(in, a.data(), size)) return;
      }
      const fs::path dir = request.back();
      request.pop_back();
      Process p;
      SpawnAndWait(request, dir, p);
      if (!WriteAll(out, &p.exit_code, sizeof p.exit_code) || !WriteAll(out, &p.seconds, sizeof p.seconds) ||
          !WriteAll(out, &p.max_rss_bytes, sizeof p.max_rss_bytes)) {
        return;
      }
    }
  }

  pid_t pid_ = -1;
  int to_ = -1, from_ = -1;
};

// The seconds of "LABEL Xs" in a job summary ("smooth": the smoothing call, also in a
// meshsmooth_peer line; "total": the job's own time inside the process).
std::optional<double> SecondsOf(const std::string& out, const std::string& label) {
  const std::regex pattern(label + R"( ([0-9.]+)s)");
  std::smatch m;
  if (!std::regex_search(out, m, pattern)) return std::nullopt;
  return std::atof(m[1].str().c_str());
}

// The flow and iteration count of a job summary's first line, "job ID: FLOW, N iterations ..."
// or "job ID: FLOW, N of M iterations ...".
std::optional<std::pair<std::string, int>> ChosenFlow(const std::string& out) {
  static const std::regex kJob(R"(job [^\n]*?: ([A-Za-z0-9_]+), ([0-9]+) (of [0-9]+ )?iterations)");
  std::smatch m;
  if (!std::regex_search(out, m, kJob)) return std::nullopt;
  return std::make_pair(m[1].str(), std::atoi(m[2].str().c_str()));
}

// One row's measurements: `runs` processes, their medians, and the first one's result measured.
struct Row {
  std::string label, iterations;
  std::optional<Quality> quality;
  double smooth_s = NAN, process_s = NAN, rss_bytes = NAN;
  double beyond_job_s = NAN;  // whole process less the job's own total (the CLI's rows)
  std::string failure;        // empty when every process succeeded
  std::string out;            // the first process's stdout
};

Row RunRow(Spawner& spawner, const std::string& label, const std::vector<std::string>& argv, const fs::path& output,
           const GroundTruth& truth, int runs, const fs::path& dir) {
  Row row;
  row.label = label;
  std::vector<double> smooth, process, rss, beyond;
  for (int r = 0; r < runs; ++r) {
    std::error_code ignored;
    fs::remove(output, ignored);
    const Process p = spawner.Run(argv, dir);
    if (!p.ok()) {
      row.failure = absl::StrFormat("exit %d: %s", p.exit_code, absl::StripAsciiWhitespace(p.err));
      std::fprintf(stderr, "  %s failed (%s)\n", absl::StrJoin(argv, " ").c_str(), row.failure.c_str());
      return row;
    }
    if (r == 0) {
      row.out = p.out;
      absl::StatusOr<Mesh> result = ReadMesh(output.string());
      absl::StatusOr<Quality> q = result.ok() ? truth.Evaluate(*result) : result.status();
      if (!q.ok()) {
        row.failure = std::string(q.status().message());
        return row;
      }
      row.quality = *q;
    }
    const std::optional<double> s = SecondsOf(p.out, "smooth");
    smooth.push_back(s ? *s : NAN);
    const std::optional<double> job = SecondsOf(p.out, "total");
    beyond.push_back(job ? p.seconds - *job : NAN);
    process.push_back(p.seconds);
    rss.push_back(p.max_rss_bytes);
  }
  row.smooth_s = Median(smooth);
  row.process_s = Median(process);
  row.rss_bytes = Median(rss);
  row.beyond_job_s = Median(beyond);
  return row;
}

std::string Fixed(double v, int digits) { return std::isnan(v) ? "-" : absl::StrFormat("%.*f", digits, v); }

void PrintRow(const Row& r) {
  if (!r.failure.empty()) {
    std::printf("| %s | %s | failed: %s | | | | |\n", r.label.c_str(), r.iterations.c_str(), r.failure.c_str());
    return;
  }
  std::printf("| %s | %s | %s | %s | %s | %s | %s |\n", r.label.c_str(), r.iterations.c_str(),
              Fixed(r.quality->rms_distance, 3).c_str(), Fixed(r.quality->normal_error_deg, 2).c_str(),
              Fixed(r.smooth_s, 3).c_str(), Fixed(r.process_s, 3).c_str(), Fixed(r.rss_bytes / 1e6, 0).c_str());
}

// The count of `counts` at which `peer` leaves `noisy` closest to the clean surface (RMS); the
// sweep stops once two counts in a row are worse than the best. 0 when no count gave a finite
// result.
int OracleCount(const Peer& peer, const Mesh& noisy, const GroundTruth& truth, const std::vector<int>& counts) {
  int best = 0, worse = 0;
  double best_rms = HUGE_VAL;
  Mesh result = noisy;
  for (int count : counts) {
    result.positions = peer.run(noisy, count).positions;
    const absl::StatusOr<Quality> q = truth.Evaluate(result);
    const double rms = q.ok() && q->non_finite_vertices == 0 ? q->rms_distance : HUGE_VAL;
    std::fprintf(stderr, "    %s, %d iterations: RMS %.4f h\n", peer.id.c_str(), count, rms);
    if (rms < best_rms) {
      best = count;
      best_rms = rms;
      worse = 0;
    } else if (++worse == 2) {
      break;
    }
  }
  return best;
}

// One mesh and sigma: the rows the summary and the scale section take up again.
struct CaseResult {
  std::string mesh;
  double sigma = 0.0;
  int32_t vertices = 0;
  Row row, expl;            // the default job, the chosen flow run explicitly
  std::optional<Row> best;  // the peer with the least RMS, if any succeeded
  bool failed() const { return !row.failure.empty(); }
};

CaseResult MeshCase(Spawner& spawner, const Options& opt, const Subject& subject, double sigma,
                    const std::vector<const Peer*>& peers, const fs::path& dir) {
  const GroundTruth& truth = *subject.truth;
  const Case c{Noise::kNormal, sigma};
  const std::string stem = absl::StrFormat("%s-%g", subject.name, sigma);
  const fs::path input = dir / (stem + ".ply");
  const fs::path output = dir / (stem + "-out.ply");
  CaseResult job{subject.name, sigma, truth.mesh().num_vertices(), {}, {}, {}};
  if (absl::Status s = WriteMesh(input.string(), MakeNoisy(truth.mesh(), c, opt.seed)); !s.ok()) {
    job.row.failure = std::string(s.message());
    std::fprintf(stderr, "%s: %s\n", input.c_str(), job.row.failure.c_str());
    return job;
  }
  // Read back: the peers' sweep starts from the very bytes the processes read.
  absl::StatusOr<Mesh> read = ReadMesh(input.string());
  if (!read.ok()) {
    job.row.failure = std::string(read.status().message());
    std::fprintf(stderr, "%s: %s\n", input.c_str(), job.row.failure.c_str());
    return job;
  }
  const Mesh noisy = *std::move(read);
  std::printf("\n### %s (%s vertices), %s\n\n", subject.name.c_str(),
              absl::StrFormat("%d", truth.mesh().num_vertices()).c_str(), c.Name().c_str());
  std::printf(
      "| run | iterations | RMS distance (h) | normal error (deg) | smoothing (s) | whole process (s) | peak RSS (MB) "
      "|\n|---|---|---|---|---|---|---|\n");
  if (absl::StatusOr<Quality> q = truth.Evaluate(noisy); q.ok()) {
    std::printf("| noisy input | - | %.3f | %.2f | - | - | - |\n", q->rms_distance, q->normal_error_deg);
  }

  const std::string cli = opt.cli.string();
  std::fprintf(stderr, "%s, sigma %g: default job\n", subject.name.c_str(), sigma);
  job.row = RunRow(spawner, "meshsmooth default job", {cli, "smooth", input.string(), "-o", output.string()}, output,
                   truth, opt.runs, dir);
  const std::optional<std::pair<std::string, int>> chosen = ChosenFlow(job.row.out);
  if (job.row.failure.empty() && !chosen) job.row.failure = "no `job ...: FLOW, N iterations` line in its output";
  if (chosen) {
    job.row.label = absl::StrFormat("meshsmooth default job: %s", chosen->first);
    job.row.iterations = absl::StrFormat("%d (automatic)", chosen->second);
  }
  PrintRow(job.row);
  Row& expl = job.expl;
  expl.failure = "not run";
  if (chosen) {
    std::fprintf(stderr, "%s, sigma %g: %s, %d iterations\n", subject.name.c_str(), sigma, chosen->first.c_str(),
                 chosen->second);
    expl = RunRow(spawner, absl::StrFormat("chosen flow, explicit: %s", chosen->first),
                  {cli, "smooth", input.string(), "-o", output.string(), "--flow", chosen->first, "--iterations",
                   absl::StrFormat("%d", chosen->second)},
                  output, truth, opt.runs, dir);
    expl.iterations = absl::StrFormat("%d", chosen->second);
    PrintRow(expl);
  }

  const Row* best = nullptr;
  std::vector<Row> peer_rows;
  peer_rows.reserve(peers.size());
  for (const Peer* peer : peers) {
    std::fprintf(stderr, "%s, sigma %g: %s, sweep\n", subject.name.c_str(), sigma, peer->id.c_str());
    const int count = OracleCount(*peer, noisy, truth, opt.counts);
    Row& row = peer_rows.emplace_back();
    if (count == 0) {
      row.label = peer->name;
      row.failure = "no finite result at any count";
    } else {
      row = RunRow(spawner, peer->name,
                   {PeerProgram(opt, *peer).string(), "--time", absl::StrFormat("%g", opt.smooth_shape_time), peer->id,
                    absl::StrFormat("%d", count), input.string(), output.string()},
                   output, truth, opt.runs, dir);
    }
    // A best count at the end of the sweep may not be the peer's best: the table says so.
    row.iterations = absl::StrFormat("%d (oracle%s)", count, count == opt.counts.back() ? ", end of sweep" : "");
    PrintRow(row);
  }
  for (const Row& r : peer_rows) {
    if (r.failure.empty() && (best == nullptr || r.quality->rms_distance < best->quality->rms_distance)) best = &r;
  }
  const Row& d = job.row;
  if (d.failure.empty()) {
    std::vector<std::string> ratios;
    if (expl.failure.empty() && expl.quality) {
      ratios.push_back(absl::StrFormat("default smoothing / explicit smoothing %.2fx", d.smooth_s / expl.smooth_s));
    }
    if (best != nullptr) {
      ratios.push_back(absl::StrFormat("default whole process / best peer's (%s) %.2fx", best->label,
                                       d.process_s / best->process_s));
      ratios.push_back(absl::StrFormat("default RMS / best peer's RMS %.2fx",
                                       d.quality->rms_distance / best->quality->rms_distance));
    }
    if (!ratios.empty()) std::printf("\nRatios: %s.\n", absl::StrJoin(ratios, "; ").c_str());
  }
  if (best != nullptr) job.best = *best;
  return job;
}

// One line per mesh and sigma: the default job against its explicit run and the best peer.
void SummaryTable(const std::vector<CaseResult>& cases) {
  std::printf(
      "\n### Summary\n\n"
      "| mesh | sigma (h) | default job | RMS (h) | smoothing (s) | whole process (s) | best peer, oracle count | "
      "RMS (h) | whole process (s) | default / explicit smoothing | default / best peer whole process | default / "
      "best peer RMS | explicit run: CLI beyond its job (ms) "
      "|\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const CaseResult& c : cases) {
    if (c.failed()) {
      std::printf("| %s | %g | failed: %s | | | | | | | | | | |\n", c.mesh.c_str(), c.sigma, c.row.failure.c_str());
      continue;
    }
    const std::string chosen = c.row.label.substr(c.row.label.find(':') + 1);
    std::printf("| %s | %g | %s, %s | %.3f | %.3f | %.3f |", c.mesh.c_str(), c.sigma,
                std::string(absl::StripAsciiWhitespace(chosen)).c_str(), c.row.iterations.c_str(),
                c.row.quality->rms_distance, c.row.smooth_s, c.row.process_s);
    if (c.best) {
      std::printf(" %s, %s | %.3f | %.3f |", c.best->label.c_str(), c.best->iterations.c_str(),
                  c.best->quality->rms_distance, c.best->process_s);
    } else {
      std::printf(" - | - | - |");
    }
    std::printf(" %s | %s | %s | %s |\n",
                c.expl.failure.empty() ? Fixed(c.row.smooth_s / c.expl.smooth_s, 2).c_str() : "-",
                c.best ? Fixed(c.row.process_s / c.best->process_s, 2).c_str() : "-",
                c.best ? Fixed(c.row.quality->rms_distance / c.best->quality->rms_distance, 2).c_str() : "-",
                c.expl.failure.empty() ? Fixed(c.expl.beyond_job_s * 1000.0, 1).c_str() : "-");
  }
}

// False when the CLI failed or the input could not be written.
bool ScaleSection(Spawner& spawner, const Options& opt, const std::vector<CaseResult>& jobs, const fs::path& dir) {
  std::fprintf(stderr, "scale: icosphere level %d\n", opt.scale_level);
  Mesh clean = Icosphere(opt.scale_level);
  Mesh noisy = clean;
  AddNormalNoise(noisy, opt.scale_sigma, opt.seed);
  const fs::path input = dir / "icosphere-scale.ply", output = dir / "icosphere-scale-out.ply";
  if (absl::Status s = WriteMesh(input.string(), noisy); !s.ok()) {
    std::fprintf(stderr, "%s: %s\n", input.c_str(), std::string(s.message()).c_str());
    return false;
  }
  const int32_t n = clean.num_vertices();
  std::printf("\n### The default job at scale: icosphere of %s vertices, normal noise, sigma = %g h\n\n",
              absl::StrFormat("%d", n).c_str(), opt.scale_sigma);
  std::printf(
      "| mesh | vertices | flow, iterations | whole process (s) | smoothing (s) | whole process (us/vertex) | "
      "smoothing (us/vertex) | peak RSS (bytes/vertex) |\n|---|---|---|---|---|---|---|---|\n");
  auto print = [](const std::string& mesh, int32_t vertices, const Row& r) {
    const std::optional<std::pair<std::string, int>> chosen = ChosenFlow(r.out);
    std::printf("| %s | %d | %s | %.3f | %.3f | %.2f | %.2f | %.0f |\n", mesh.c_str(), vertices,
                chosen ? absl::StrFormat("%s, %d", chosen->first, chosen->second).c_str() : "?", r.process_s,
                r.smooth_s, 1e6 * r.process_s / vertices, 1e6 * r.smooth_s / vertices, r.rss_bytes / vertices);
  };
  // The icosphere's result is not measured against the clean sphere here: only the CLI's time and
  // memory are asked for, and a ground truth of 2.6M vertices would double this section's time.
  Row row;
  std::vector<double> smooth, process, rss;
  for (int r = 0; r < opt.runs; ++r) {
    const Process p = spawner.Run({opt.cli.string(), "smooth", input.string(), "-o", output.string()}, dir);
    if (!p.ok()) {
      std::fprintf(stderr, "scale: the CLI failed (exit %d): %s\n", p.exit_code, p.err.c_str());
      std::printf("| icosphere | %d | failed (exit %d) | | | | | |\n", n, p.exit_code);
      return false;
    }
    if (r == 0) row.out = p.out;
    const std::optional<double> s = SecondsOf(p.out, "smooth");
    smooth.push_back(s ? *s : NAN);
    process.push_back(p.seconds);
    rss.push_back(p.max_rss_bytes);
  }
  row.smooth_s = Median(smooth);
  row.process_s = Median(process);
  row.rss_bytes = Median(rss);
  print(absl::StrFormat("icosphere level %d", opt.scale_level), n, row);
  for (const CaseResult& j : jobs) {
    if (j.mesh == "stanford-dragon" && j.sigma == opt.scale_sigma && !j.failed()) {
      print(absl::StrFormat("stanford-dragon, sigma = %g h", j.sigma), j.vertices, j.row);
    }
  }
  return true;
}

std::vector<double> ParseDoubles(const std::string& s) {
  std::vector<double> v;
  for (absl::string_view part : absl::StrSplit(s, ',', absl::SkipEmpty())) {
    v.push_back(std::atof(std::string(part).c_str()));
  }
  return v;
}

std::vector<std::string> ParseNames(const std::string& s) {
  std::vector<std::string> v;
  for (absl::string_view part : absl::StrSplit(s, ',', absl::SkipEmpty())) v.emplace_back(part);
  return v;
}

// A whole number >= `lo`; false otherwise.
bool ParseCount(const std::string& s, long lo, long& out) {
  char* end = nullptr;
  out = std::strtol(s.c_str(), &end, 10);
  return !s.empty() && *end == '\0' && out >= lo;
}

std::string CpuModel() {
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("model name", 0) == 0) {
      return std::string(absl::StripAsciiWhitespace(line.substr(line.find(':') + 1)));
    }
  }
  return "unknown CPU";
}

int Usage(const std::string& message) {
  std::fprintf(stderr, "meshsmooth_time_to_quality: %s\n%s", message.c_str(), kUsage);
  return kExitUsage;
}

int Main(int argc, char** argv) {
  Options opt;
  bool scale_only = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::fputs(kUsage, stdout);
      return 0;
    }
    if (a == "--scale") {
      opt.scale = true;
      continue;
    }
    if (a == "--scale-only") {
      opt.scale = scale_only = true;
      continue;
    }
    if (i + 1 >= argc) return Usage(absl::StrFormat("unknown option or missing value: %s", a));
    const std::string v = argv[++i];
    long number = 0;
    if (a == "--meshes") {
      opt.meshes = ParseNames(v);
    } else if (a == "--sigmas") {
      opt.sigmas = ParseDoubles(v);
      for (double s : opt.sigmas) {
        if (!(s > 0.0)) return Usage("--sigmas: each sigma must be above 0");
      }
    } else if (a == "--seed") {
      if (!ParseCount(v, 0, number)) return Usage("--seed needs a whole number >= 0");
      opt.seed = static_cast<uint64_t>(number);
    } else if (a == "--runs") {
      if (!ParseCount(v, 1, number) || number > 1000) return Usage("--runs needs a whole number in 1..1000");
      opt.runs = static_cast<int>(number);
    } else if (a == "--peers") {
      opt.peers = ParseNames(v);
    } else if (a == "--counts") {
      opt.counts.clear();
      for (const std::string& c : ParseNames(v)) {
        if (!ParseCount(c, 1, number) || number > 100000) return Usage("--counts: whole numbers in 1..100000");
        opt.counts.push_back(static_cast<int>(number));
      }
      if (opt.counts.empty()) return Usage("--counts needs at least one count");
    } else if (a == "--smooth-shape-time") {
      opt.smooth_shape_time = std::atof(v.c_str());
      if (!(opt.smooth_shape_time > 0.0)) return Usage("--smooth-shape-time must be above 0");
    } else if (a == "--scale-sigma") {
      opt.scale_sigma = std::atof(v.c_str());
      if (!(opt.scale_sigma > 0.0)) return Usage("--scale-sigma must be above 0");
    } else if (a == "--scale-level") {
      if (!ParseCount(v, 1, number) || number > 11) return Usage("--scale-level needs a whole number in 1..11");
      opt.scale_level = static_cast<int>(number);
    } else if (a == "--cli") {
      opt.cli = v;
    } else if (a == "--peer-program") {
      opt.peer_program = v;
    } else if (a == "--shared") {
      opt.shared = v;
    } else if (a == "--workdir") {
      opt.workdir = v;
    } else {
      return Usage(absl::StrFormat("unknown option: %s", a));
    }
  }
  if (scale_only) opt.meshes.clear();

  // The programs this one runs: beside it in the build tree unless given.
  const fs::path self_dir = fs::read_symlink("/proc/self/exe").parent_path();
  if (opt.cli.empty()) opt.cli = self_dir.parent_path() / "client" / "meshsmooth";
  opt.self_dir = self_dir;
  const std::vector<Peer> all = AllPeers(opt.smooth_shape_time);
  std::vector<const Peer*> peers;
  std::vector<std::string> missing;
  std::vector<fs::path> programs = {opt.cli};
  for (const std::string& id : opt.peers) {
    if (const Peer* p = FindPeer(all, id)) {
      peers.push_back(p);
      programs.push_back(PeerProgram(opt, *p));
    } else {
      missing.push_back(id);
    }
  }
  for (const fs::path& program : programs) {
    if (access(program.c_str(), X_OK) != 0) {
      std::fprintf(stderr, "meshsmooth_time_to_quality: %s is not an executable program (--cli, --peer-program)\n",
                   program.c_str());
      return kExitFailed;
    }
  }

  const bool own_workdir = opt.workdir.empty();
  if (own_workdir) {
    std::string pattern = (fs::temp_directory_path() / "meshsmooth-ttq-XXXXXX").string();
    if (mkdtemp(pattern.data()) == nullptr) {
      std::fprintf(stderr, "meshsmooth_time_to_quality: cannot make a directory in %s\n",
                   fs::temp_directory_path().c_str());
      return kExitFailed;
    }
    opt.workdir = pattern;
  } else {
    std::error_code error;
    fs::create_directories(opt.workdir, error);
    if (error) {
      std::fprintf(stderr, "meshsmooth_time_to_quality: %s: %s\n", opt.workdir.c_str(), error.message().c_str());
      return kExitFailed;
    }
  }

  Spawner spawner;
  if (!spawner.Start()) {
    std::fprintf(stderr, "meshsmooth_time_to_quality: cannot fork: %s\n", std::strerror(errno));
    return kExitFailed;
  }
  // What any process started this way reports as its peak, however small it is.
  const double rss_floor = spawner.Run({"/bin/true"}, opt.workdir).max_rss_bytes;

  std::vector<std::string> command;
  for (int i = 0; i < argc; ++i) command.emplace_back(argv[i]);
  std::printf("## Time to a good mesh\n\n");
  std::printf("`%s` on %s, %u hardware threads.\n", absl::StrJoin(command, " ").c_str(), CpuModel().c_str(),
              std::thread::hardware_concurrency());
  std::printf("Times are medians of %d processes; the peers' counts come from the sweep %s.\n", opt.runs,
              absl::StrJoin(opt.counts, ",").c_str());
  std::printf("Peak RSS is the process's ru_maxrss (wait4); /bin/true started the same way reports %.1f MB.\n",
              rss_floor / 1e6);
  if (!missing.empty()) {
    std::printf("Not in this build (left out): %s.\n", absl::StrJoin(missing, ", ").c_str());
  }

  int status = 0;
  std::vector<CaseResult> jobs;
  const fs::path mesh_dir = opt.shared / "data" / "meshes";
  for (const std::string& name : opt.meshes) {
    std::fprintf(stderr, "%s: ground truth\n", name.c_str());
    absl::StatusOr<Subject> subject = LoadSubject(name, mesh_dir);
    if (!subject.ok()) {
      std::fprintf(stderr, "meshsmooth_time_to_quality: %s: %s\n", name.c_str(), subject.status().ToString().c_str());
      status = kExitFailed;
      continue;
    }
    for (double sigma : opt.sigmas) {
      jobs.push_back(MeshCase(spawner, opt, *subject, sigma, peers, opt.workdir));
      if (jobs.back().failed()) status = kExitFailed;
    }
  }
  if (!jobs.empty()) SummaryTable(jobs);
  if (opt.scale && !ScaleSection(spawner, opt, jobs, opt.workdir)) status = kExitFailed;
  if (own_workdir) {
    std::error_code ignored;
    fs::remove_all(opt.workdir, ignored);
  }
  return status;
}

}  // namespace
}  // namespace meshsmooth::bench

int main(int argc, char** argv) { return meshsmooth::bench::Main(argc, argv); }
