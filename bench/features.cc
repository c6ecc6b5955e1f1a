// Times curvature estimation and ridge/ravine detection (core/features/) on one mesh: the
// fastest and the median wall time of several runs of EstimateCurvature and of DetectFeatures
// (which includes an estimate), with the thread count OpenMP chooses. On a shared machine the
// fastest run is the steadier figure. docs/performance.md ("Curvature and ridges") quotes it:
//   flock /tmp/meshsmooth-build.lock build/bench/meshsmooth_features_bench ../shared/data/meshes/stanford-dragon.ply 7
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "core/features/ridges.h"
#include "core/io/mesh_io.h"
#include "core/topology.h"

namespace {

struct Times {
  double fastest = 0.0, median = 0.0;
};

template <typename F>
Times Seconds(int runs, F&& f) {
  std::vector<double> t;
  for (int i = 0; i < runs; ++i) {
    const auto start = std::chrono::steady_clock::now();
    f();
    t.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
  std::sort(t.begin(), t.end());
  return {t.front(), t[t.size() / 2]};
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s MESH [RUNS]\n", argv[0]);
    return 2;
  }
  const int runs = argc > 2 ? std::max(1, std::atoi(argv[2])) : 5;
  absl::StatusOr<meshsmooth::Mesh> mesh = meshsmooth::ReadMesh(argv[1]);
  if (!mesh.ok()) {
    std::fprintf(stderr, "%s\n", std::string(mesh.status().message()).c_str());
    return 1;
  }
  const meshsmooth::Topology topo = meshsmooth::BuildTopology(*mesh);
  int64_t labelled = 0, classified = 0;
  const Times estimate = Seconds(runs, [&] { (void)meshsmooth::EstimateCurvature(*mesh, topo); });
  const Times detect = Seconds(runs, [&] {
    const meshsmooth::Features f = meshsmooth::DetectFeatures(*mesh, topo);
    labelled = f.ridges + f.ravines;
    classified = f.classified;
  });
  std::printf(
      "%s: %d vertices, %d threads, %d runs (fastest / median): EstimateCurvature %.1f / %.1f ms, "
      "DetectFeatures %.1f / %.1f ms (%lld labelled of %lld classified)\n",
      argv[1], mesh->num_vertices(), omp_get_max_threads(), runs, 1e3 * estimate.fastest, 1e3 * estimate.median,
      1e3 * detect.fastest, 1e3 * detect.median, static_cast<long long>(labelled), static_cast<long long>(classified));
  return 0;
}
