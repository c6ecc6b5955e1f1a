// The default job on a large mesh, run locally as `meshsmooth smooth IN -o OUT` runs it (no
// --server: the job in memory): time per phase, peak resident bytes per vertex against the job's
// memory estimate, and how close the result comes to the clean surface.
//
// The input is a noisy height field of about --vertices vertices, written here (never kept in
// the repository): a square grid of unit spacing over z = f(x, y) (two waves, 23-31 and 11 edge
// lengths long), cut into two triangles a cell, with Gaussian noise of --sigma h on z (h, the
// mean edge length, is (2 + sqrt 2) / 3). The file is written as it is generated (row by row),
// so this process stays small; each run is a child process (this program with --child) started
// from it, whose peak is its own (wait4's ru_maxrss).
//
// The child runs the steps of the CLI's local run (client/smooth_file.cc's SmoothFile): read the
// file (PrepareUpload), the job in memory (RunInMemory: the memory estimate first, then the weld,
// validation, noise estimate, choice on a sample, smoothing, the after-metrics), write the result
// (WriteResultPoints); the job's phases are timed by its progress events. RMS distances are
// vertical (z - f(x, y)), at most 7% above the distance along the normal (the surface's slope is
// below 0.37).
//
// Usage: meshsmooth_large_mesh [--vertices N] [--sigma 0.2] [--seed 1] [--workdir DIR]
//                              [--reference MESH.ply]... [--service]
//   --reference: also the default job on that mesh (e.g. the noisy dragon that
//   `meshsmooth_quality --write-noisy stanford-dragon 0.2 1 FILE` writes), for its time per
//   vertex beside the height field's.
//   --service: instead, the CLI itself (build/client/meshsmooth beside this program's folder) on
//   the height field, locally and through a meshsmoothd of the same build started with the limits
//   of docs/deployment.md's "Large meshes" (CompareWithService): each process's time and peak,
//   and whether the two outputs hold the same bytes (exit 1 when not).
#include <fcntl.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "absl/strings/str_format.h"
#include "base/huge_pages.h"
#include "bench/bench_common.h"
#include "client/job_run.h"
#include "client/transfer.h"
#include "meshsmooth/v1/smoothing.pb.h"
#include "server/job_memory.h"

extern char** environ;

