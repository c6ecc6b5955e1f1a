#include "core/shapes/added_noise.h"

#include <cmath>
#include <vector>

#include "core/measure/metrics.h"
#include "core/normals.h"
#include "core/shapes/random.h"
#include "core/topology.h"

namespace meshsmooth {
namespace {

using shapes_internal::SplitMix64;

// Moves each vertex a usable face touches by sigma h N(0, 1) along direction(v), in vertex
// order (one Gaussian, then whatever `direction` draws, per vertex).
template <typename Direction>
void AddGaussianNoise(Mesh& mesh, double sigma_fraction_of_mean_edge, uint64_t seed, Direction&& direction) {
  const Topology topo = BuildTopology(mesh);
  const double sigma = sigma_fraction_of_mean_edge * MeanEdgeLength(mesh, topo);
  SplitMix64 rng(seed);
  for (int32_t v = 0; v < topo.num_vertices(); ++v) {
    if (topo.kind[v] == VertexKind::kIsolated) continue;
    const double distance = sigma * rng.NextGaussian();
    mesh.positions[v] += distance * direction(v, rng);
  }
}

}  // namespace

void AddUniformNoise(Mesh& mesh, double fraction_of_mean_edge, uint64_t seed) {
  const double amplitude = fraction_of_mean_edge * MeanEdgeLength(mesh, BuildTopology(mesh));
  SplitMix64 rng(seed);
  for (Vec3& p : mesh.positions) {
    p.x += amplitude * rng.NextSigned();
    p.y += amplitude * rng.NextSigned();
    p.z += amplitude * rng.NextSigned();
  }
}

void AddNormalNoise(Mesh& mesh, double sigma_fraction_of_mean_edge, uint64_t seed) {
  const std::vector<Vec3> normals = VertexNormals(mesh);
  AddGaussianNoise(mesh, sigma_fraction_of_mean_edge, seed, [&](int32_t v, SplitMix64&) { return normals[v]; });
}

void AddImpulsiveNoise(Mesh& mesh, double share, double scale_fraction_of_mean_edge, uint64_t seed) {
  const std::vector<Vec3> normals = VertexNormals(mesh);
  const Topology topo = BuildTopology(mesh);
  const double scale = scale_fraction_of_mean_edge * MeanEdgeLength(mesh, topo);
  SplitMix64 rng(seed);
  for (int32_t v = 0; v < topo.num_vertices(); ++v) {
    if (topo.kind[v] == VertexKind::kIsolated) continue;
    // Three draws per vertex, whether thrown or not: the same vertices for any share's run.
    const double pick = 0.5 * (rng.NextSigned() + 1.0), size = 0.5 * (rng.NextSigned() + 1.0);
    const double side = rng.NextSigned() < 0.0 ? -1.0 : 1.0;
    if (pick < share) mesh.positions[v] += normals[v] * (side * scale * (1.0 + 2.0 * size));
  }
}

void AddRandomDirectionNoise(Mesh& mesh, double sigma_fraction_of_mean_edge, uint64_t seed) {
  AddGaussianNoise(mesh, sigma_fraction_of_mean_edge, seed,
                   [](int32_t, SplitMix64& rng) { return rng.NextDirection(); });
}

}  // namespace meshsmooth
