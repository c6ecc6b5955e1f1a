// meshsmooth_attribute_cost: what a scan's attributes cost the CLI. The same noisy mesh as a
// plain PLY (positions and faces) and as a textured one (per-vertex `s t` and `nx ny nz`, as a
// scanner writes them), each smoothed by `meshsmooth smooth IN -o OUT.ply` with the default job
// as a whole process, alternately, --runs times; the medians of the wall time (spawn to exit)
// and of the CPU time (user + system), and their ratios; then meshsmooth's readers against Draco's own on the textured
// mesh as PLY and OBJ (docs/decisions.md). docs/performance.md ("What attributes cost") is its output.
//
//   meshsmooth_attribute_cost --cli build/client/meshsmooth [--runs 5] [--write-inputs DIR] [MESH]
//
// --write-inputs DIR writes the two inputs (plain.ply, textured.ply) to DIR and stops.
//
// MESH defaults to ../shared/data/meshes/stanford-dragon.ply (given Gaussian noise of 0.2 mean
// edges along the normals, seed 1).
#include <fcntl.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "bench/bench_common.h"
#include "core/attributes.h"
#include "core/io/gltf.h"
#include "core/io/mesh_io.h"
#include "core/shapes/added_noise.h"
#include "draco/io/mesh_io.h"

extern char** environ;

