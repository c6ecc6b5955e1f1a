#include "bench/quality_inputs.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <utility>

#include "absl/strings/str_format.h"
#include "bench/bench_common.h"
#include "bench/decimate.h"
#include "core/io/mesh_io.h"
#include "core/shapes/added_noise.h"
#include "core/shapes/marching_tetrahedra.h"
#include "core/shapes/parametric.h"

namespace meshsmooth::bench {

std::string Case::Name() const {
  if (sigma == 0.0) return "clean input (sigma = 0)";
  if (noise == Noise::kImpulsive) {
    return absl::StrFormat("impulsive noise, %g%% of vertices thrown %g-%g h", 100 * kImpulsiveShare, sigma, 3 * sigma);
  }
  return absl::StrFormat("%s, sigma = %g h", noise == Noise::kNormal ? "normal noise" : "random-direction noise",
                         sigma);
}

std::vector<Case> MakeCases(const std::vector<double>& sigmas, const std::vector<double>& random_sigmas,
                            const std::vector<double>& impulsive_scales) {
  std::vector<Case> cases;
  for (double s : sigmas) cases.push_back({Noise::kNormal, s});
  for (double s : random_sigmas) {
    if (s > 0.0) cases.push_back({Noise::kRandom, s});
  }
  for (double s : impulsive_scales) {
    if (s > 0.0) cases.push_back({Noise::kImpulsive, s});
  }
  return cases;
}

absl::StatusOr<Subject> LoadSubject(const std::string& name, const std::filesystem::path& meshes) {
  Subject s;
  s.name = name;
  Mesh clean;
  if (name == "sphere") {
    clean = Icosphere(4);
    s.what = "icosphere, level 4";
  } else if (name == "two-rate-torus") {
    clean = TwoRateTorus(32);
    s.what = "the paper's Fig. 4 torus, two sampling rates";
  } else if (name == "mt-torus") {
    // A tilted torus (R = 1, r = 0.4) through marching tetrahedra: iso-surface output. sqrt,
    // not hypot, in the shapes' functions: the same bits on every machine.
    clean = MarchingTetrahedra(
        [](const Vec3& p) {
          const Vec3 q{p.x, 0.8 * p.y - 0.6 * p.z, 0.6 * p.y + 0.8 * p.z};
          const double ring = std::sqrt(q.x * q.x + q.y * q.y) - 1.0;
          return std::sqrt(ring * ring + q.z * q.z) - 0.4;
        },
        Vec3{-1.5, -1.5, -1.5}, Vec3{1.5, 1.5, 1.5}, 0.045);
    s.what = "torus R 1, r 0.4, marching tetrahedra, step 0.045";
  } else if (name == "mt-cylinder") {
    // A capped cylinder (radius 0.6, height 1.6) through marching tetrahedra: a machined part
    // as iso-surface output, its rims cut into jagged chamfers.
    clean = MarchingTetrahedra(
        [](const Vec3& p) { return std::max(std::sqrt(p.x * p.x + p.y * p.y) - 0.6, std::abs(p.z) - 0.8); },
        Vec3{-0.9, -0.9, -1.1}, Vec3{0.9, 0.9, 1.1}, 0.037);
    s.what = "capped cylinder, marching tetrahedra, step 0.037";
  } else if (name == "holey-sphere") {
    clean = HoleySphere(5, 60, 0.07, 7);
    s.what = "icosphere level 5, 60 round holes";
  } else if (name == "perforated-sphere") {
    // An open scan's worth of rims: 431 holes, 40% of the vertices on one.
    clean = HoleySphere(5, 700, 0.03, 7);
    s.what = "icosphere level 5, 431 small holes (40% of vertices on a rim)";
  } else if (name == "sliver-shaft") {
    clean = SliverShaft(128);
    s.what = "stepped shaft as CAD tessellates it: slivers (0.8-1.4 deg) and cap fans, 128 around";
  } else if (name == "dragon-8k") {
    // A detailed clean scan: the dragon's scales at the scale of an edge.
    absl::StatusOr<Mesh> read = ReadMesh((meshes / "stanford-dragon.ply").string());
    if (!read.ok()) return read.status();
    clean = Decimate(*read, 8000);
    s.what = "stanford-dragon.ply decimated to 8,000 vertices (OpenMesh quadrics)";
  } else {
    std::filesystem::path path = meshes / (name + ".obj");
    if (!std::filesystem::exists(path)) path = meshes / (name + ".ply");
    absl::StatusOr<Mesh> read = ReadMesh(path.string());
    if (!read.ok()) return read.status();
    clean = *std::move(read);
    s.what = path.filename().string();
  }
  // On one thread: the figure the Inputs table gives is the cost of the measure alone.
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  const Clock::time_point t0 = Clock::now();
  s.truth = std::make_unique<GroundTruth>(std::move(clean));
  s.truth_seconds = Seconds(t0, Clock::now());
  omp_set_num_threads(threads);
  return s;
}

double OneThreadEvaluationSeconds(const GroundTruth& truth, const Mesh& mesh) {
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  const Clock::time_point t0 = Clock::now();
  const absl::StatusOr<Quality> q = truth.Evaluate(mesh);
  const double seconds = Seconds(t0, Clock::now());
  omp_set_num_threads(threads);
  return q.ok() ? seconds : std::nan("");
}

Mesh MakeNoisy(const Mesh& clean, const Case& c, uint64_t seed) {
  Mesh m = clean;
  if (c.sigma == 0.0) return m;
  if (c.noise == Noise::kNormal) {
    AddNormalNoise(m, c.sigma, seed);
  } else if (c.noise == Noise::kImpulsive) {
    AddImpulsiveNoise(m, kImpulsiveShare, c.sigma, seed);
  } else {
    AddRandomDirectionNoise(m, c.sigma, seed);
  }
  return m;
}

}  // namespace meshsmooth::bench
