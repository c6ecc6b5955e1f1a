#include "core/measure/normal_turn.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include "core/normals.h"

namespace meshsmooth {
namespace {

// At most this many faces are measured, by the prediction and by the turn (every k-th of a larger
// mesh): the mean angle over them is within about half a percent of the whole mesh's, at a small
// share of an iteration's cost.
constexpr int32_t kMaxMeasuredFaces = 20000;

Vec3 UnitFaceNormal(const Vec3* pos, const Triangle& t) {
  const Vec3 c = Cross(pos[t[1]] - pos[t[0]], pos[t[2]] - pos[t[0]]);
  const double len = Norm(c);
  return len > 0.0 && std::isfinite(len) ? c * (1.0 / len) : Vec3{};
}

double Angle(const Vec3& a, const Vec3& b) { return std::acos(std::clamp(Dot(a, b), -1.0, 1.0)); }

// A standard normal draw from a hash of (i, draw): the same for any thread count or order.
double Gaussian(uint64_t i, uint64_t draw) {
  auto mix = [](uint64_t z) {
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  };
  const uint64_t a = mix(i * 0x9E3779B97F4A7C15ull + draw * 0xD1B54A32D192ED03ull + 1);
  const uint64_t b = mix(a + 0x9E3779B97F4A7C15ull);
  const double u1 = (static_cast<double>(a >> 11) + 0.5) * 0x1.0p-53;
  const double u2 = static_cast<double>(b >> 11) * 0x1.0p-53;
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
}

}  // namespace

double PredictedNormalNoise(const Mesh& mesh, const Topology& topo, double sigma, int draws) {
  const Vec3* pos = mesh.positions.data();
  const auto faces = static_cast<int32_t>(topo.faces.size());
  const int32_t stride = std::max<int32_t>(1, (faces + kMaxMeasuredFaces - 1) / kMaxMeasuredFaces);
  double sum = 0.0;
  int64_t count = 0;
  for (int32_t i = 0; i < faces; i += stride) {
    const Triangle& t = mesh.triangles[topo.faces[i]];
    const Vec3 before = UnitFaceNormal(pos, t);
    std::array<Vec3, 3> normal;
    bool usable = before != Vec3{};
    for (int c = 0; c < 3 && usable; ++c) {
      const Vec3 n = RingNormal(topo, pos, t[c]);
      const double len = Norm(n);
      usable = len > 0.0 && std::isfinite(len);
      if (usable) normal[c] = n * (1.0 / len);
    }
    if (!usable) continue;
    for (int d = 0; d < draws; ++d) {
      std::array<Vec3, 3> moved;
      for (int c = 0; c < 3; ++c) moved[c] = pos[t[c]] + normal[c] * (sigma * Gaussian(t[c], d));
      const Vec3 after = UnitFaceNormal(moved.data(), {0, 1, 2});
      if (after == Vec3{}) continue;
      sum += Angle(before, after);
      ++count;
    }
  }
  return count > 0 ? sum / static_cast<double>(count) : 0.0;
}

NormalTurn::NormalTurn(const Vec3* input, const std::vector<Triangle>& triangles, const Topology& topo)
    : triangles_(triangles) {
  const auto faces = static_cast<int32_t>(topo.faces.size());
  const int32_t stride = std::max<int32_t>(1, (faces + kMaxMeasuredFaces - 1) / kMaxMeasuredFaces);
  for (int32_t i = 0; i < faces; i += stride) {
    const Vec3 n = UnitFaceNormal(input, triangles[topo.faces[i]]);
    if (n == Vec3{}) continue;
    faces_.push_back(topo.faces[i]);
    normal_.push_back(n);
  }
}

double NormalTurn::Of(const Vec3* pos) const {
  double sum = 0.0;
  for (size_t i = 0; i < faces_.size(); ++i) {
    const Vec3 n = UnitFaceNormal(pos, triangles_[faces_[i]]);
    sum += n == Vec3{} ? 0.5 * std::numbers::pi : Angle(n, normal_[i]);
  }
  return faces_.empty() ? 0.0 : sum / static_cast<double>(faces_.size());
}

double NormalVariation(const Vec3* pos, const Topology& topo) {
  double sum = 0.0;
  for (int32_t v = 0; v < topo.num_vertices(); ++v) {
    if (topo.kind[v] != VertexKind::kInterior) continue;
    // Each interior edge once, from its lower end: the faces on either side of (v, w) are
    // (v, prev, w) and (v, w, next) in the ring's order.
    const int32_t first = topo.ring_offsets[v], last = topo.ring_offsets[v + 1];
    for (int32_t k = first; k < last; ++k) {
      const int32_t w = topo.ring[k];
      if (w < v && topo.kind[w] == VertexKind::kInterior) continue;
      const int32_t prev = topo.ring[k == first ? last - 1 : k - 1], next = topo.ring[k + 1 == last ? first : k + 1];
      const Vec3 a = UnitFaceNormal(pos, {v, prev, w}), b = UnitFaceNormal(pos, {v, w, next});
      sum += Norm(pos[w] - pos[v]) * Norm(a - b);
    }
  }
  return sum;
}

}  // namespace meshsmooth