namespace meshsmooth::bench {
namespace {

namespace fs = std::filesystem;

struct ProcessTime {
  double wall_ms = -1.0, cpu_ms = -1.0;  // -1: the process failed
};

// Runs `cli smooth in -o out -q`: its wall time (spawn to exit) and CPU time (user + system,
// from wait4), in ms.
ProcessTime RunCli(const std::string& cli, const std::string& in, const std::string& out) {
  std::vector<std::string> argv_s = {cli, "smooth", in, "-o", out, "-q"};
  std::vector<char*> args;
  for (std::string& a : argv_s) args.push_back(a.data());
  args.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
  pid_t pid = 0;
  const Clock::time_point start = Clock::now();
  const int spawned = posix_spawn(&pid, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) return {};
  int status = 0;
  rusage usage{};
  while (wait4(pid, &status, 0, &usage) < 0 && errno == EINTR) {
  }
  const double ms = Ms(start, Clock::now());
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) return {};
  auto tv_ms = [](const timeval& t) {
    return 1e3 * static_cast<double>(t.tv_sec) + 1e-3 * static_cast<double>(t.tv_usec);
  };
  return {ms, tv_ms(usage.ru_utime) + tv_ms(usage.ru_stime)};
}

int Main(int argc, char** argv) {
  std::string cli, mesh_path = std::string(MESHSMOOTH_SOURCE_DIR) + "/../shared/data/meshes/stanford-dragon.ply";
  int runs = 5;
  std::string write_inputs;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--cli" && i + 1 < argc) {
      cli = argv[++i];
    } else if (a == "--write-inputs" && i + 1 < argc) {
      write_inputs = argv[++i];
    } else if (a == "--runs" && i + 1 < argc) {
      runs = std::max(1, std::atoi(argv[++i]));
    } else if (a == "--help" || a == "-h") {
      std::printf("usage: %s --cli PATH/TO/meshsmooth [--runs N] [MESH]\n", argv[0]);
      return 0;
    } else if (!a.empty() && a[0] != '-') {
      mesh_path = a;
    } else {
      std::fprintf(stderr, "%s: unknown option '%s' (see --help)\n", argv[0], a.c_str());
      return 2;
    }
  }
  if (cli.empty() && write_inputs.empty()) {
    std::fprintf(stderr, "%s: --cli PATH is required\n", argv[0]);
    return 2;
  }
  absl::StatusOr<Mesh> read = ReadMesh(mesh_path);
  if (!read.ok()) {
    std::fprintf(stderr, "%s\n", std::string(read.status().message()).c_str());
    return 1;
  }
  Mesh plain;
  plain.positions = std::move(read->positions);
  plain.triangles = std::move(read->triangles);
  AddNormalNoise(plain, 0.2, 1);
  // A scanner's texture: a planar projection onto the bounding box's widest faces, and the
  // normals of the noisy mesh, per vertex.
  Mesh textured = plain;
  BoundingBox box;
  for (const Vec3& p : plain.positions) box.Add(p);
  textured.uvs.components = 2;
  for (const Vec3& p : plain.positions) {
    textured.uvs.values.push_back(static_cast<float>((p.x - box.lo.x) / (box.hi.x - box.lo.x)));
    textured.uvs.values.push_back(static_cast<float>((p.y - box.lo.y) / (box.hi.y - box.lo.y)));
  }
  for (const Triangle& t : plain.triangles) {
    textured.uvs.corners.insert(textured.uvs.corners.end(), t.begin(), t.end());
  }
  textured.normals = FreshNormals(plain, {});
  const fs::path dir = !write_inputs.empty()
                           ? fs::path(write_inputs)
                           : fs::temp_directory_path() / ("meshsmooth_attribute_cost_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const std::string plain_in = (dir / "plain.ply").string(), textured_in = (dir / "textured.ply").string();
  if (!WriteMesh(plain_in, plain).ok() || !WriteMesh(textured_in, textured).ok()) {
    std::fprintf(stderr, "cannot write the inputs to %s\n", dir.c_str());
    return 1;
  }
  if (!write_inputs.empty()) return 0;
  std::vector<double> plain_ms, textured_ms, plain_cpu, textured_cpu;
  for (int r = 0; r < runs; ++r) {
    const ProcessTime a = RunCli(cli, plain_in, (dir / "plain-out.ply").string());
    const ProcessTime b = RunCli(cli, textured_in, (dir / "textured-out.ply").string());
    if (a.wall_ms < 0 || b.wall_ms < 0) {
      std::fprintf(stderr, "the CLI failed (run %d)\n", r + 1);
      return 1;
    }
    plain_ms.push_back(a.wall_ms);
    textured_ms.push_back(b.wall_ms);
    plain_cpu.push_back(a.cpu_ms);
    textured_cpu.push_back(b.cpu_ms);
    std::fprintf(stderr, "run %d: plain %.0f ms (CPU %.0f), textured %.0f ms (CPU %.0f)\n", r + 1, a.wall_ms, a.cpu_ms,
                 b.wall_ms, b.cpu_ms);
  }
  const double p = Median(plain_ms), t = Median(textured_ms);
  const double pc = Median(plain_cpu), tc = Median(textured_cpu);
  std::printf(
      "| input | vertices | file MB | CLI wall ms | ratio | CLI CPU ms | ratio |\n|---|---|---|---|---|---|---|\n");
  std::printf("| %s, noisy, positions only | %d | %.1f | %.0f | 1 | %.0f | 1 |\n",
              fs::path(mesh_path).filename().c_str(), plain.num_vertices(), fs::file_size(plain_in) / 1e6, p, pc);
  std::printf("| the same with per-vertex `s t` and `nx ny nz` | %d | %.1f | %.0f | %.3f | %.0f | %.3f |\n",
              textured.num_vertices(), fs::file_size(textured_in) / 1e6, t, t / p, tc, tc / pc);
  // The readers: meshsmooth's own (core/io) against Draco's (draco::ReadMeshFromFile) on the
  // textured mesh as PLY and as OBJ, from a file each time; and what each gives back.
  const std::string textured_obj = (dir / "textured.obj").string();
  if (!WriteMesh(textured_obj, textured).ok()) return 1;
  std::printf("\n| reader | file | ms (median of %d) | vertices (points for Draco) | faces |\n|---|---|---|---|---|\n",
              runs);
  UseDracoFileIo();
  for (const std::string& file : {textured_in, textured_obj}) {
    std::vector<double> ours, theirs;
    int64_t our_vertices = 0, our_faces = 0, their_points = 0, their_faces = 0;
    for (int r = 0; r < runs; ++r) {
      Clock::time_point t0 = Clock::now();
      absl::StatusOr<Mesh> m = ReadMesh(file);
      ours.push_back(Ms(t0, Clock::now()));
      if (!m.ok()) return 1;
      our_vertices = m->num_vertices();
      our_faces = m->num_triangles();
      t0 = Clock::now();
      draco::StatusOr<std::unique_ptr<draco::Mesh>> dm = draco::ReadMeshFromFile(file);
      theirs.push_back(Ms(t0, Clock::now()));
      if (!dm.ok()) {
        std::fprintf(stderr, "Draco cannot read %s: %s\n", file.c_str(), dm.status().error_msg());
        return 1;
      }
      their_points = dm.value()->num_points();
      their_faces = dm.value()->num_faces();
    }
    const std::string name = fs::path(file).extension().string();
    std::printf("| meshsmooth (core/io) | %s | %.0f | %lld | %lld |\n", name.c_str(), Median(ours),
                static_cast<long long>(our_vertices), static_cast<long long>(our_faces));
    std::printf("| Draco 1.5.5 (draco::ReadMeshFromFile) | %s | %.0f | %lld | %lld |\n", name.c_str(), Median(theirs),
                static_cast<long long>(their_points), static_cast<long long>(their_faces));
  }
  fs::remove_all(dir);
  return 0;
}

}  // namespace
}  // namespace meshsmooth::bench

int main(int argc, char** argv) { return meshsmooth::bench::Main(argc, argv); }