namespace meshsmooth::bench {
namespace {

namespace fs = std::filesystem;

// The clean surface.
double CleanHeight(double x, double y) {
  return 4.0 * std::sin(x / 23.0) * std::cos(y / 31.0) + 1.5 * std::sin((x + y) / 11.0);
}

// The height field's mean edge length: two unit edges and a diagonal a cell, in equal numbers.
const double kMeanEdge = (2.0 + std::sqrt(2.0)) / 3.0;

// Writes a side x side noisy height field as binary PLY (float x, y, z; int faces), row by row.
bool WriteHeightField(const fs::path& path, int side, double sigma, uint32_t seed) {
  std::ofstream out(path, std::ios::binary);
  const int64_t vertices = int64_t{side} * side, faces = 2 * int64_t{side - 1} * (side - 1);
  out << "ply\nformat binary_little_endian 1.0\nelement vertex " << vertices
      << "\nproperty float x\nproperty float y\nproperty float z\nelement face " << faces
      << "\nproperty list uchar int vertex_indices\nend_header\n";
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma * kMeanEdge);
  std::vector<float> row(3 * static_cast<size_t>(side));
  for (int y = 0; y < side; ++y) {
    for (int x = 0; x < side; ++x) {
      row[3 * x] = static_cast<float>(x);
      row[3 * x + 1] = static_cast<float>(y);
      row[3 * x + 2] = static_cast<float>(CleanHeight(x, y) + noise(rng));
    }
    out.write(reinterpret_cast<const char*>(row.data()), static_cast<std::streamsize>(row.size() * sizeof(float)));
  }
  std::vector<char> face_row;
  for (int y = 0; y + 1 < side; ++y) {
    face_row.clear();
    for (int x = 0; x + 1 < side; ++x) {
      const int32_t a = y * side + x;
      const int32_t tris[2][3] = {{a, a + 1, a + side + 1}, {a, a + side + 1, a + side}};
      for (const auto& t : tris) {
        face_row.push_back(3);
        const char* p = reinterpret_cast<const char*>(t);
        face_row.insert(face_row.end(), p, p + sizeof t);
      }
    }
    out.write(face_row.data(), static_cast<std::streamsize>(face_row.size()));
  }
  return static_cast<bool>(out);
}

// The vertical RMS distance to the clean surface of a binary little-endian PLY's vertices (x, y,
// z first, any further scalar properties), read in blocks; negative when it cannot be read.
double RmsToClean(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::string line;
  int64_t n = -1;
  bool in_vertex = false, binary = false;
  std::vector<int> sizes;  // bytes of each vertex property
  std::vector<bool> is_double;
  const std::map<std::string, int> kSize = {{"char", 1},  {"uchar", 1},   {"int8", 1},   {"uint8", 1},
                                            {"short", 2}, {"ushort", 2},  {"int16", 2},  {"uint16", 2},
                                            {"int", 4},   {"uint", 4},    {"int32", 4},  {"uint32", 4},
                                            {"float", 4}, {"float32", 4}, {"double", 8}, {"float64", 8}};
  while (std::getline(in, line) && line != "end_header") {
    std::istringstream w(line);
    std::string a, b, c;
    w >> a >> b >> c;
    if (a == "format") binary = b == "binary_little_endian";
    if (a == "element") {
      in_vertex = b == "vertex";
      if (in_vertex) n = std::atoll(c.c_str());
    } else if (a == "property" && in_vertex) {
      if (b == "list" || !kSize.count(b)) return -1.0;
      sizes.push_back(kSize.at(b));
      is_double.push_back(kSize.at(b) == 8);
    }
  }
  if (!binary || n <= 0 || sizes.size() < 3) return -1.0;
  int stride = 0;
  for (int s : sizes) stride += s;
  std::vector<char> block(static_cast<size_t>(stride) * 65536);
  double sum = 0.0;
  for (int64_t done = 0; done < n;) {
    const int64_t count = std::min<int64_t>(65536, n - done);
    if (!in.read(block.data(), count * stride)) return -1.0;
    for (int64_t i = 0; i < count; ++i) {
      const char* p = block.data() + i * stride;
      double xyz[3];
      for (int k = 0, offset = 0; k < 3; offset += sizes[k], ++k) {
        if (is_double[k]) {
          std::memcpy(&xyz[k], p + offset, 8);
        } else {
          float f;
          std::memcpy(&f, p + offset, 4);
          xyz[k] = f;
        }
      }
      const double d = xyz[2] - CleanHeight(xyz[0], xyz[1]);
      sum += d * d;
    }
    done += count;
  }
  return std::sqrt(sum / static_cast<double>(n));
}

// The child: the CLI's local run of the default job on `in`, written to `out`; prints one
// "key value" line per figure.
int Child(const std::string& in, const std::string& out) {
  const Clock::time_point t0 = Clock::now();
  absl::StatusOr<client::Upload> upload = client::PrepareUpload(in, false, false, {}, /*in_memory=*/true);
  if (!upload.ok()) {
    std::fprintf(stderr, "reading %s: %s\n", in.c_str(), upload.status().ToString().c_str());
    return 1;
  }
  const Clock::time_point read = Clock::now();
  const int64_t vertices = upload->kept.num_vertices();
  const auto faces = static_cast<int64_t>(upload->kept.triangles.size());
  const v1::JobSpec spec;  // the default job
  client::ConnectionOptions connection;
  client::JobCancels cancels;
  client::JobHooks hooks;
  // The first time each phase was reported, in seconds from the job's start.
  std::map<int, double> first_seen;
  const Clock::time_point job_start = Clock::now();
  hooks.progress = [&](const v1::Progress& p) {
    first_seen.emplace(static_cast<int>(p.phase()), Seconds(job_start, Clock::now()));
  };
  client::JobRun run = client::RunInMemory(spec, *upload, connection, cancels, hooks);
  const Clock::time_point job_end = Clock::now();
  if (!run.status.ok()) {
    std::fprintf(stderr, "the job: %s%s\n", run.prefix.c_str(), std::string(run.status.message()).c_str());
    return 1;
  }
  std::vector<std::string> dropped;
  const absl::Status written =
      client::WriteResultPoints(*upload, std::move(run.local.points), run.local.labels, out, false, &dropped);
  const Clock::time_point end = Clock::now();
  if (!written.ok()) {
    std::fprintf(stderr, "writing %s: %s\n", out.c_str(), written.ToString().c_str());
    return 1;
  }
  const v1::Timings& t = run.summary.timings();
  auto phase = [&](v1::ProgressPhase p) {
    auto it = first_seen.find(static_cast<int>(p));
    return it == first_seen.end() ? -1.0 : it->second;
  };
  // Phase boundaries within the job: the weld and validation end at the first progress (the noise
  // estimate); the estimate and choice at the final run's first iteration; the final run at
  // "writing" (the after-metrics and displacement follow).
  const double noise = phase(v1::PROGRESS_PHASE_NOISE_ESTIMATE);
  const double smoothing = phase(v1::PROGRESS_PHASE_SMOOTHING);
  const double writing = phase(v1::PROGRESS_PHASE_WRITING);
  std::printf("vertices %lld\nfaces %lld\n", static_cast<long long>(vertices), static_cast<long long>(faces));
  std::printf("estimate_bytes %lld\n",
              static_cast<long long>(server::EstimateJobBytes(vertices, faces, server::JobParams{})));
  std::printf("read %.3f\n", Seconds(t0, read));
  std::printf("prepare %.3f\n", t.decode_seconds());
  std::printf("noise_and_choice %.3f\n", noise >= 0 && smoothing >= 0 ? smoothing - noise : -1.0);
  std::printf("final_run %.3f\n", smoothing >= 0 && writing >= 0 ? writing - smoothing : -1.0);
  std::printf("after %.3f\n", writing >= 0 ? Seconds(job_start, job_end) - writing : -1.0);
  std::printf("job %.3f\n", Seconds(job_start, job_end));
  std::printf("write %.3f\n", Seconds(job_end, end));
  std::printf("total %.3f\n", Seconds(t0, end));
  const v1::EffectiveParameters& e = run.summary.parameters();
  std::printf("flow %s\niterations %d\nstop %s\n", e.flow().c_str(), static_cast<int>(e.iterations_run()),
              e.stop_reason().c_str());
  return 0;
}

// A process of ours that ended: its exit status, time and peak (wait4's ru_maxrss).
struct Ended {
  int exit_code = -1;
  double seconds = 0.0, max_rss_bytes = 0.0;
};

// `argv` started with stdout (and stderr, when not empty) to files; -1 when it cannot start.
pid_t Spawn(const std::vector<std::string>& argv, const fs::path& out, const fs::path& err = {}) {
  std::vector<std::string> copy = argv;
  std::vector<char*> args;
  for (std::string& a : copy) args.push_back(a.data());
  args.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (!err.empty()) posix_spawn_file_actions_addopen(&actions, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  return spawned == 0 ? pid : -1;
}

Ended Wait(pid_t pid, Clock::time_point start) {
  Ended e;
  if (pid < 0) return e;
  int status = 0;
  rusage usage{};
  while (wait4(pid, &status, 0, &usage) < 0 && errno == EINTR) {
  }
  e.seconds = Seconds(start, Clock::now());
  e.max_rss_bytes = 1024.0 * static_cast<double>(usage.ru_maxrss);
  if (WIFEXITED(status)) e.exit_code = WEXITSTATUS(status);
  return e;
}

struct ChildRun : Ended {
  std::map<std::string, std::string> figures;
};

// This program with --child IN OUT, its stdout parsed into figures.
ChildRun RunChild(const std::string& self, const fs::path& in, const fs::path& out, const fs::path& dir) {
  ChildRun r;
  const fs::path stdout_path = dir / "child-stdout.txt";
  const Clock::time_point start = Clock::now();
  static_cast<Ended&>(r) = Wait(Spawn({self, "--child", in.string(), out.string()}, stdout_path), start);
  std::ifstream figures(stdout_path);
  std::string key, value;
  while (figures >> key >> value) r.figures[key] = value;
  return r;
}

// The first byte at which the files differ; -1 when they hold the same bytes.
int64_t FirstDifference(const fs::path& a, const fs::path& b) {
  std::ifstream fa(a, std::ios::binary), fb(b, std::ios::binary);
  std::vector<char> ba(1 << 20), bb(1 << 20);
  for (int64_t offset = 0;; offset += static_cast<int64_t>(ba.size())) {
    fa.read(ba.data(), static_cast<std::streamsize>(ba.size()));
    fb.read(bb.data(), static_cast<std::streamsize>(bb.size()));
    const std::streamsize na = fa.gcount(), nb = fb.gcount();
    for (std::streamsize i = 0; i < std::min(na, nb); ++i) {
      if (ba[i] != bb[i]) return offset + i;
    }
    if (na != nb) return offset + std::min(na, nb);
    if (na == 0) return -1;
  }
}

// The port meshsmoothd printed ("meshsmoothd listening on HOST:PORT") in `out`, waiting up to
// 10 s; 0 when it did not.
int ListeningPort(const fs::path& out) {
  for (int tries = 0; tries < 100; ++tries) {
    std::ifstream in(out);
    std::string line;
    while (std::getline(in, line)) {
      const size_t colon = line.rfind(':');
      if (line.rfind("meshsmoothd listening on ", 0) == 0 && colon != std::string::npos) {
        return std::atoi(line.c_str() + colon + 1);
      }
    }
    usleep(100'000);
  }
  return 0;
}

// --service: `meshsmooth smooth IN -o OUT` locally, then through a meshsmoothd started with the
// limits docs/deployment.md's "Large meshes" gives for this machine (one worker, uploads and
// buffers of 2 GiB, --max-job-bytes the rest of MemTotal, an hour a job), from the build tree
// this benchmark is in; prints each process's time and peak and whether the outputs hold the same
// bytes. 0 when they do.
int CompareWithService(const std::string& self, const fs::path& input, int64_t vertices, const fs::path& dir) {
  const fs::path build = fs::path(self).parent_path().parent_path();
  const std::string cli = (build / "client" / "meshsmooth").string();
  const std::string daemon = (build / "server" / "meshsmoothd").string();
  const fs::path local = dir / "cli-local.ply", served = dir / "cli-service.ply";
  constexpr int64_t kBuffers = int64_t{2} << 30;
  const int64_t job_bytes =
      static_cast<int64_t>(sysconf(_SC_PHYS_PAGES)) * sysconf(_SC_PAGESIZE) - kBuffers - (int64_t{64} << 20);
  std::fprintf(stderr, "the CLI's local run on %s\n", input.c_str());
  Clock::time_point start = Clock::now();
  const Ended cli_local =
      Wait(Spawn({cli, "smooth", input.string(), "-o", local.string(), "--quiet", "--timeout", "7200"},
                 dir / "cli-local.txt"),
           start);
  const std::vector<std::string> server_argv = {daemon,
                                                "--listen",
                                                "127.0.0.1:0",
                                                "--workers",
                                                "1",
                                                "--quiet",
                                                "--max-upload-bytes",
                                                std::to_string(kBuffers),
                                                "--max-buffered-bytes",
                                                std::to_string(kBuffers),
                                                "--max-job-bytes",
                                                std::to_string(job_bytes),
                                                "--max-job-seconds",
                                                "3600"};
  std::string command;
  for (const std::string& a : server_argv) command += (command.empty() ? "" : " ") + a;
  std::fprintf(stderr, "%s\n", command.c_str());
  const Clock::time_point server_start = Clock::now();
  const pid_t server = Spawn(server_argv, dir / "meshsmoothd-out.txt", dir / "meshsmoothd-err.txt");
  const int port = ListeningPort(dir / "meshsmoothd-out.txt");
  Ended client;
  if (port > 0) {
    start = Clock::now();
    client = Wait(Spawn({cli, "smooth", input.string(), "-o", served.string(), "--quiet", "--timeout", "7200",
                         "--server", absl::StrFormat("127.0.0.1:%d", port)},
                        dir / "cli-service.txt"),
                  start);
  }
  if (server > 0) kill(server, SIGTERM);
  const Ended daemon_run = Wait(server, server_start);
  std::printf("\n| run (%lld vertices) | exit | seconds | peak RSS | bytes/vertex |\n|---|---|---|---|---|\n",
              static_cast<long long>(vertices));
  auto row = [&](const char* name, const Ended& e) {
    std::printf("| %s | %d | %.2f | %.2f GB | %.0f |\n", name, e.exit_code, e.seconds, e.max_rss_bytes / 1e9,
                e.max_rss_bytes / static_cast<double>(vertices));
  };
  row("meshsmooth smooth IN -o OUT (local)", cli_local);
  row("meshsmooth smooth IN -o OUT --server (the client)", client);
  row("meshsmoothd (its whole life, idle included)", daemon_run);
  if (cli_local.exit_code != 0 || client.exit_code != 0) {
    std::printf("\na run failed: see %s\n", dir.c_str());
    return 1;
  }
  const int64_t differ = FirstDifference(local, served);
  std::error_code ignored;
  if (differ < 0) {
    std::printf("\nlocal and service outputs: the same %lld bytes\n",
                static_cast<long long>(fs::file_size(local, ignored)));
  } else {
    std::printf("\nlocal and service outputs DIFFER from byte %lld (kept in %s)\n", static_cast<long long>(differ),
                dir.c_str());
    return 1;
  }
  fs::remove(local, ignored);
  fs::remove(served, ignored);
  return 0;
}

double Figure(const ChildRun& r, const std::string& key) {
  auto it = r.figures.find(key);
  return it == r.figures.end() ? -1.0 : std::atof(it->second.c_str());
}

int Usage(const char* why) {
  std::fprintf(stderr,
               "%s\nusage: meshsmooth_large_mesh [--vertices N] [--sigma 0.2] [--seed 1] [--workdir DIR] "
               "[--reference MESH.ply]... [--service]\n",
               why);
  return 2;
}

int Main(int argc, char** argv) {
  if (argc == 4 && std::string(argv[1]) == "--child") return Child(argv[2], argv[3]);
  int64_t target = 10'000'000;
  double sigma = 0.2;
  uint32_t seed = 1;
  fs::path dir;
  std::vector<std::string> references;
  bool service = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--service") {
      service = true;
      continue;
    }
    if (i + 1 >= argc) return Usage(("missing value after " + a).c_str());
    const std::string v = argv[++i];
    if (a == "--vertices") {
      target = std::atoll(v.c_str());
      if (target < 4 || target > 2'000'000'000) return Usage("--vertices must be 4 .. 2,000,000,000");
    } else if (a == "--sigma") {
      sigma = std::atof(v.c_str());
      if (!(sigma > 0.0)) return Usage("--sigma must be above 0");
    } else if (a == "--seed") {
      seed = static_cast<uint32_t>(std::atoll(v.c_str()));
    } else if (a == "--workdir") {
      dir = v;
    } else if (a == "--reference") {
      references.push_back(v);
    } else {
      return Usage(("unknown option " + a).c_str());
    }
  }
  if (dir.empty()) dir = fs::temp_directory_path() / absl::StrFormat("meshsmooth-large-%d", getpid());
  fs::create_directories(dir);
  const std::string self = fs::read_symlink("/proc/self/exe").string();
  const int side = static_cast<int>(std::lround(std::sqrt(static_cast<double>(target))));
  const fs::path input = dir / absl::StrFormat("height-field-%d.ply", int64_t{side} * side);
  std::fprintf(stderr, "writing %s (%d x %d vertices, sigma %g h)\n", input.c_str(), side, side, sigma);
  if (!WriteHeightField(input, side, sigma, seed)) return Usage("cannot write the height field");
  if (service) {
    const int differ = CompareWithService(self, input, int64_t{side} * side, dir);
    std::fprintf(stderr, "input kept in %s\n", dir.c_str());
    return differ;
  }

  std::printf(
      "| mesh | vertices | flow, iterations (stop) | read | prepare (weld, validate, metrics) | noise estimate + "
      "choice | final run | after (metrics, displacement) | write | whole process (s) | us/vertex | peak "
      "RSS | bytes/vertex | estimate (bytes/vertex) | RMS noisy (h) | RMS result (h) |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  std::vector<std::pair<std::string, fs::path>> meshes = {{"height field", input}};
  for (const std::string& r : references) meshes.emplace_back(fs::path(r).stem().string(), r);
  double height_field_us = 0.0;
  int status = 0;
  for (const auto& [name, path] : meshes) {
    const fs::path out = dir / (fs::path(path).stem().string() + "-out.ply");
    std::fprintf(stderr, "the default job on %s\n", path.c_str());
    const ChildRun r = RunChild(self, path, out, dir);
    if (r.exit_code != 0) {
      std::fprintf(stderr, "the run on %s failed (exit %d)\n", path.c_str(), r.exit_code);
      status = 1;
      continue;
    }
    const double n = Figure(r, "vertices");
    const double us = 1e6 * r.seconds / n;
    if (path == input) height_field_us = us;
    const bool height_field = path == input;
    const std::string rms_in = height_field ? absl::StrFormat("%.3f", RmsToClean(input) / kMeanEdge) : "-";
    const std::string rms_out = height_field ? absl::StrFormat("%.3f", RmsToClean(out) / kMeanEdge) : "-";
    std::printf(
        "| %s | %.0f | %s, %s (%s) | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f GB | %.0f | "
        "%.0f | %s | %s |\n",
        name.c_str(), n, r.figures.at("flow").c_str(), r.figures.at("iterations").c_str(), r.figures.at("stop").c_str(),
        Figure(r, "read"), Figure(r, "prepare"), Figure(r, "noise_and_choice"), Figure(r, "final_run"),
        Figure(r, "after"), Figure(r, "write"), r.seconds, us, r.max_rss_bytes / 1e9, r.max_rss_bytes / n,
        Figure(r, "estimate_bytes") / n, rms_in.c_str(), rms_out.c_str());
    if (!height_field && height_field_us > 0.0) {
      std::printf("\nheight field / %s, whole process per vertex: %.2fx\n", name.c_str(), height_field_us / us);
    }
    std::error_code ignored;
    fs::remove(out, ignored);
  }
  std::fprintf(stderr, "inputs kept in %s\n", dir.c_str());
  return status;
}

}  // namespace
}  // namespace meshsmooth::bench

int main(int argc, char** argv) {
  // As the CLI does for an input of 4 MiB and more: glibc's huge-page tunables (base/huge_pages.h);
  // the child inherits them through the environment.
  meshsmooth::UseHugePagesForLargeBuffers(argv);
  return meshsmooth::bench::Main(argc, argv);
}
