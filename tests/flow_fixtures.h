// Shared fixtures for the flow tests: the noisy shapes of the paper's claims and the measures.
#pragma once

#include <array>
#include <cmath>
#include <vector>

#include "core/flows/flow.h"
#include "core/measure/metrics.h"
#include "core/shapes/added_noise.h"
#include "core/shapes/parametric.h"
#include "core/topology.h"

namespace meshsmooth::testing {

// Noisy icosphere of the claims: level 4, uniform noise 0.3 x mean edge, seed 1.
inline Mesh NoisySphere(int level = 4, double noise = 0.3, uint64_t seed = 1) {
  Mesh m = Icosphere(level);
  AddUniformNoise(m, noise, seed);
  return m;
}

// Noisy two-rate torus (the paper's Fig. 4); `dense` gets the dense half's vertex count.
inline Mesh NoisyTorus(int32_t* dense = nullptr, double noise = 0.3, uint64_t seed = 1) {
  Mesh m = TwoRateTorus(32, 1.0, 0.25, dense);
  AddUniformNoise(m, noise, seed);
  return m;
}

// An icosphere(3) whose every fifth face f is split into a needle along its first edge and two
// fat triangles by a point `height` of the face's height (default a hundredth) from that edge:
// the needle stays face f, (t0, t1, new point); normal noise folds many needles over, as on raw
// scans. The needle's angles are about 2 height, 2 height and 180 degrees less both.
inline Mesh SphereWithNeedles(double height = 0.01) {
  Mesh m = Icosphere(3);
  const size_t faces = m.triangles.size();
  for (size_t f = 0; f < faces; f += 5) {
    const Triangle t = m.triangles[f];
    const auto p = m.num_vertices();
    const double side = (1.0 - height) / 2;
    m.positions.push_back(m.positions[t[0]] * side + m.positions[t[1]] * side + m.positions[t[2]] * height);
    m.triangles[f] = {t[0], t[1], p};  // the needle along edge t0 t1
    m.triangles.push_back({t[1], t[2], p});
    m.triangles.push_back({t[2], t[0], p});
  }
  return m;
}

// Edge-length CV of the edges inside each sampling-rate part of the two-rate torus (vertices
// [0, dense) and [dense, n)): the regularity within a part, not the designed difference
// between the parts, which no smoothing flow should erase.
inline std::array<double, 2> PartEdgeCv(const Mesh& m, int32_t dense) {
  const Topology t = BuildTopology(m);
  std::vector<double> len[2];
  for (int32_t v = 0; v < t.num_vertices(); ++v) {
    for (int32_t i = t.ring_offsets[v]; i < t.ring_offsets[v + 1]; ++i) {
      const int32_t w = t.ring[i];
      if (v < w && (v < dense) == (w < dense)) len[v < dense ? 0 : 1].push_back(Norm(m.positions[v] - m.positions[w]));
    }
  }
  std::array<double, 2> cv{};
  for (int k = 0; k < 2; ++k) {
    double mean = 0.0, sq = 0.0;
    for (double l : len[k]) mean += l;
    mean /= static_cast<double>(len[k].size());
    for (double l : len[k]) sq += (l - mean) * (l - mean);
    cv[k] = std::sqrt(sq / static_cast<double>(len[k].size())) / mean;
  }
  return cv;
}

// "Radius error": RMS deviation of the vertex radii from their mean (shrinkage does not count).
inline double RadiusError(const Mesh& m) {
  double mean = 0.0;
  for (const Vec3& p : m.positions) mean += Norm(p);
  mean /= static_cast<double>(m.positions.size());
  double sq = 0.0;
  for (const Vec3& p : m.positions) sq += (Norm(p) - mean) * (Norm(p) - mean);
  return std::sqrt(sq / static_cast<double>(m.positions.size()));
}

inline double Volume(const Mesh& m) { return ComputeMetrics(m, BuildTopology(m)).signed_volume; }
inline double EdgeCv(const Mesh& m) { return ComputeMetrics(m, BuildTopology(m)).edge_length_cv; }

inline double RmsDistance(const Mesh& a, const Mesh& b) { return CompareMeshes(a, b)->rms; }

inline Mesh Smoothed(Mesh m, FlowParams p) {
  absl::StatusOr<FlowResult> r = Smooth(m, p);
  if (!r.ok()) std::abort();
  return m;
}

inline FlowParams Params(const std::string& flow, int iterations, std::optional<double> step = std::nullopt) {
  FlowParams p;
  p.flow = ParseFlowName(flow).value();
  p.iterations = iterations;
  p.step = step;
  return p;
}

}  // namespace meshsmooth::testing
